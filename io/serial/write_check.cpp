#include "io/serial/write_check.hpp"

#include "core/fault.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <unistd.h>
#include <sys/resource.h>
#include <sys/statvfs.h>

#include <cmath>

namespace fabrica {
namespace {

void fsync_file(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), O_RDONLY | (directory ? O_DIRECTORY : 0));
  if (fd < 0) throw_write_error(path, directory ? "open the directory to sync it" : "open to sync", errno);
  const int rc = ::fsync(fd), err = errno;
  ::close(fd);
  // A directory that cannot be synced (some file systems) keeps its entries anyway.
  if (rc != 0 && !(directory && (err == EINVAL || err == EROFS))) throw_write_error(path, "sync", err);
}

std::string dir_of(const std::string& path) {
  const std::string d = std::filesystem::path(path).parent_path().string();
  return d.empty() ? "." : d;
}

}  // namespace

void throw_write_error(const std::string& path, const std::string& what, int err) {
  throw WriteError(path + ": cannot " + what + ": " + (err ? std::strerror(err) : "unknown error"));
}

void open_checked(std::ofstream& f, const std::string& path, std::ios::openmode mode) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw WriteError(path + ": cannot create the file: it is a directory");
  errno = 0;
  f.open(path, std::ios::out | mode);
  if (!f) throw_write_error(path, "create the file", errno);
}

void check_stream(std::ostream& s, const std::string& path) {
  if (fault_injected("csv")) throw WriteError(path + ": cannot write: " + fault_text("csv"));
  errno = 0;
  s.flush();
  if (!s) throw_write_error(path, "write", errno ? errno : EIO);
}

void sync_stream(std::ofstream& f, const std::string& path) {
  check_stream(f, path);
  fsync_file(path, false);
}

void close_checked(std::ofstream& f, const std::string& path) {
  if (!f.is_open()) return;
  sync_stream(f, path);
  errno = 0;
  f.close();
  if (f.fail()) throw_write_error(path, "close", errno ? errno : EIO);
}

void check_room(const std::string& path, double bytes) {
  std::error_code ec;
  const double size = std::filesystem::exists(path, ec) ? double(std::filesystem::file_size(path, ec)) : 0;
  struct rlimit lim {};
  if (::getrlimit(RLIMIT_FSIZE, &lim) == 0 && lim.rlim_cur != RLIM_INFINITY && size + bytes > double(lim.rlim_cur))
    throw WriteError(path + ": cannot grow by " + std::to_string(std::llround(bytes)) + " bytes to " +
                     std::to_string(std::llround(size + bytes)) + ": the file-size limit (ulimit -f) is " +
                     std::to_string(lim.rlim_cur) + " bytes (" + std::strerror(EFBIG) + ")");
  struct statvfs fs {};
  if (::statvfs(dir_of(path).c_str(), &fs) == 0) {
    const double free = double(fs.f_bavail) * double(fs.f_frsize);
    if (bytes > free)
      throw WriteError(path + ": cannot grow by " + std::to_string(std::llround(bytes)) +
                       " bytes: " + std::to_string(std::llround(free)) + " bytes free on its file system (" +
                       std::strerror(ENOSPC) + ")");
  }
}

void make_output_directory(const std::string& dir) {
  std::error_code ec;
  // A dangling symbolic link: create_directories would say only "File exists".
  if (std::filesystem::is_symlink(dir, ec) && !std::filesystem::exists(dir, ec))
    throw WriteError(dir + ": cannot create the output directory: it is a symbolic link to " +
                     std::filesystem::read_symlink(dir, ec).string() + ", which does not exist (a dangling link)");
  std::filesystem::create_directories(dir, ec);
  if (ec) throw WriteError(dir + ": cannot create the output directory: " + ec.message());
  if (!std::filesystem::is_directory(dir, ec))
    throw WriteError(dir + ": cannot write the output there: not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0) throw_write_error(dir, "write the output there", errno);
}

void replace_file(const std::string& tmp, const std::string& path) {
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw_write_error(path, "replace it by " + tmp, err);
  }
  fsync_file(dir_of(path), true);
}

void write_file_atomic(const std::string& path, const std::string& text, const char* site) {
  const std::string tmp = path + ".tmp";
  if (fault_injected(site)) throw WriteError(tmp + ": cannot write: " + fault_text(site));
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) throw_write_error(tmp, "create the file", errno);
  auto fail = [&](const std::string& what, int err) {
    ::close(fd);
    std::remove(tmp.c_str());
    throw_write_error(tmp, what, err);
  };
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail("write", errno);
    if (n == 0) fail("write", EIO);
    done += std::size_t(n);
  }
  if (::fsync(fd) != 0) fail("sync", errno);
  if (::close(fd) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw_write_error(tmp, "close", err);
  }
  replace_file(tmp, path);
}

}  // namespace fabrica
