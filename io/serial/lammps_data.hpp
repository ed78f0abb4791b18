// Reader for LAMMPS/LIGGGHTS data files with atom_style sphere, as used by shared/bench:
//   Atoms section:      id type diameter density x y z
//   Velocities section: id vx vy vz wx wy wz      (optional; every atom once if present)
// Velocities become the particles' initial velocity and spin (Fabrica's v is relative to the
// affine field of the deforming cell: for a cell at rest, as in the benchmark, the same thing).
// Any other section (Masses, Bonds, ...) is refused, so nothing in a file is silently ignored.
#pragma once
#include "core/particles.hpp"
#include "core/errors.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace fabrica {

struct DataFile {
  Particles particles;                        // ids as in the file
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // box bounds (m)
  bool has_velocities = false;
};

// Throws InputError naming the file, the line and the offending value. Checked: the atom count
// (a whole number >= 1, within the machine's memory), each box axis (present before Atoms, hi >
// lo), ids (kMaxParticleId), diameters (kMinDiameter, kMaxDiameter in io/serial/scene.hpp), densities,
// positions inside the box, every atom once, the count.
// With 'types' (a scene of [[material]] tables: types[k] the atom type of material k, -1 for
// none), each sphere's material is that of its type, and a type of no material is refused.
DataFile read_lammps_data(const std::string& path, const std::vector<std::int64_t>* types = nullptr);

// The pieces of the reader, shared with the distributed one (io/mpi/distributed_read.cpp), which
// reads the body in byte ranges, one per rank. Each throws InputError as above.
struct DataHeader {
  long long natoms = -1;
  int natoms_line = 0;  // the line of 'N atoms'
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
  std::uint64_t body_offset = 0;  // byte offset of the first section line (the file size if none)
  int body_line = 0;              // its line number (1-based)
};
// Opens 'path' and reads the title and the header up to the first section line: the atom
// count and the three box axes, present and valid.
DataHeader read_data_header(const std::string& path);
enum class DataSection { Atoms, Velocities };
// The section a line starting with 'word' opens (only Atoms and Velocities are read).
DataSection data_section_keyword(const std::string& word, const std::string& path, int lineno);
std::string data_line_body(const std::string& line);  // without its comment
// An Atoms line: the sphere, its position relative to the box's lower corner.
SphereInit parse_atom_line(const std::string& line, const DataHeader& h, const std::string& path, int lineno,
                           const std::vector<std::int64_t>* types = nullptr);
struct DataMotion {
  GlobalId id;
  Vec3 v, w;
};
DataMotion parse_velocity_line(const std::string& line, const std::string& path, int lineno);
// The messages of the whole-file checks.
std::string data_duplicate_id(const std::string& path, int lineno, GlobalId id, bool velocities);
std::string data_count_error(const std::string& path, long long natoms, long long read, bool velocities);
std::string data_orphan_velocity(const std::string& path, int lineno, GlobalId id);

// Particle ids are whole numbers in [1, 2^53]: exact in a double (Python readers of run.h5) and
// never an internal marker (core/history_map.hpp keys negative ids for walls and the most
// negative one for an empty slot).
constexpr long long kMaxParticleId = 9007199254740992LL;
// 'token' as an id; InputError("<where>: particle id '<token>': must be ...") otherwise.
GlobalId parse_particle_id(const std::string& token, const std::string& where);

}  // namespace fabrica
