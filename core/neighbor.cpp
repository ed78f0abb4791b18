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
  const Vec3 h = cell.heights();
  for (int k = 0; k < 3; ++k) {
    if (!(h[k] > need)) {
      if (cell.sheared())
        throw std::invalid_argument("sheared periodic cell height h" + std::to_string(k + 1) + " = " +
                                    std::to_string(h[k]) + " m must exceed 2 (2 Rmax + skin) = " +
                                    std::to_string(need) + " m so that every pair has a single periodic image");
      throw std::invalid_argument("periodic cell length L" + std::to_string(k + 1) + " = " + std::to_string(h[k]) +
                                  " m must exceed 2 (2 Rmax + skin) = " + std::to_string(need) +
                                  " m so that every pair has a single periodic image");
    }
  }
}

namespace {

// Cells of the cell's fractional coordinates: an orthorhombic cell's boxes of edge L_k / n_k,
// a sheared cell's parallelepipeds of height h_k / n_k (two points closer than that height are
// in neighbouring cells whatever the shear).
struct Grid {
  std::array<int, 3> n{};
  Vec3 inv_h;            // orthorhombic: n_k / L_k
  bool sheared = false;  // else: the fractional coordinates H^-1 x, times n_k
  Mat3 to_cells;         // sheared: diag(n) H^-1
  void coords(const Vec3& x, int c[3]) const {
    if (sheared) {
      const Vec3 f = to_cells * x;
      for (int k = 0; k < 3; ++k) c[k] = std::min(n[k] - 1, std::max(0, int(f[k])));
    } else {
      for (int k = 0; k < 3; ++k) c[k] = std::min(n[k] - 1, std::max(0, int(x[k] * inv_h[k])));
    }
  }
  int index(const Vec3& x) const {
    int c[3];
    coords(x, c);
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

// Cells of edge at least `edge`, and at most 16 per sphere of the grid (65,536 at least): a
// dilute specimen would otherwise ask for up to (L / edge)^3 cells (2.8e10 for 1-cm spheres in
// a 64 m cell, beyond the memory and an int). Wider cells find the same pairs.
Grid make_grid(const PeriodicCell& cell, real_t edge, std::size_t spheres) {
  const double most = std::max(65536.0, 16.0 * double(spheres));
  const Vec3 L = cell.heights();  // orthorhombic: the lengths
  Grid g;
  for (real_t e = edge;; e *= 1.25) {
    double cells = 1;
    for (int k = 0; k < 3; ++k) {
      g.n[k] = int(std::max(1.0, std::min(most, std::floor(L[k] / e))));
      cells *= g.n[k];
    }
    if (cells <= most) break;
  }
  for (int k = 0; k < 3; ++k) g.inv_h[k] = g.n[k] / L[k];
  if (cell.sheared()) {
    g.sheared = true;
    g.to_cells = Vec3(g.n[0], g.n[1], g.n[2]).asDiagonal() * cell.matrix().inverse();
  }
  return g;
}

}  // namespace

// The class-b spheres of one grid in cell order, with their positions and radii copied in that
// order in single precision, so that the scan of a cell reads memory in sequence (20 bytes a
// sphere instead of 36: the neighbour build's peak memory at large N). The copies only pick
// the candidates, with a margin that covers their rounding; the pairs are then decided from
// the particles' own positions and radii, as before, so the list is the same bit for bit.
struct NeighborSearch::CellCopies {
  std::vector<Index> start, item;  // counting sort: cell c holds item[start[c] .. start[c + 1])
  std::vector<float> x, y, z, r;   // position and radius of item[q], rounded to float
};

namespace {

// Room for at least `need` candidate pairs (grown by an eighth at a time past the first guess,
// so that the buffers do not double past need at large N).
void make_room(std::vector<Index>& ti, std::vector<Index>& tj, std::vector<std::uint8_t>& timg, std::size_t need) {
  if (need <= ti.size()) return;
  const std::size_t size = std::max(need, ti.size() + ti.size() / 8 + 1024);
  ti.resize(size);
  tj.resize(size);
  timg.resize(size);
}

// Scans the 27 cells around every sphere a of class `ca` in the grid of class `cb` and appends
// the pairs within R_a + R_b + skin as (a, b, image of b), unoriented. Branch-free: every
// candidate is written to the next slot and the count advances by the test, so the ~80 % of
// candidates that fail do not cost a mispredicted branch. With at least 3 cells on every axis
// each of the 27 cells is a distinct cell seen through one periodic image, known from the
// offset (the three cells of a row are scanned as one range where they are consecutive), and
// the single-precision copies decide every candidate but those within `margin` (which covers
// their rounding) of the cutoff, which are tested in double precision from the particles. On a
// smaller grid the image is found per candidate (minimum image) and repeated cells are scanned
// once, in double precision from the particles. Both give the nearest image of b, the same
// bits as d = x_b - x_a + s L.
template <bool kImagePerCandidate>
std::size_t scan_grid(const Particles& p, const std::vector<Index>& members_a, bool same_class, const Grid& g,
                      const PeriodicCell& cell, real_t skin, real_t margin, const NeighborSearch::CellCopies& cb,
                      std::size_t m, std::vector<Index>& ti, std::vector<Index>& tj, std::vector<std::uint8_t>& timg) {
  const Index n_owned = Index(p.n_owned());
  const Vec3* px = p.x.data();
  const real_t* pr = p.radius.data();
  const float skin_lo = float(skin - margin), skin_hi = float(skin + margin);
  const Vec3& L = cell.lengths();
  std::array<Vec3, 27> shifts;  // of image_code(s0, s1, s2)
  for (int c = 0; c < 27; ++c) shifts[c] = image_offset(c, cell);
  for (Index a : members_a) {
    const Vec3 xa = p.x[a];
    const real_t ra = p.radius[a];
    const bool a_ghost = a >= n_owned;
    int c[3];
    g.coords(xa, c);
    int cells[3][3], shift[3][3], count[3];
    for (int k = 0; k < 3; ++k) {
      if constexpr (kImagePerCandidate) {
        count[k] = g.around(k, c[k], cells[k]);
        for (int o = 0; o < 3; ++o) shift[k][o] = 0;
      } else {
        count[k] = 3;
        for (int o = 0; o < 3; ++o) {
          int v = c[k] + o - 1, s = 0;
          if (v < 0) v += g.n[k], s = -1;            // b lies near L: its image at x_b - L
          else if (v >= g.n[k]) v -= g.n[k], s = 1;  // b lies near 0: its image at x_b + L
          cells[k][o] = v;
          shift[k][o] = s;
        }
      }
    }
    const float xa0 = float(xa[0]), xa1 = float(xa[1]), xa2 = float(xa[2]);
    const float ra_f = float(ra);
    // The candidates cb.item[q0 .. q1), seen through the periodic image (s0, s1, s2).
    auto scan = [&](std::size_t q0, std::size_t q1, int s0, int s1, int s2) {
      make_room(ti, tj, timg, m + (q1 - q0));
      const std::uint8_t code = std::uint8_t(image_code(s0, s1, s2));
      const real_t sh0 = shifts[code][0], sh1 = shifts[code][1], sh2 = shifts[code][2];
      Index* __restrict out_i = ti.data();
      Index* __restrict out_j = tj.data();
      std::uint8_t* __restrict out_img = timg.data();
      // The exact test of sphere b seen at d (x_b - x_a + shift), as every build has made it.
      auto within_exact = [&](Index b, real_t d0, real_t d1, real_t d2) {
        const real_t cut = ra + pr[b] + skin;
        const real_t r2 = d0 * d0 + d1 * d1 + d2 * d2;
        return !(r2 >= cut * cut);
      };
      if constexpr (kImagePerCandidate) {
        for (std::size_t q = q0; q < q1; ++q) {
          const Index b = cb.item[q];
          real_t d0 = px[b][0] - xa[0], d1 = px[b][1] - xa[1], d2 = px[b][2] - xa[2];
          int t0, t1, t2;
          if (g.sheared) {  // the nearest image from the fractional difference, then its shift
            const Vec3 f = cell.fractional(Vec3(d0, d1, d2));
            t0 = -int(std::nearbyint(f[0])), t1 = -int(std::nearbyint(f[1])), t2 = -int(std::nearbyint(f[2]));
            const Vec3& sh = shifts[image_code(t0, t1, t2)];
            d0 += sh[0], d1 += sh[1], d2 += sh[2];
          } else {
            t0 = -int(std::nearbyint(d0 / L[0]));
            t1 = -int(std::nearbyint(d1 / L[1]));
            t2 = -int(std::nearbyint(d2 / L[2]));
            d0 += t0 * L[0], d1 += t1 * L[1], d2 += t2 * L[2];
          }
          out_i[m] = a;
          out_j[m] = b;
          out_img[m] = std::uint8_t(image_code(t0, t1, t2));
          m += within_exact(b, d0, d1, d2) & !(same_class & (b <= a)) & !(a_ghost & (b >= n_owned));
        }
      } else {
        // From the copies: a candidate nearer than the cutoff less the margin is a pair, one
        // farther than the cutoff plus the margin is not; between the two (a band of about
        // 4e-6 of the cell length, so few candidates) the exact test decides.
        const float sh0f = float(sh0), sh1f = float(sh1), sh2f = float(sh2);
        const Index* __restrict item = cb.item.data();
        const float* __restrict cx = cb.x.data();
        const float* __restrict cy = cb.y.data();
        const float* __restrict cz = cb.z.data();
        const float* __restrict cr = cb.r.data();
        for (std::size_t q = q0; q < q1; ++q) {
          const Index b = item[q];
          const float d0 = (cx[q] - xa0) + sh0f, d1 = (cy[q] - xa1) + sh1f, d2 = (cz[q] - xa2) + sh2f;
          const float sum_r = ra_f + cr[q];
          // (Below zero where the margin exceeds the cutoff: nothing is then surely in.)
          const float lo = std::max(sum_r + skin_lo, 0.0f), hi = sum_r + skin_hi;
          const float r2 = d0 * d0 + d1 * d1 + d2 * d2;
          bool keep = !(r2 >= lo * lo);
          const bool near = !(r2 >= hi * hi);
          if (keep != near) [[unlikely]]  // one branch, nearly never taken
            keep = within_exact(b, (px[b][0] - xa[0]) + sh0, (px[b][1] - xa[1]) + sh1, (px[b][2] - xa[2]) + sh2);
          out_i[m] = a;
          out_j[m] = b;
          out_img[m] = code;
          m += keep & !(same_class & (b <= a)) & !(a_ghost & (b >= n_owned));
        }
      }
    };
    // Away from the x ends of the grid the three cells of a row are consecutive in the cell
    // order: one scan of their items (9 scans per sphere instead of 27).
    const bool row_in_one = !kImagePerCandidate && c[0] >= 1 && c[0] + 1 < g.n[0];
    for (int iz = 0; iz < count[2]; ++iz)
      for (int iy = 0; iy < count[1]; ++iy) {
        const int row = g.n[0] * (cells[1][iy] + g.n[1] * cells[2][iz]);
        if (row_in_one) {
          const std::size_t q0 = cb.start[row + c[0] - 1], q1 = cb.start[row + c[0] + 2];
          if (q0 != q1) scan(q0, q1, 0, shift[1][iy], shift[2][iz]);
          continue;
        }
        for (int ix = 0; ix < count[0]; ++ix) {
          const int cc = row + cells[0][ix];
          const std::size_t q0 = cb.start[cc], q1 = cb.start[cc + 1];
          if (q0 != q1) scan(q0, q1, shift[0][ix], shift[1][iy], shift[2][iz]);
        }
      }
  }
  return m;
}

}  // namespace

void NeighborSearch::build(const Particles& p, const PeriodicCell& cell, real_t skin, PairList& out) {
  const std::size_t n = p.size();
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
  std::size_t m = 0;
  make_room(tmp_i_, tmp_j_, tmp_img_, last_pairs_ + last_pairs_ / 16);
  // The largest coordinate of a wrapped position (orthorhombic: the largest length).
  const Mat3 H = cell.matrix();
  const real_t extent = cell.sheared() ? H.cwiseAbs().rowwise().sum().maxCoeff() : cell.lengths().maxCoeff();
  // The single-precision copies' rounding: each of x_b, x_a and the shift rounded once (at most
  // 2^-24 of L each), the two sums rounded once more (2^-24 of 2 L each), the squares, the sum
  // of radii and the skin likewise relative to the cutoff: 2^-18 (64 u) of the largest cell
  // length plus the largest cutoff bounds every error of |d| and of the cutoff with room to
  // spare.
  const real_t margin = std::ldexp(extent + 2 * rmax + skin, -18);
  CellCopies cb;
  for (int b_class = 0; b_class < nclass; ++b_class) {
    const std::vector<Index>& mb = members[b_class];
    if (mb.empty()) continue;
    for (int a_class = 0; a_class <= b_class; ++a_class) {
      if (members[a_class].empty()) continue;
      const Grid g = make_grid(cell, cls_rmax[a_class] + cls_rmax[b_class] + skin, mb.size());
      const int ncell = g.n[0] * g.n[1] * g.n[2];
      // Counting sort of class-b spheres into cells, with their positions and radii.
      cb.start.assign(ncell + 1, 0);
      for (Index b : mb) ++cb.start[g.index(p.x[b]) + 1];
      for (int c = 0; c < ncell; ++c) cb.start[c + 1] += cb.start[c];
      cb.item.resize(mb.size());
      const bool copies = g.n[0] >= 3 && g.n[1] >= 3 && g.n[2] >= 3;  // else read from p
      if (copies) {
        cb.x.resize(mb.size());
        cb.y.resize(mb.size());
        cb.z.resize(mb.size());
        cb.r.resize(mb.size());
      }
      {
        std::vector<Index> fill(cb.start.begin(), cb.start.end() - 1);
        for (Index b : mb) {
          const Index q = fill[g.index(p.x[b])]++;
          cb.item[q] = b;
          if (copies) {
            cb.x[q] = float(p.x[b][0]);
            cb.y[q] = float(p.x[b][1]);
            cb.z[q] = float(p.x[b][2]);
            cb.r[q] = float(p.radius[b]);
          }
        }
      }
      const bool same = a_class == b_class;
      if (copies)
        m = scan_grid<false>(p, members[a_class], same, g, cell, skin, margin, cb, m, tmp_i_, tmp_j_, tmp_img_);
      else m = scan_grid<true>(p, members[a_class], same, g, cell, skin, margin, cb, m, tmp_i_, tmp_j_, tmp_img_);
    }
  }
  cb = CellCopies();  // free before the sort (memory at large N)
  // Orient each pair from the lower to the higher global id (the image then seen from i).
  for (std::size_t q = 0; q < m; ++q) {
    const Index a = tmp_i_[q], b = tmp_j_[q];
    const bool swap = p.id[a] > p.id[b];
    tmp_i_[q] = swap ? b : a;
    tmp_j_[q] = swap ? a : b;
    tmp_img_[q] = swap ? std::uint8_t(26 - tmp_img_[q]) : tmp_img_[q];
  }

  std::vector<int>().swap(cls_);  // the class grids are done with: free before the sort
  last_pairs_ = m;
  order_pairs(p, cell, m, out);
}

// Moves the m pairs found (tmp_i_, tmp_j_, tmp_img_) into 'out' in the space-filling-curve order.
void NeighborSearch::order_pairs(const Particles& p, const PeriodicCell& cell, std::size_t m, PairList& out) {
  const std::size_t n = p.size();
  // Order the pairs along the space-filling curve (core/space_order.hpp): by the place of body
  // i in the (Morton key, id) order, then by that of body j. The order compares two particles
  // by their own position and id only, so each particle receives its contact forces in the
  // same order whatever the rank count or the local storage order: force sums, and so
  // trajectories, are bitwise the same on any number of ranks. And it follows space, so the
  // force loop walks memory nearly in order at any specimen size.
  space_ranks(p, n, cell, rank_);
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

std::vector<Index> NeighborSearch::spatial_order(const Particles& p, const PeriodicCell& cell) const {
  std::vector<std::uint32_t> rank;
  std::vector<Index> order;
  space_ranks(p, p.n_owned(), cell, rank, &order);
  return order;
}

std::vector<std::pair<GlobalId, GlobalId>> brute_force_pairs(const Particles& p, const PeriodicCell& cell,
                                                             real_t skin) {
  std::vector<std::pair<GlobalId, GlobalId>> pairs;
  for (std::size_t a = 0; a < p.size(); ++a)
    for (std::size_t b = a + 1; b < p.size(); ++b) {
      const Vec3 d = cell.minimum_image(p.x[b] - p.x[a]);
      const real_t cut = p.radius[a] + p.radius[b] + skin;
      if (d.squaredNorm() < cut * cut) pairs.emplace_back(std::min(p.id[a], p.id[b]), std::max(p.id[a], p.id[b]));
    }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace fabrica
