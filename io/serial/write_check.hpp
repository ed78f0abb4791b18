// Checked writes. Every file Fabrica writes goes through one of these, so that a full disk, a
// file-size limit, a read-only or missing directory, or a directory where a file should be, ends
// the run with a WriteError naming the file and the cause (strerror), instead of output silently
// lost. Files written whole (run.xmf, the trimmed series of a restart, summary.csv, the offline
// fabric files) go to PATH.tmp, are checked and synced, then renamed over PATH: the earlier
// version stays intact until the new one is complete. Streams that grow (series.csv, the fabric
// files of a run) are checked at every flush; what was written before stays as it was.
#pragma once
#include <fstream>
#include <ios>
#include <stdexcept>
#include <string>

namespace fabrica {

class WriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "<path>: cannot <what>: <strerror(err)>".
[[noreturn]] void throw_write_error(const std::string& path, const std::string& what, int err);

// Opens 'f' on 'path' for writing ('mode' adds to std::ios::out); throws if it cannot be opened.
void open_checked(std::ofstream& f, const std::string& path, std::ios::openmode mode = std::ios::trunc);
// Flushes 's' (written to 'path') and throws if any write so far failed. Site "csv" of
// FABRICA_FAULT_INJECT (core/fault.hpp) makes it fail.
void check_stream(std::ostream& s, const std::string& path);
// check_stream, then the file's data to the disk (fsync).
void sync_stream(std::ofstream& f, const std::string& path);
// sync_stream and close.
void close_checked(std::ofstream& f, const std::string& path);

// Throws a WriteError (ENOSPC or EFBIG) if 'path' (existing or not) cannot grow by 'bytes': the
// free space of its file system, or the process's file-size limit (ulimit -f). For files written
// in place (run.h5), where a write that fails part-way would leave the file unreadable.
void check_room(const std::string& path, double bytes);

// Creates the directory 'dir' (and its parents) if missing; throws a WriteError naming it and
// the cause if it cannot, or if it is not a writable directory.
void make_output_directory(const std::string& dir);

// Writes 'text' to path.tmp, syncs it, renames it over 'path' and syncs the directory. 'site'
// names the FABRICA_FAULT_INJECT site that makes it fail (core/fault.hpp).
void write_file_atomic(const std::string& path, const std::string& text, const char* site = "csv");
// Renames 'tmp' (a complete, synced file) over 'path' and syncs the directory.
void replace_file(const std::string& tmp, const std::string& path);

}  // namespace fabrica
