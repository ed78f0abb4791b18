// A CSV series written by rank 0 and checked on every rank: each write is checked
// (io/serial/write_check.hpp) and the ranks agree on the outcome (parallel/guard.hpp), so that a failed
// write ends every rank. On a restart the rows after the checkpoint's step are dropped (column
// 'step_column' holds the step) and the run appends from there.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace fabrica {

class SeriesFile {
 public:
  // Collective. 'resume_step' >= 0: a restart at that step (the rows through it are kept).
  SeriesFile(MPI_Comm comm, std::string path, const std::string& header, int step_column,
             std::int64_t resume_step = -1);
  std::ostream* stream() { return root_ ? &f_ : nullptr; }  // rank 0's; null elsewhere
  const std::string& path() const { return path_; }
  void check();  // collective: the rows so far written
  void sync();   // collective: the rows so far on disk (before a checkpoint)
  void close();  // collective: synced and closed

 private:
  MPI_Comm comm_;
  bool root_;
  std::string path_;
  std::ofstream f_;
  bool open_ = false;
};

}  // namespace fabrica
