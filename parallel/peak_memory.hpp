// The peak resident memory of each rank (Linux: VmHWM of /proc/self/status), gathered over the
// ranks: what a run on a cluster must budget per rank (printed at the end of every run).
#pragma once
#include <mpi.h>

namespace fabrica {

struct PeakMemory {
  double max = 0, mean = 0, min = 0;  // bytes, over the ranks
  int max_rank = 0;                   // a rank with the largest peak
};

// Collective. The peak of this process so far; 0 where /proc is not available.
PeakMemory peak_memory(MPI_Comm comm);
double own_peak_memory();  // bytes, this process

}  // namespace fabrica
