// The checkpoint file on disk, through MPI-IO (docs/checkpoint.md, "Writing", "Reading"): every
// call collective over the ranks that write or read it, every failure agreed over them, so that
// all ranks stop with the same message and none hangs.
//
// Writing goes to DIR/name.tmp, which is synced, closed, its size checked, and renamed by rank
// 0 after a barrier: a run killed at any moment leaves the previous complete checkpoint in
// place. Reading is independent I/O at offsets, each rank its own ranges.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <string>

namespace fabrica {

// The message of the lowest rank whose 'error' is not empty ("" if none), on every rank.
std::string agreed(MPI_Comm comm, const std::string& error);

// A checkpoint being written: 'path'.tmp until replace().
class CheckpointOutFile {
 public:
  // Opens path.tmp (collective); throws CollectiveError naming 'path' if it cannot.
  CheckpointOutFile(MPI_Comm comm, std::string path);
  CheckpointOutFile(const CheckpointOutFile&) = delete;
  CheckpointOutFile& operator=(const CheckpointOutFile&) = delete;

  void truncate();
  // Writes 'bytes' at 'offset' (MPI_File_write_at_all: every rank calls it; a rank with
  // 'mine' false writes nothing). A failed or short write (a full disk) throws CollectiveError
  // on every rank, naming 'what', the rank and the error.
  void write_at(std::uint64_t offset, const std::string& bytes, bool mine, const std::string& what);
  // Syncs and closes path.tmp, checks that it holds 'file_bytes', renames it to 'path' and
  // syncs the directory (rank 0). Throws CollectiveError if any of these fails.
  void replace(std::uint64_t file_bytes);
  // After a CollectiveError (which every rank meets alike): closes and removes path.tmp, so
  // that the previous checkpoint stays and the partial file gives its space back.
  void abandon();

 private:
  // Agreed over the ranks: throws CollectiveError on every rank if 'err' failed on any.
  void check(int err, const std::string& what, const std::string& detail = "") const;
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  std::string path_, tmp_;
  MPI_File fh_;
};

// A checkpoint open for reading on every rank of 'comm'.
class CheckpointInFile {
 public:
  // Throws InputError ("PATH: cannot open the checkpoint (...)") on every rank if any cannot.
  CheckpointInFile(MPI_Comm comm, const std::string& path);
  CheckpointInFile(const CheckpointInFile&) = delete;
  CheckpointInFile& operator=(const CheckpointInFile&) = delete;
  ~CheckpointInFile();
  std::uint64_t size() const;
  // Reads n bytes at 'offset' into 'out' (this rank alone, in chunks below 2 GiB); returns ""
  // or what went wrong.
  std::string read_at(std::uint64_t offset, std::uint64_t n, std::string& out) const;

 private:
  MPI_File fh_;
};

}  // namespace fabrica
