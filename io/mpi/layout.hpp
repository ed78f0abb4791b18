// Names shared by the writer (io/mpi/run_output) and the reader (io/mpi/snapshot) of OUT/run.h5;
// the layout itself is described in docs/output.md.
#pragma once
#include <cstdint>
#include <cstdio>
#include <string>

namespace fabrica::layout {

inline constexpr const char* kVersionAttr = "fabrica_version";  // marks a Fabrica file
inline constexpr const char* kFormat = "fabrica-run-1";
inline constexpr int kStepDigits = 12;
// A snapshot group's attribute: the cell matrix H, 9 doubles row by row (its columns the edge
// vectors; diag(cell_lengths) for an orthorhombic cell; absent in files written before it).
inline constexpr const char* kCellMatrix = "cell_matrix";
// 0, 1, 2, ... (int64, at least as long as the largest snapshot): the vertex connectivity that
// run.xmf takes a hyperslab of, so that ParaView makes one vertex cell per particle.
inline constexpr const char* kVertexIndex = "xdmf/vertices";

// The name of a snapshot group: the step, zero-padded so that name order is step order.
inline std::string step_name(std::int64_t step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%0*lld", kStepDigits, static_cast<long long>(step));
  return buf;
}

inline std::string snapshot_path(const std::string& case_name, std::int64_t step) {
  return "snapshots/" + case_name + "/" + step_name(step);
}

}  // namespace fabrica::layout
