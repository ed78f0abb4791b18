// `fabrica fabric RUN.h5 [--case C] [--step S | --all] [--strong-ratio R] [--bins B] [-o DIR]`:
// the fabric analysis (core/fabric.hpp) of contact snapshots stored in a run file (io/
// snapshot.hpp), written as DIR/<case>/fabric.csv, sff.csv, rose.csv (docs/fabric.md). On
// several ranks every rank reads the snapshot and keeps every P-th contact; the result is the
// same, bit for bit.
#pragma once
#include "parallel/mpi_context.hpp"

#include <cstdint>
#include <optional>
#include <string>

namespace fabrica {

struct FabricOfflineArgs {
  std::string file;                  // RUN.h5
  std::string case_name;             // empty: every case of the file
  std::optional<std::int64_t> step;  // one step; else the last snapshot of each case (or --all)
  bool all = false;                  // every snapshot
  double strong_ratio = 1.0;
  std::int64_t bins = 36;
  std::string outdir;  // empty: <directory of RUN.h5>/fabric
};

int fabric_offline(const MpiContext& mpi, const FabricOfflineArgs& args);

}  // namespace fabrica
