#include "core/region_packing.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace fabrica {

namespace {
std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
  Random r(a ^ (b * 0xD1B54A32D192ED03ull + 0x8CB92BA72F3D8DD7ull));
  r.next();
  return r.next();
}
}  // namespace

real_t expected_solid_volume(const RegionSpec& s) {
  // d = (a - u (a - b))^(-1/D), u uniform: E[d^3] = (a^(1-3/D) - b^(1-3/D)) / ((1 - 3/D)(a - b)).
  const real_t a = std::pow(s.d_min, -s.D), b = std::pow(s.d_max, -s.D), e = 1 - 3 / s.D;
  const real_t d3 = a == b ? s.d_min * s.d_min * s.d_min : (std::pow(a, e) - std::pow(b, e)) / (e * (a - b));
  return real_t(s.count) * std::numbers::pi / 6 * d3;
}

RegionGrid::RegionGrid(const RegionSpec& s, const Vec3& expected, const Vec3& actual) : count_(s.count) {
  for (int k = 0; k < 3; ++k) {
    dims_[k] = 2 * std::max(1, int(expected[k] / (2 * 4 * s.d_max)));
    side_[k] = actual[k] / dims_[k];
    if (side_[k] < s.d_max)
      throw std::runtime_error("region packing: regions of " + std::to_string(side_[k]) + " m along axis " +
                               std::to_string(k + 1) + " are narrower than d_max");
  }
}

int RegionGrid::colour(int g) const {
  const int i = g % dims_[0], j = (g / dims_[0]) % dims_[1], l = g / (dims_[0] * dims_[1]);
  return (i & 1) + 2 * (j & 1) + 4 * (l & 1);
}

std::vector<int> RegionGrid::neighbours(int g) const {
  const int c[3] = {g % dims_[0], (g / dims_[0]) % dims_[1], g / (dims_[0] * dims_[1])};
  std::vector<int> out;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int o[3] = {dx, dy, dz};
        int n[3];
        for (int k = 0; k < 3; ++k) n[k] = (c[k] + o[k] + dims_[k]) % dims_[k];
        const int h = n[0] + dims_[0] * (n[1] + dims_[1] * n[2]);
        if (h != g && std::find(out.begin(), out.end(), h) == out.end()) out.push_back(h);
      }
  std::sort(out.begin(), out.end());
  return out;
}

int RegionGrid::region_of(const Vec3& x) const {
  int c[3];
  for (int k = 0; k < 3; ++k) c[k] = std::clamp(int(x[k] / side_[k]), 0, dims_[k] - 1);
  return c[0] + dims_[0] * (c[1] + dims_[1] * c[2]);
}

Vec3 RegionGrid::lower(int g) const {
  const int c[3] = {g % dims_[0], (g / dims_[0]) % dims_[1], g / (dims_[0] * dims_[1])};
  return Vec3(c[0] * side_[0], c[1] * side_[1], c[2] * side_[2]);
}

std::vector<real_t> region_diameters(const RegionSpec& s, const RegionGrid& grid, int g) {
  const std::int64_t n = grid.first_id(g + 1) - grid.first_id(g);
  Random rng(mix(s.seed, 2 * std::uint64_t(g)));
  const real_t a = std::pow(s.d_min, -s.D), b = std::pow(s.d_max, -s.D);
  std::vector<real_t> d(static_cast<std::size_t>(n));
  for (std::int64_t j = 0; j < n; ++j) {
    const real_t u = (real_t(j) + rng.uniform()) / real_t(n);  // stratified
    d[std::size_t(j)] = std::clamp(std::pow(a - u * (a - b), -1.0 / s.D), s.d_min, s.d_max);
  }
  for (std::int64_t j = n - 1; j > 0; --j)  // Fisher-Yates: ids do not follow the sizes
    std::swap(d[std::size_t(j)], d[std::size_t(rng.next() % std::uint64_t(j + 1))]);
  return d;
}

int size_classes(const RegionSpec& s) {
  int n = 1;
  while (s.d_max / std::ldexp(1.0, n) > s.d_min) ++n;
  return n;
}

bool in_size_class(const RegionSpec& s, int c, real_t d) {
  const real_t hi = s.d_max / std::ldexp(1.0, c), lo = s.d_max / std::ldexp(1.0, c + 1);
  return d <= hi && (d > lo || c == size_classes(s) - 1);
}

namespace {

// Positions and radii only: what the placement needs of the spheres already there.
struct SphereSet {
  std::vector<Vec3> x;
  std::vector<real_t> r;
};

Particles place_among(const RegionSpec& s, const RegionGrid& grid, const PeriodicCell& cell, int g,
                      const std::vector<const SphereSet*>& near, int size_class) {
  const std::vector<real_t> d = region_diameters(s, grid, g);
  const std::int64_t first = grid.first_id(g);
  std::vector<Index> order;
  for (std::size_t a = 0; a < d.size(); ++a)
    if (size_class < 0 || in_size_class(s, size_class, d[a])) order.push_back(Index(a));
  std::stable_sort(order.begin(), order.end(), [&](Index x, Index y) { return d[x] > d[y]; });
  // Spheres already there (near, then this region's), in bins of d_max over the whole cell.
  const Vec3& L = cell.lengths();
  int nb[3];
  for (int k = 0; k < 3; ++k) nb[k] = std::max(1, int(L[k] / s.d_max));
  auto key = [&](const int c[3]) {
    return std::int64_t(c[0]) + std::int64_t(nb[0]) * (std::int64_t(c[1]) + std::int64_t(nb[1]) * c[2]);
  };
  auto bin = [&](const Vec3& x, int c[3]) {
    for (int k = 0; k < 3; ++k) c[k] = std::clamp(int(x[k] / L[k] * nb[k]), 0, nb[k] - 1);
  };
  std::vector<Vec3> pos;
  std::vector<real_t> rad;
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> bins;
  auto insert = [&](const Vec3& x, real_t r) {
    int c[3];
    bin(x, c);
    bins[key(c)].push_back(std::uint32_t(pos.size()));
    pos.push_back(x);
    rad.push_back(r);
  };
  for (const SphereSet* n : near)
    for (std::size_t a = 0; a < n->x.size(); ++a) insert(n->x[a], n->r[a]);
  Random rng(mix(s.seed, 2 * std::uint64_t(g) + 1));
  const Vec3 lo = grid.lower(g), side = grid.side();
  Particles out;
  out.reserve(d.size());
  std::vector<Vec3> placed(d.size());
  for (Index a : order) {
    const real_t ra = 0.5 * d[a];
    bool done = false;
    for (int attempt = 0; attempt < 100000 && !done; ++attempt) {
      const Vec3 x = cell.wrap(
          Vec3(lo[0] + rng.uniform() * side[0], lo[1] + rng.uniform() * side[1], lo[2] + rng.uniform() * side[2]));
      int c[3];
      bin(x, c);
      bool free = true;
      std::int64_t seen[27];
      int nseen = 0;
      for (int dz = -1; dz <= 1 && free; ++dz)
        for (int dy = -1; dy <= 1 && free; ++dy)
          for (int dx = -1; dx <= 1 && free; ++dx) {
            const int n[3] = {(c[0] + dx + nb[0]) % nb[0], (c[1] + dy + nb[1]) % nb[1], (c[2] + dz + nb[2]) % nb[2]};
            const std::int64_t k = key(n);
            if (std::find(seen, seen + nseen, k) != seen + nseen) continue;  // a small cell
            seen[nseen++] = k;
            const auto it = bins.find(k);
            if (it == bins.end()) continue;
            for (std::uint32_t o : it->second) {
              const real_t sum = ra + rad[o];
              if (cell.minimum_image(pos[o] - x).squaredNorm() < sum * sum) {
                free = false;
                break;
              }
            }
          }
      if (free) {
        placed[a] = x;
        insert(x, ra);
        done = true;
      }
    }
    if (!done)
      throw std::runtime_error("region packing: no room for sphere " + std::to_string(first + a) + " of diameter " +
                               std::to_string(d[a]) + " m in region " + std::to_string(g) + "; lower solid_fraction");
  }
  std::sort(order.begin(), order.end());
  for (Index a : order) out.add({GlobalId(first + std::int64_t(a)), 0.5 * d[a], s.density, placed[a]});
  return out;
}

}  // namespace

Particles place_region(const RegionSpec& s, const RegionGrid& grid, const PeriodicCell& cell, int g,
                       const Particles& near, int size_class) {
  SphereSet n;
  n.x.assign(near.x.begin(), near.x.begin() + std::ptrdiff_t(near.n_owned()));
  n.r.assign(near.radius.begin(), near.radius.begin() + std::ptrdiff_t(near.n_owned()));
  return place_among(s, grid, cell, g, {&n}, size_class);
}

Particles region_packing(const RegionSpec& s, const RegionGrid& grid, const PeriodicCell& cell,
                         std::span<const int> mine, const RegionExchange& exchange) {
  // Spheres known here, by region (positions and radii): this rank's and those received.
  std::unordered_map<int, SphereSet> known;
  Particles result;
  std::string failure;  // after a sphere found no room: the rounds go on, placing nothing
  for (int size_class = 0; size_class < size_classes(s); ++size_class)
    for (int colour = 0; colour < 8; ++colour) {
      Particles placed;
      std::vector<int> region_of_placed;
      for (int g : mine) {
        if (grid.colour(g) != colour || !failure.empty()) continue;
        std::vector<const SphereSet*> near;
        std::vector<int> around = grid.neighbours(g);
        around.push_back(g);  // its own spheres of the larger classes
        for (int h : around)
          if (const auto it = known.find(h); it != known.end()) near.push_back(&it->second);
        Particles p;
        try {
          p = place_among(s, grid, cell, g, near, size_class);
        } catch (const std::runtime_error& e) {
          failure = e.what();
          continue;
        }
        SphereSet& into = known[g];
        for (std::size_t a = 0; a < p.n_owned(); ++a) {
          const SphereInit si{p.id[a], p.radius[a], s.density, p.x[a]};
          into.x.push_back(si.x);
          into.r.push_back(si.radius);
          placed.add(si);
          result.add(si);
          region_of_placed.push_back(g);
        }
      }
      const Particles from_others = exchange(placed, region_of_placed);
      for (std::size_t a = 0; a < from_others.n_owned(); ++a) {
        SphereSet& into = known[grid.region_of(from_others.x[a])];
        into.x.push_back(from_others.x[a]);
        into.r.push_back(from_others.radius[a]);
      }
    }
  if (!failure.empty()) throw std::runtime_error(failure);
  return result;
}

}  // namespace fabrica
