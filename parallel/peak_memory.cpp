#include "parallel/peak_memory.hpp"

#include <fstream>
#include <string>

namespace fabrica {
namespace {

struct StatusMemory {
  double hwm = 0, shared = 0;  // bytes
};

// VmHWM, and RssFile + RssShmem, of /proc/self/status (zeros where it is missing).
StatusMemory read_status() {
  std::ifstream in("/proc/self/status");
  StatusMemory s;
  std::string key;
  while (in >> key) {
    double kb = 0;
    if (key == "VmHWM:") {
      in >> kb;
      s.hwm = kb * 1024.0;
    } else if (key == "RssFile:" || key == "RssShmem:") {
      in >> kb;
      s.shared += kb * 1024.0;
    }
    std::getline(in, key);
  }
  return s;
}

std::int64_t g_ghosts_max = 0, g_owned_at_ghosts_max = 0;

struct ValueRank {
  double v;
  int r;
};

ValueRank max_loc(MPI_Comm comm, double v, int rank) {
  ValueRank mine{v, rank}, top{0, 0};
  MPI_Allreduce(&mine, &top, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm);
  return top;
}

double sum(MPI_Comm comm, double v) {
  double s = 0;
  MPI_Allreduce(&v, &s, 1, MPI_DOUBLE, MPI_SUM, comm);
  return s;
}

}  // namespace

double own_peak_memory() { return read_status().hwm; }

void note_ghosts(std::size_t ghosts, std::size_t owned) {
  if (std::int64_t(ghosts) <= g_ghosts_max) return;
  g_ghosts_max = std::int64_t(ghosts);
  g_owned_at_ghosts_max = std::int64_t(owned);
}

PeakMemory peak_memory(MPI_Comm comm) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const StatusMemory own = read_status();
  const double priv = own.hwm > own.shared ? own.hwm - own.shared : 0.0;
  PeakMemory p;
  const ValueRank top = max_loc(comm, own.hwm, rank);
  p.max = top.v;
  p.max_rank = top.r;
  p.mean = sum(comm, own.hwm) / size;
  MPI_Allreduce(&own.hwm, &p.min, 1, MPI_DOUBLE, MPI_MIN, comm);
  const ValueRank top_private = max_loc(comm, priv, rank);
  p.private_max = top_private.v;
  p.private_max_rank = top_private.r;
  p.private_mean = sum(comm, priv) / size;
  MPI_Allreduce(&own.shared, &p.shared_max, 1, MPI_DOUBLE, MPI_MAX, comm);
  // The rank with the most ghosts, and its owned count then.
  const ValueRank top_ghosts = max_loc(comm, double(g_ghosts_max), rank);
  std::int64_t g[2] = {rank == top_ghosts.r ? g_ghosts_max : 0, rank == top_ghosts.r ? g_owned_at_ghosts_max : 0};
  MPI_Allreduce(MPI_IN_PLACE, g, 2, MPI_INT64_T, MPI_SUM, comm);
  p.ghosts_max = g[0];
  p.owned_at_ghosts_max = g[1];
  return p;
}

}  // namespace fabrica
