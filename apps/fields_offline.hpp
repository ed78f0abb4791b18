// `fabrica fields RUN.h5 [--case C] [--step S | --all] [--spacing H | --cells NX NY NZ]
// [--kernel gaussian|lucy] [--width W] [--cutoff C] [--density RHO] [--strong-ratio R] [-o FILE]`:
// the coarse-grained fields (core/coarse_grain.hpp) of particle and contact snapshots stored in a
// run file (io/mpi/snapshot.hpp), written to the HDF5 file FILE (default <directory of RUN.h5>/
// fields.h5), group /fields/<case>/<step>, with the XDMF sidecars FILE with .xmf (every case) and
// <stem>_<case>.xmf (docs/fields.md).
// On several ranks every rank reads the snapshot and keeps every P-th particle and contact; the
// fields are the same, bit for bit.
#pragma once
#include "parallel/mpi_context.hpp"

#include <array>
#include <cstdint>
#include <optional>
#include <string>

namespace fabrica {

struct FieldsOfflineArgs {
  std::string file;                  // RUN.h5
  std::string case_name;             // empty: every case of the file
  std::optional<std::int64_t> step;  // one step; else the last snapshot of each case (or --all)
  bool all = false;                  // every snapshot
  std::optional<double> spacing;     // m; the grid's target spacing (cells = round(L / H))
  std::optional<std::array<int, 3>> cells;
  std::string kernel = "gaussian";
  std::optional<double> width;    // m; default: the mean diameter (gaussian), 3 mean diameters (lucy)
  double cutoff = 3;              // gaussian: support radius in widths
  std::optional<double> density;  // kg/m^3; default: the run's scene
  double strong_ratio = 1.0;
  std::string output;  // empty: <directory of RUN.h5>/fields.h5
};

int fields_offline(const MpiContext& mpi, const FieldsOfflineArgs& args);

}  // namespace fabrica
