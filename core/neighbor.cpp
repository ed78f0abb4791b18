#include "core/neighbor.hpp"

#include "core/space_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fabrica {

void check_cell_size(const PeriodicCell& cell, real_t max_radius, real_t skin) {
  const real_t need = 2.0 * (2.0 * max_radius + skin);
  for (int k = 0; k < 3; ++k) {
    if (!(cell.lengths()[k] > need)) {
      throw std::invalid_argument(
          "periodic cell length L" + std::to_string(k + 1) + " = " +
          std::to_string(cell.lengths()[k]) + " m must exceed 2 (2 Rmax + skin) = " +
          std::to_string(need) + " m so that every pair has a single periodic image");
    }
  }
}

namespace {

struct Grid {
  std::array<int, 3> n{};
  Vec3 inv_h;
  int index(const Vec3& x) const {
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::min(n[k] - 1, std::max(0, int(x[k] * inv_h[k])));
    return c[0] + n[0] * (c[1] + n[1] * c[2]);
  }
  // Distinct cell indices along axis k around c (periodic), at most 3.
  int around(int k, int c, int out[3]) const {
    int m = 0;
    for (int o = -1; o <= 1; ++o) {
      const int v = ((c + o) % n[k] + n[k]) % n[k];
      bool dup = false;
      for (int q = 0; q < m; ++q) dup |= out[q] == v;
      if (!dup) out[m++] = v;
    }
    return m;
  }
};

Grid make_grid(const Vec3& L, real_t edge) {
  Grid g;
  for (int k = 0; k < 3; ++k) {
    g.n[k] = std::max(1, int(std::floor(L[k] / edge)));
    g.inv_h[k] = g.n[k] / L[k];
  }
  return g;
}

}  // namespace

void NeighborSearch::build(const Particles& p, const PeriodicCell& cell, real_t skin,
                           PairList& out) {
  const std::size_t n = p.size();
  const std::size_t n_owned = p.n_owned();
  out.i.clear();
  out.j.clear();
  out.image.clear();
  if (n < 2) return;

  // Size classes: class c holds radii in [rmin 2^c, rmin 2^(c+1)), at most 4 classes.
  const real_t rmin = p.min_radius();
  const real_t rmax = p.max_radius();
  const int nclass = std::min(4, 1 + int(std::floor(std::log2(rmax / rmin) + 1e-12)));
  cls_.resize(n);
  std::array<real_t, 4> cls_rmax{};
  std::array<std::vector<Index>, 4> members;
  for (std::size_t a = 0; a < n; ++a) {
    const int c = std::min(nclass - 1, int(std::floor(std::log2(p.radius[a] / rmin))));
    cls_[a] = c;
    cls_rmax[c] = std::max(cls_rmax[c], p.radius[a]);
    members[c].push_back(Index(a));
  }

  // Room for about as many pairs as last time, so that the buffers do not double past need.
  const std::size_t guess = last_pairs_ + last_pairs_ / 16;
  tmp_i_.reserve(guess);
  tmp_j_.reserve(guess);
  tmp_img_.reserve(guess);
  const Vec3& L = cell.lengths();
  for (int cb = 0; cb < nclass; ++cb) {
    if (members[cb].empty()) continue;
    for (int ca = 0; ca <= cb; ++ca) {
      if (members[ca].empty()) continue;
      const Grid g = make_grid(L, cls_rmax[ca] + cls_rmax[cb] + skin);
      const int ncell = g.n[0] * g.n[1] * g.n[2];
      // Counting sort of class-b spheres into cells.
      cell_start_.assign(ncell + 1, 0);
      for (Index b : members[cb]) ++cell_start_[g.index(p.x[b]) + 1];
      for (int c = 0; c < ncell; ++c) cell_start_[c + 1] += cell_start_[c];
      cell_items_.resize(members[cb].size());
      {
        std::vector<Index> fill(cell_start_.begin(), cell_start_.end() - 1);
        for (Index b : members[cb]) cell_items_[fill[g.index(p.x[b])]++] = b;
      }
      for (Index a : members[ca]) {
        const Vec3 xa = p.x[a];
        const real_t ra = p.radius[a];
        int c[3];
        for (int k = 0; k < 3; ++k)
          c[k] = std::min(g.n[k] - 1, std::max(0, int(xa[k] * g.inv_h[k])));
        int ax[3], ay[3], az[3];
        const int mx = g.around(0, c[0], ax), my = g.around(1, c[1], ay), mz = g.around(2, c[2], az);
        for (int iz = 0; iz < mz; ++iz)
          for (int iy = 0; iy < my; ++iy)
            for (int ix = 0; ix < mx; ++ix) {
              const int cc = ax[ix] + g.n[0] * (ay[iy] + g.n[1] * az[iz]);
              for (Index q = cell_start_[cc]; q < cell_start_[cc + 1]; ++q) {
                const Index b = cell_items_[q];
                if (ca == cb && b <= a) continue;
                if (std::size_t(a) >= n_owned && std::size_t(b) >= n_owned) continue;
                Vec3 d = p.x[b] - xa;
                int s[3];
                for (int k = 0; k < 3; ++k) {
                  s[k] = -int(std::nearbyint(d[k] / L[k]));
                  d[k] += s[k] * L[k];
                }
                const real_t cut = ra + p.radius[b] + skin;
                if (d.squaredNorm() >= cut * cut) continue;
                if (p.id[a] < p.id[b]) {
                  tmp_i_.push_back(a), tmp_j_.push_back(b);
                  tmp_img_.push_back(std::uint8_t(image_code(s[0], s[1], s[2])));
                } else {
                  tmp_i_.push_back(b), tmp_j_.push_back(a);
                  tmp_img_.push_back(std::uint8_t(image_code(-s[0], -s[1], -s[2])));
                }
              }
            }
      }
    }
  }

  // Order the pairs along the space-filling curve (core/space_order.hpp): by the place of body
  // i in the (Morton key, id) order, then by that of body j. The order compares two particles
  // by their own position and id only, so each particle receives its contact forces in the
  // same order whatever the rank count or the local storage order: force sums, and so
  // trajectories, are bitwise the same on any number of ranks. And it follows space, so the
  // force loop walks memory nearly in order at any specimen size.
  space_ranks(p, n, L, rank_);
  const std::size_t m = tmp_i_.size();
  std::vector<int>().swap(cls_);  // the class grids are done with: free before the sort
  std::vector<Index>().swap(cell_items_);
  // A counting sort by the place of i (the places are 0 .. n-1), then each run of one i
  // ordered by the place of j: the (place i, place j) order without a sort buffer per pair
  // (memory at large N: 4 bytes per particle instead of 16 per pair). Every pair is listed
  // once, so the keys are distinct and the order is the same as a full sort's.
  std::vector<Index>& start = cell_start_;
  start.assign(n + 1, 0);
  for (std::size_t q = 0; q < m; ++q) ++start[rank_[tmp_i_[q]] + 1];
  for (std::size_t r = 0; r < n; ++r) start[r + 1] += start[r];
  out.i.resize(m);
  out.j.resize(m);
  out.image.resize(m);
  for (std::size_t q = 0; q < m; ++q) {
    const Index k = start[rank_[tmp_i_[q]]]++;
    out.i[k] = tmp_i_[q];
    out.j[k] = tmp_j_[q];
    out.image[k] = tmp_img_[q];
  }
  std::vector<Index>().swap(tmp_i_);
  std::vector<Index>().swap(tmp_j_);
  std::vector<std::uint8_t>().swap(tmp_img_);
  // start[r] is now the end of run r (the start of run r + 1); run 0 starts at 0.
  for (std::size_t r = 0, begin = 0; r < n; begin = start[r], ++r)
    for (std::size_t k = begin + 1; k < std::size_t(start[r]); ++k) {
      const Index j = out.j[k];
      const std::uint8_t img = out.image[k];
      const std::uint32_t key = rank_[j];
      std::size_t h = k;
      for (; h > begin && rank_[out.j[h - 1]] > key; --h) {
        out.j[h] = out.j[h - 1];
        out.image[h] = out.image[h - 1];
      }
      out.j[h] = j;
      out.image[h] = img;
    }
  // Free the buffers until the next build (memory at large N).
  last_pairs_ = m;
  std::vector<Index>().swap(cell_start_);
  std::vector<std::uint32_t>().swap(rank_);
}

void NeighborSearch::build_walls(const Particles& p, const std::vector<Wall>& walls, real_t skin,
                                 WallContactList& out) {
  out.i.clear();
  out.wall.clear();
  for (std::size_t w = 0; w < walls.size(); ++w)
    for (std::size_t a = 0; a < p.n_owned(); ++a)
      if ((p.x[a] - walls[w].point).dot(walls[w].normal) < p.radius[a] + skin) {
        out.i.push_back(Index(a));
        out.wall.push_back(std::int32_t(w));
      }
}

std::vector<Index> NeighborSearch::spatial_order(const Particles& p,
                                                 const PeriodicCell& cell) const {
  std::vector<std::uint32_t> rank;
  std::vector<Index> order;
  space_ranks(p, p.n_owned(), cell.lengths(), rank, &order);
  return order;
}

std::vector<std::pair<GlobalId, GlobalId>> brute_force_pairs(const Particles& p,
                                                             const PeriodicCell& cell,
                                                             real_t skin) {
  std::vector<std::pair<GlobalId, GlobalId>> pairs;
  for (std::size_t a = 0; a < p.size(); ++a)
    for (std::size_t b = a + 1; b < p.size(); ++b) {
      const Vec3 d = cell.minimum_image(p.x[b] - p.x[a]);
      const real_t cut = p.radius[a] + p.radius[b] + skin;
      if (d.squaredNorm() < cut * cut)
        pairs.emplace_back(std::min(p.id[a], p.id[b]), std::max(p.id[a], p.id[b]));
    }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace fabrica
