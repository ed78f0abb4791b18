#include "parallel/peak_memory.hpp"

#include <fstream>
#include <string>

namespace fabrica {

double own_peak_memory() {
  std::ifstream in("/proc/self/status");
  std::string key;
  while (in >> key) {
    if (key == "VmHWM:") {
      double kb = 0;
      in >> kb;
      return kb * 1024.0;
    }
    std::getline(in, key);
  }
  return 0;
}

PeakMemory peak_memory(MPI_Comm comm) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const double own = own_peak_memory();
  struct {
    double v;
    int r;
  } mine{own, rank}, top{0, 0};
  MPI_Allreduce(&mine, &top, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm);
  PeakMemory p;
  p.max = top.v;
  p.max_rank = top.r;
  MPI_Allreduce(&own, &p.mean, 1, MPI_DOUBLE, MPI_SUM, comm);
  p.mean /= size;
  MPI_Allreduce(&own, &p.min, 1, MPI_DOUBLE, MPI_MIN, comm);
  return p;
}

}  // namespace fabrica
