// RAII ownership of MPI for one executable: MPI_Init in the constructor, MPI_Finalize in the
// destructor. Passed explicitly (no singleton); everything else takes an MPI_Comm.
#pragma once
#include "core/heap_policy.hpp"

#include <mpi.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace fabrica {

class MpiContext {
 public:
  MpiContext(int& argc, char**& argv) {
    map_large_blocks();  // resident memory that follows the heap in use (core/heap_policy.hpp)
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      // Open MPI's shared-file-pointer component "sm" keeps a named semaphore per file basename
      // (/dev/shm/sem.OMPIO_<name>), machine-wide and never released by a killed process: after
      // one job is killed inside MPI_File_open, every later job on that node that opens a file
      // of the same name (checkpoint.ckpt.tmp) waits on it for ever. Fabrica never uses shared
      // file pointers, so the component is excluded unless the user chose a sharedfp setting.
      setenv("OMPI_MCA_sharedfp", "^sm", /*overwrite=*/0);
      MPI_Init(&argc, &argv);
      owner_ = true;
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  // The ranks of 'comm' (a group of the run's ranks, apps/ensemble.hpp), MPI already running:
  // neither initialises nor finalises it, nor frees 'comm'.
  explicit MpiContext(MPI_Comm comm) : comm_(comm) {
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
  ~MpiContext() {
    if (owner_) MPI_Finalize();
  }
  MpiContext(const MpiContext&) = delete;
  MpiContext& operator=(const MpiContext&) = delete;

  MPI_Comm comm() const { return comm_; }
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  bool owner_ = false;
  MPI_Comm comm_ = MPI_COMM_WORLD;
  int rank_ = 0, size_ = 1;
};

// An error that every rank detects identically (e.g. from reduced values): the run ends on every
// rank with one message, printed by rank 0, without MPI_Abort.
class CollectiveError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A collective error for a numerical blow-up (diagnose() in core/measures.hpp): the executable
// saves the state at detection (OUT/blowup.ckpt) before it ends the run.
class BlowUpError : public CollectiveError {
 public:
  using CollectiveError::CollectiveError;
};

}  // namespace fabrica
