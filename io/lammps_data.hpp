// Reader for LAMMPS/LIGGGHTS data files with atom_style sphere, as used by shared/bench:
//   Atoms section:      id type diameter density x y z
//   Velocities section: id vx vy vz wx wy wz      (optional; every atom once if present)
// Velocities become the particles' initial velocity and spin (Fabrica's v is relative to the
// affine field of the deforming cell: for a cell at rest, as in the benchmark, the same thing).
// Any other section (Masses, Bonds, ...) is refused, so nothing in a file is silently ignored.
#pragma once
#include "core/particles.hpp"
#include "io/errors.hpp"

#include <string>

namespace fabrica {

struct DataFile {
  Particles particles;  // ids as in the file
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // box bounds (m)
  bool has_velocities = false;
};

// Throws InputError naming the file, the line and the offending value. Checked: the atom count
// (a whole number >= 1, within the machine's memory), each box axis (present before Atoms, hi >
// lo), ids (kMaxParticleId), diameters (kMinDiameter, kMaxDiameter in io/scene.hpp), densities,
// positions inside the box, every atom once, the count.
DataFile read_lammps_data(const std::string& path);

// Particle ids are whole numbers in [1, 2^53]: exact in a double (Python readers of run.h5) and
// never an internal marker (core/history_map.hpp keys negative ids for walls and the most
// negative one for an empty slot).
constexpr long long kMaxParticleId = 9007199254740992LL;
// 'token' as an id; InputError("<where>: particle id '<token>': must be ...") otherwise.
GlobalId parse_particle_id(const std::string& token, const std::string& where);

}  // namespace fabrica
