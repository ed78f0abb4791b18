// When a run takes a checkpoint (docs/checkpoint.md: every [run] checkpoint_every steps or
// checkpoint_seconds of wall-clock time, at a neighbour-rebuild step), and the CSV series of a
// restarted run cut back to the checkpoint's step.
#pragma once
#include "core/simulation.hpp"

#include <mpi.h>

#include <cstdint>
#include <string>

namespace fabrica {

// For a restart (rank 0): keeps the header line and the complete rows of the CSV series 'path'
// whose column 'step_column' (0-based) is at most 'step', and drops the others (rows written
// after the checkpoint, or a last row cut short by a kill), so that the restarted run appends
// exactly what the uninterrupted run wrote. Returns false if there is no such file.
bool keep_series_through(const std::string& path, int step_column, std::int64_t step);

// When to take a checkpoint: at the first neighbour-rebuild step after 'every' steps since the
// last one (0 = never by count), or after 'seconds' of wall-clock time (0 = never by time,
// decided by rank 0 and broadcast). Collective at rebuild steps (identical on every rank).
class CheckpointSchedule {
 public:
  CheckpointSchedule(MPI_Comm comm, std::int64_t every, double seconds, std::int64_t step);
  bool due(const Simulation& sim);
  void taken(std::int64_t step);
  void rebase(std::int64_t step) { last_step_ = step; }  // count from here (a new branch)

 private:
  MPI_Comm comm_;
  std::int64_t every_;
  double seconds_;
  std::int64_t last_step_;
  double last_time_;
};

}  // namespace fabrica
