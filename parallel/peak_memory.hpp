// The peak resident memory of each rank (Linux: VmHWM of /proc/self/status), gathered over the
// ranks: what a run on a cluster must budget per rank (printed at the end of every run).
//
// A rank's peak counts the pages of the shared libraries it maps (Open MPI, HDF5, the C++
// runtime: about 17-19 MB here, 11 MB for a bare MPI program), which every process of a node
// maps from the same files and which the node holds once. The private peak is the peak less
// the file-backed and shared pages resident when it is read (RssFile + RssShmem, which are
// mapped at start-up and stay): the memory the run's data took, the figure that falls with the
// rank count. The ghost count is the largest this rank held (noted by the MPI domain at each
// ghost build) with its owned count then, so that the ghosts' share of a peak can be told.
#pragma once
#include <mpi.h>

#include <cstddef>
#include <cstdint>

namespace fabrica {

struct PeakMemory {
  double max = 0, mean = 0, min = 0;         // bytes, over the ranks
  int max_rank = 0;                          // a rank with the largest peak
  double private_max = 0, private_mean = 0;  // bytes: peak less shared and file-backed pages
  int private_max_rank = 0;
  double shared_max = 0;                 // bytes: those pages, the largest rank
  std::int64_t ghosts_max = 0;           // the most ghosts a rank held at once
  std::int64_t owned_at_ghosts_max = 0;  // that rank's owned particles then
};

// Collective. The peak of this process so far; 0 where /proc is not available.
PeakMemory peak_memory(MPI_Comm comm);
double own_peak_memory();  // bytes, this process

// Called at each ghost build: keeps the largest ghost count of this process (and its owned
// count then) for peak_memory.
void note_ghosts(std::size_t ghosts, std::size_t owned);

}  // namespace fabrica
