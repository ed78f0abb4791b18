#include "io/mpi/checkpoint_file.hpp"

#include "core/errors.hpp"
#include "core/fault.hpp"
#include "parallel/mpi_context.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace fabrica {
namespace {

constexpr std::uint64_t kChunk = std::uint64_t(1) << 30;  // bytes per MPI-IO call at most

std::string mpi_error_text(int err) {
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(err, text, &len);
  return std::string(text, std::size_t(len));
}

// The rank and size of 'comm'.
std::pair<int, int> where_in(MPI_Comm comm) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  return {rank, size};
}

// Syncs the directory entry of 'path' (after a rename).
void sync_directory_of(const std::string& path) {
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = ".";
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

}  // namespace

std::string agreed(MPI_Comm comm, const std::string& error) {
  const auto [rank, size] = where_in(comm);
  int first = error.empty() ? size : rank;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return "";
  std::string msg = error;
  int len = int(msg.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  msg.resize(std::size_t(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, first, comm);
  return msg;
}

// ---------------------------------------------------------------------------------- writing

CheckpointOutFile::CheckpointOutFile(MPI_Comm comm, std::string path)
    : comm_(comm), path_(std::move(path)), tmp_(path_ + ".tmp") {
  std::tie(rank_, size_) = where_in(comm_);
  check(MPI_File_open(comm_, tmp_.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &fh_), "open " + tmp_);
  MPI_File_set_errhandler(fh_, MPI_ERRORS_RETURN);
}

void CheckpointOutFile::check(int err, const std::string& what, const std::string& detail) const {
  std::string msg;
  if (err != MPI_SUCCESS) {
    msg = what + ": " + mpi_error_text(err) + detail;
    if (size_ > 1) msg += " on rank " + std::to_string(rank_);
  }
  msg = agreed(comm_, msg);
  if (!msg.empty())
    throw CollectiveError(path_ + ": cannot write the checkpoint (" + msg +
                          "); the previous checkpoint, if any, is kept");
}

void CheckpointOutFile::truncate() { check(MPI_File_set_size(fh_, 0), "truncate " + tmp_); }

void CheckpointOutFile::write_at(std::uint64_t offset, const std::string& bytes, bool mine, const std::string& what) {
  const std::string& b = mine ? bytes : std::string();
  if (b.size() > std::size_t(std::numeric_limits<int>::max()))
    throw std::runtime_error(path_ + ": a checkpoint block above 2 GiB on one rank");
  MPI_Status st;
  int err = MPI_File_write_at_all(fh_, MPI_Offset(offset), b.data(), int(b.size()), MPI_BYTE, &st);
  // A write can succeed short (a full disk, a file-size limit): the count must be the size.
  int count = 0;
  if (err == MPI_SUCCESS) MPI_Get_count(&st, MPI_BYTE, &count);
  std::string detail;
  if (err == MPI_SUCCESS && (count != int(b.size()) || fault_injected("ckpt_write"))) {
    err = MPI_ERR_IO;
    detail = fault_injected("ckpt_write")
        ? " (" + fault_text("ckpt_write") + ")"
        : " (" + std::to_string(count) + " of " + std::to_string(b.size()) + " bytes written: is the disk full?)";
  }
  check(err, "write " + what + " to " + tmp_, detail);
}

void CheckpointOutFile::abandon() {
  MPI_File_close(&fh_);
  if (rank_ == 0) std::remove(tmp_.c_str());  // the partial file gives its space back
}

void CheckpointOutFile::replace(std::uint64_t file_bytes) {
  try {
    check(MPI_File_sync(fh_), "sync " + tmp_);
  } catch (const CollectiveError&) {
    abandon();
    throw;
  }
  check(MPI_File_close(&fh_), "close " + tmp_);
  // The complete file is on disk before it replaces the previous checkpoint: rank 0 checks the
  // size of the temporary, and every rank learns the outcome.
  int short_file = 0;
  std::uint64_t on_disk = 0;
  if (rank_ == 0) {
    std::error_code ec;
    on_disk = std::filesystem::file_size(tmp_, ec);
    short_file = ec || on_disk != file_bytes;
  }
  MPI_Bcast(&short_file, 1, MPI_INT, 0, comm_);
  if (short_file && rank_ == 0) std::remove(tmp_.c_str());
  if (short_file)
    check(rank_ == 0 ? MPI_ERR_IO : MPI_SUCCESS, "check " + tmp_,
          " (" + std::to_string(on_disk) + " bytes on disk, " + std::to_string(file_bytes) + " written)");
  // Rank 0 replaces the previous checkpoint (atomic rename) and syncs the directory entry.
  int err = 0;
  if (rank_ == 0) {
    err = std::rename(tmp_.c_str(), path_.c_str()) != 0 ? errno : 0;
    if (!err) sync_directory_of(path_);
  }
  MPI_Bcast(&err, 1, MPI_INT, 0, comm_);
  if (err) throw CollectiveError(path_ + ": cannot rename " + tmp_ + " to it (" + std::strerror(err) + ")");
}

// ---------------------------------------------------------------------------------- reading

CheckpointInFile::CheckpointInFile(MPI_Comm comm, const std::string& path) {
  auto fail = [&](const std::string& error) {
    if (const std::string e = agreed(comm, error); !e.empty()) throw InputError(path + ": " + e);
  };
  std::string error;
  if (fault_injected("checkpoint")) error = "cannot read the checkpoint (" + fault_text("checkpoint") + ")";
  else if (std::error_code ec; std::filesystem::is_directory(path, ec))
    error = "cannot open the checkpoint (it is a directory)";
  else if (::access(path.c_str(), R_OK) != 0)
    error = "cannot open the checkpoint (" + std::string(std::strerror(errno)) + ")";
  fail(error);
  const int err = MPI_File_open(comm, path.c_str(), MPI_MODE_RDONLY, MPI_INFO_NULL, &fh_);
  if (err != MPI_SUCCESS) error = "cannot open the checkpoint (" + mpi_error_text(err) + ")";
  try {
    fail(error);
  } catch (...) {
    if (err == MPI_SUCCESS) MPI_File_close(&fh_);
    throw;
  }
  MPI_File_set_errhandler(fh_, MPI_ERRORS_RETURN);
}

CheckpointInFile::~CheckpointInFile() { MPI_File_close(&fh_); }

std::uint64_t CheckpointInFile::size() const {
  MPI_Offset on_disk = 0;
  MPI_File_get_size(fh_, &on_disk);
  return std::uint64_t(on_disk);
}

std::string CheckpointInFile::read_at(std::uint64_t offset, std::uint64_t n, std::string& out) const {
  out.resize(std::size_t(n));
  for (std::uint64_t k = 0; k < n; k += kChunk) {
    const std::uint64_t len = std::min(n - k, kChunk);
    MPI_Status st;
    const int err = MPI_File_read_at(fh_, MPI_Offset(offset + k), out.data() + k, int(len), MPI_BYTE, &st);
    int count = 0;
    if (err == MPI_SUCCESS) MPI_Get_count(&st, MPI_BYTE, &count);
    if (err != MPI_SUCCESS || std::uint64_t(count) != len)
      return "cannot read " + std::to_string(len) + " bytes at offset " + std::to_string(offset + k) +
          (err != MPI_SUCCESS ? " (" + mpi_error_text(err) + ")" : " (" + std::to_string(count) + " read)");
  }
  return "";
}

}  // namespace fabrica
