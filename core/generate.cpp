#include "core/generate.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace fabrica {

std::vector<real_t> fractal_diameters(std::size_t n, real_t D, real_t d_min, real_t d_max, Random& rng) {
  const real_t a = std::pow(d_min, -D), b = std::pow(d_max, -D);
  std::vector<real_t> d(n);
  for (auto& x : d) x = std::pow(a - rng.uniform() * (a - b), -1.0 / D);
  return d;
}

Particles random_packing(const std::vector<real_t>& diameters, real_t density, const PeriodicCell& cell, Random& rng) {
  const std::size_t n = diameters.size();
  std::vector<Index> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](Index x, Index y) { return diameters[x] > diameters[y]; });
  const real_t dmax = n ? *std::max_element(diameters.begin(), diameters.end()) : 1.0;
  const Vec3& L = cell.lengths();
  int g[3];
  for (int k = 0; k < 3; ++k) g[k] = std::max(1, int(L[k] / dmax));
  const std::size_t nbins = std::size_t(g[0]) * std::size_t(g[1]) * std::size_t(g[2]);
  std::vector<std::vector<Index>> bins(nbins);
  auto bin_of = [&](const Vec3& x, int c[3]) {
    for (int k = 0; k < 3; ++k) c[k] = std::min(g[k] - 1, int(x[k] / L[k] * g[k]));
  };
  std::vector<Vec3> pos(n);
  for (Index a : order) {
    const real_t ra = 0.5 * diameters[a];
    bool placed = false;
    for (int attempt = 0; attempt < 100000 && !placed; ++attempt) {
      const Vec3 x(rng.uniform() * L[0], rng.uniform() * L[1], rng.uniform() * L[2]);
      int c[3];
      bin_of(x, c);
      bool free = true;
      for (int dz = -1; dz <= 1 && free; ++dz)
        for (int dy = -1; dy <= 1 && free; ++dy)
          for (int dx = -1; dx <= 1 && free; ++dx) {
            const int b =
                (c[0] + dx + g[0]) % g[0] + g[0] * ((c[1] + dy + g[1]) % g[1] + g[1] * ((c[2] + dz + g[2]) % g[2]));
            for (Index o : bins[b]) {
              const real_t s = ra + 0.5 * diameters[o];
              if (cell.minimum_image(pos[o] - x).squaredNorm() < s * s) {
                free = false;
                break;
              }
            }
          }
      if (free) {
        pos[a] = x;
        bins[c[0] + g[0] * (c[1] + g[1] * c[2])].push_back(a);
        placed = true;
      }
    }
    if (!placed)
      throw std::runtime_error("random packing: no room for sphere " + std::to_string(a) + " of diameter " +
                               std::to_string(diameters[a]) + " m; enlarge the initial cell");
  }
  Particles p;
  p.reserve(n);
  for (std::size_t a = 0; a < n; ++a) p.add({GlobalId(a), 0.5 * diameters[a], density, pos[a]});
  return p;
}

Particles simple_cubic(int n, real_t R, real_t a, real_t density) {
  Particles p;
  p.reserve(std::size_t(n) * n * n);
  GlobalId id = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) p.add({id++, R, density, Vec3((i + 0.5) * a, (j + 0.5) * a, (k + 0.5) * a)});
  return p;
}

}  // namespace fabrica
