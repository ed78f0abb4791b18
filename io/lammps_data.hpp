// Reader for LAMMPS/LIGGGHTS data files with atom_style sphere
// (Atoms section columns: id type diameter density x y z), as used by shared/bench.
#pragma once
#include "core/particles.hpp"
#include "io/errors.hpp"

#include <string>

namespace fabrica {

struct DataFile {
  Particles particles;  // ids as in the file
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // box bounds (m)
};

// Throws InputError naming the file, the line and the offending value.
DataFile read_lammps_data(const std::string& path);

}  // namespace fabrica
