#include "io/serial/memory_check.hpp"

#include "core/errors.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace fabrica {
namespace {
std::string gb(double bytes) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3g GB", bytes / 1e9);
  return b;
}
}  // namespace

double machine_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 0.0;
}

void check_memory(const std::string& what, double bytes, const std::string& why) {
  const double have = machine_memory_bytes();
  if (have > 0 && bytes > have)
    throw InputError(what + ": needs at least " + gb(bytes) + " of memory (" + why + "), the machine has " + gb(have));
}

void check_specimen_memory(const std::string& what, std::int64_t spheres, int ranks, int node) {
  const double bytes = double(spheres) * kBytesPerSphere / ranks * node;
  if (ranks == 1) check_memory(what, bytes, "200 B per sphere at least");
  else
    check_memory(what, bytes,
                 "200 B per sphere at least, " + std::to_string(spheres / ranks) + " spheres on each of " +
                     std::to_string(node) + " rank(s) of this node");
}

void check_neighbour_grid(const std::string& what, const Vec3& L, real_t rmin, real_t skin) {
  const double edge = 2 * rmin + skin;
  double cells = 1;
  for (int k = 0; k < 3; ++k) cells *= std::max(1.0, std::floor(L[k] / edge));
  char b[160];
  std::snprintf(b, sizeof b, "a neighbour grid of %.3g cells of %.3g m for a cell of %.3g x %.3g x %.3g m", cells, edge,
                L[0], L[1], L[2]);
  if (!(cells < 2147483648.0))
    throw InputError(what + ": " + b + " (more than 2^31 cells): the box is far larger than its spheres");
  check_memory(what, cells * 16, b);
}

}  // namespace fabrica
