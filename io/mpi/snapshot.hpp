// Reading a run's output file OUT/run.h5 (written by io/mpi/run_output.hpp; layout in
// docs/output.md). Serial and independent of MPI: usable from the CLI, tests and offline
// analyses. Every function opens the file, reads and closes it again; a missing, truncated or
// foreign file (not HDF5, or HDF5 without Fabrica's version attribute) and a missing case or
// step throw InputError naming the file and the object.
#pragma once
#include "core/contact_snapshot.hpp"
#include "core/types.hpp"
#include "core/errors.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace fabrica {

namespace h5 {
class Object;
}

// Whether a cell matrix has an off-diagonal term: a sheared cell's (an orthorhombic cell's
// matrix is diagonal).
bool matrix_sheared(const Mat3& h);
// The cell matrix H row by row, as the attribute cell_matrix holds it.
std::array<double, 9> matrix_rows(const Mat3& h);

// The attributes of one snapshot group /snapshots/<case>/<step>.
struct SnapshotInfo {
  std::string case_name;
  std::int64_t step = 0;
  real_t time = 0;                   // s
  Vec3 cell_lengths = Vec3::Zero();  // m (of a sheared cell: the diagonal of its matrix)
  // m: the cell matrix H, its columns the edge vectors (a point of fractional coordinates s is
  // H s); diag(cell_lengths) for an orthorhombic cell, and in files written before the attribute.
  Mat3 cell_matrix = Mat3::Zero();
  Vec3 strain = Vec3::Zero();  // eps_i = ln(l_i0 / l_i), compression positive
  std::int64_t particles = 0, contacts = 0;
  bool sheared() const { return matrix_sheared(cell_matrix); }
  // m^3: L1 L2 L3 (orthorhombic, as before sheared cells), |det H| (sheared).
  real_t volume() const {
    return sheared() ? std::abs(cell_matrix.determinant()) : cell_lengths[0] * cell_lengths[1] * cell_lengths[2];
  }
};

// The cell matrix of a snapshot group: its attribute cell_matrix (9 values, row by row), or
// diag(cell_lengths) without it (a file written before it). Throws h5::Error for a malformed one.
Mat3 snapshot_cell_matrix(const h5::Object& group);

struct ContactSnapshot {
  SnapshotInfo info;
  std::vector<ContactRecord> contacts;  // every contact once, in (id1, id2) order; a wall
                                        // contact has id2 = -1 - wall index (docs/output.md)
};

struct ParticleSnapshot {
  SnapshotInfo info;
  std::vector<GlobalId> id;            // increasing
  std::vector<Vec3> position;          // m
  std::vector<Vec3> velocity;          // m/s
  std::vector<Vec3> spin;              // rad/s
  std::vector<real_t> radius;          // m
  std::vector<std::uint8_t> material;  // the index of its [[material]] (0 in files without it)
};

// One series table /series/<case>: a column per quantity, as in the CSV series.
struct Series {
  std::vector<std::string> columns;         // names, in CSV order (without stage and step)
  std::vector<std::vector<double>> values;  // values[c][row]
  std::vector<std::int64_t> step;
  std::vector<std::string> stage;  // per row; empty if the table has no stage column
  std::size_t rows() const { return step.size(); }
  const std::vector<double>& column(const std::string& name) const;  // throws if absent
};

// Fabrica's version attributes and the scene of a run file.
struct RunFileInfo {
  std::string version, git_describe, scene_path, scene_text;
  std::int64_t ranks = 0;  // MPI ranks that wrote the file
};

RunFileInfo read_run_info(const std::string& path);
// Every snapshot of the file, by case (in name order), then step.
std::vector<SnapshotInfo> list_snapshots(const std::string& path);
std::vector<std::string> list_series(const std::string& path);  // case names with a series
ContactSnapshot read_contact_snapshot(const std::string& path, const std::string& case_name, std::int64_t step);
ParticleSnapshot read_particle_snapshot(const std::string& path, const std::string& case_name, std::int64_t step);
Series read_series(const std::string& path, const std::string& case_name);

}  // namespace fabrica
