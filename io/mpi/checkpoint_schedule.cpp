#include "io/mpi/checkpoint_schedule.hpp"

#include "io/serial/write_check.hpp"

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace fabrica {

bool keep_series_through(const std::string& path, int step_column, std::int64_t step) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream all;
  all << in.rdbuf();
  const std::string text = all.str();
  std::string kept;
  std::size_t pos = 0;
  for (bool header = true; pos < text.size(); header = false) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) break;  // cut short: dropped
    const std::string line = text.substr(pos, end + 1 - pos);
    pos = end + 1;
    if (!header) {
      std::size_t at = 0;
      for (int c = 0; c < step_column && at != std::string::npos; ++c) {
        at = line.find(',', at);
        if (at != std::string::npos) ++at;
      }
      if (at == std::string::npos) continue;
      char* stop = nullptr;
      const long long s = std::strtoll(line.c_str() + at, &stop, 10);
      if (stop == line.c_str() + at || s > step) continue;
    }
    kept += line;
  }
  write_file_atomic(path, kept);  // path.tmp, checked, synced, renamed (io/serial/write_check.hpp)
  return true;
}

// ------------------------------------------------------------------------------- scheduling

namespace {
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

CheckpointSchedule::CheckpointSchedule(MPI_Comm comm, std::int64_t every, double seconds, std::int64_t step)
    : comm_(comm), every_(every), seconds_(seconds), last_step_(step), last_time_(wall_seconds()) {}

bool CheckpointSchedule::due(const Simulation& sim) {
  if (!sim.rebuilt_last_step()) return false;  // identical on every rank
  if (every_ > 0 && sim.step_count() - last_step_ >= every_) return true;
  if (seconds_ <= 0) return false;
  int now = wall_seconds() - last_time_ >= seconds_;  // rank 0 decides for all
  MPI_Bcast(&now, 1, MPI_INT, 0, comm_);
  return now != 0;
}

void CheckpointSchedule::taken(std::int64_t step) {
  last_step_ = step;
  last_time_ = wall_seconds();
}

}  // namespace fabrica
