// The directory a test process writes its scratch files in: made on first use under the
// system's temporary directory, named by the process id (ctest runs tests of one executable as
// concurrent processes), and removed with everything in it when the process ends normally, so
// that a run of the suite leaves nothing behind there.
#pragma once
#include <filesystem>
#include <string>
#include <system_error>

#include <unistd.h>

namespace fabrica::test {

inline const std::filesystem::path& temp_dir() {
  struct Dir {
    std::filesystem::path path;
    Dir() : path(std::filesystem::temp_directory_path() / ("fabrica-test-" + std::to_string(::getpid()))) {
      std::filesystem::create_directories(path);
    }
    ~Dir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

}  // namespace fabrica::test
