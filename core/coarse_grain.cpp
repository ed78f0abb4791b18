#include "core/coarse_grain.hpp"

#include "core/exact_sum.hpp"
#include "core/grid_share.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace fabrica {
namespace {

constexpr real_t kNaN = std::numeric_limits<real_t>::quiet_NaN();

__extension__ typedef __int128 Wide;
__extension__ typedef unsigned __int128 UWide;

// Fixed-point sums over the grid, the same bits for any order and grouping of the terms.
// Slot s of node g holds an integer I with value I 2^e[s]; e[s] is chosen from a bound on every
// term of the slot over all ranks (a max reduction, order-independent) so that each term is
// below 2^84 in units of 2^e[s]: terms are rounded once (towards zero) to that grid, about 2^-84
// of the largest possible term, and added as 128-bit integers, which hold 2^42 such terms.
class GridSums {
 public:
  // The integers live in a buffer kept by the thread between calls (grown, never shrunk): a
  // fresh allocation of tens of MB at every field instant costs its page faults again, more
  // than the sums themselves on a fine grid; zeroing a buffer already mapped is cheap.
  // 'store': which of the thread's two buffers (a rank sharing the grid holds its box's sums and
  // its slab's at once).
  GridSums(std::size_t nodes, std::size_t slots, int store = 0)
      : nodes_(nodes), slots_(slots), acc_(workspace(store)), e_(slots, 0), scale_(slots, 1.0), unit_(slots, 1.0) {
    if (acc_.size() < nodes * slots) {
      // Grown without copying: the old integers are not needed, and two buffers at once (a
      // vector's growth) would double the peak when a rank's box grows between two instants.
      std::vector<Wide>().swap(acc_);
      acc_.resize(nodes * slots);
    }
    std::fill(acc_.begin(), acc_.begin() + std::ptrdiff_t(nodes * slots), Wide(0));
  }
  GridSums(const GridSums&) = delete;
  GridSums& operator=(const GridSums&) = delete;

  // bound[s]: an upper bound of |term| over every term of slot s on every rank.
  void set_bounds(std::span<const double> bound) {
    for (std::size_t s = 0; s < slots_; ++s) {
      e_[s] = bound[s] > 0 && std::isfinite(bound[s]) ? std::ilogb(bound[s]) + 1 - 84 : 0;
      e_[s] = std::max(e_[s], -1000);  // 2^-e finite (a coarser grid still holds every term)
      scale_[s] = std::ldexp(1.0, -e_[s]);
      unit_[s] = std::ldexp(1.0, e_[s]);
    }
  }

  void add(std::size_t node, std::size_t slot, double x) { acc_[node * slots_ + slot] += fixed(slot, x); }

  // Adds x[k] w to slots first .. first + count - 1 of a node (each term rounded once).
  void add_row(std::size_t node, std::size_t first, const double* x, std::size_t count, double w) {
    Wide* a = acc_.data() + node * slots_ + first;
    for (std::size_t k = 0; k < count; ++k) a[k] += fixed(first + k, x[k] * w);
  }

  // Sums the grids of every rank, exactly: each 128-bit integer as four 32-bit digits in int64
  // words (the top one signed), summed as integers, in chunks of at most 2^18 slots.
  void reduce(Domain& reducer) {
    if (reducer.size() == 1) return;  // the sums are this rank's
    const std::size_t total = nodes_slots(), chunk = std::size_t(1) << 18;
    std::vector<std::int64_t> buf;
    for (std::size_t a = 0; a < total; a += chunk) {
      const std::size_t b = std::min(total, a + chunk);
      buf.assign(4 * (b - a), 0);
      for (std::size_t i = a; i < b; ++i) {
        const UWide u = UWide(acc_[i]);
        std::int64_t* d = buf.data() + 4 * (i - a);
        d[0] = std::int64_t(std::uint64_t(u) & 0xffffffffu);
        d[1] = std::int64_t(std::uint64_t(u >> 32) & 0xffffffffu);
        d[2] = std::int64_t(std::uint64_t(u >> 64) & 0xffffffffu);
        d[3] = std::int64_t(std::int32_t(std::uint32_t(std::uint64_t(u >> 96))));  // signed top digit
      }
      reducer.sum_all(std::span<std::int64_t>(buf));
      for (std::size_t i = a; i < b; ++i) {
        const std::int64_t* d = buf.data() + 4 * (i - a);
        acc_[i] = Wide(d[0]) + (Wide(d[1]) << 32) + (Wide(d[2]) << 64) + (Wide(d[3]) << 96);
      }
    }
  }

  // The sum of a slot at a node (correctly rounded integer to double, then scaled exactly).
  double value(std::size_t node, std::size_t slot) const { return value_of(acc_[node * slots_ + slot], slot); }
  // The integer of a slot at a node, and the value of an integer on a slot's grid (sums of the
  // integers of slots with the same grid are exact).
  Wide raw(std::size_t node, std::size_t slot) const { return acc_[node * slots_ + slot]; }
  // (Times 2^e, a normal double: the same correctly rounded result as ldexp.)
  double value_of(Wide a, std::size_t slot) const { return static_cast<double>(a) * unit_[slot]; }
  int exponent(std::size_t slot) const { return e_[slot]; }
  std::size_t nodes() const { return nodes_; }
  std::size_t slots() const { return slots_; }
  // A node's integers (slots() of them), to send and to add into.
  Wide* row(std::size_t node) { return acc_.data() + node * slots_; }
  const Wide* row(std::size_t node) const { return acc_.data() + node * slots_; }

 private:
  // x rounded towards zero to a multiple of 2^e[slot], in units of 2^e[slot]. y = x 2^-e is
  // exact (a power-of-two scaling; a result below the normal range is below one unit and
  // truncates to 0 whatever its rounding), below 2^93 by the bound (2^9 of margin over the
  // 2^84 of set_bounds), and split exactly as hi 2^41 + lo with both parts truncated towards
  // zero and of the sign of y: their sum is trunc(y), with no conversion of a double to 128 bits.
  Wide fixed(std::size_t slot, double x) const {
    const double y = x * scale_[slot];
    if (!(std::abs(y) < 0x1p93)) {
      if (!std::isfinite(x)) throw std::domain_error("coarse_grain: non-finite term");
      throw std::logic_error("coarse_grain: a term exceeds its slot's bound");
    }
    const auto hi = static_cast<std::int64_t>(y * 0x1p-41);
    const auto lo = static_cast<std::int64_t>(y - static_cast<double>(hi) * 0x1p41);
    return Wide(hi) * (Wide(1) << 41) + Wide(lo);
  }

  static std::vector<Wide>& workspace(int store) {
    thread_local std::array<std::vector<Wide>, 2> w;
    return w[std::size_t(store)];
  }
  std::size_t nodes_slots() const { return nodes_ * slots_; }

  std::size_t nodes_ = 0, slots_;
  std::vector<Wide>& acc_;
  std::vector<int> e_;
  std::vector<double> scale_, unit_;  // 2^-e, 2^e
};

// The nodes a kernel centred at x reaches, with their normalised weights (sum w dV = 1).
struct Reach {
  std::size_t node;
  Vec3 d;                  // X_node - x (the node's position relative to the image of x it sees), m
  std::array<int, 3> img;  // the image: the node sees x - img (.) L
  double w;                // 1/m^3
};

struct NodeWeight {
  std::size_t node;
  double w;  // 1/m^3
};

class Spreader {
 public:
  // The nodes are numbered in 'box' (core/grid_box.hpp: the whole grid, or a rank's box).
  Spreader(const FieldGrid& g, const FieldKernel& k, const NodeBox& box)
      : g_(g), k_(k), box_(box), h_(g.spacing()), rs_(k.support()), dv_(g.cell_volume()) {
    if (g.sheared) reach_ = g.index_reach(rs_);
  }

  // The nodes within the support of x (any real position) with their normalised weights, in a
  // fixed order (z, then y, then x along each axis's reach): reach() with each node's offset and
  // image (the displacement fields), weights() with the node and weight alone (the other fields).
  const std::vector<Reach>& reach(const Vec3& x) {
    out_.clear();
    const auto push = [&](std::size_t node, const Vec3& d, const Ax& xx, const Ax& y, const Ax& z, double w) {
      out_.push_back({node, d, {xx.img, y.img, z.img}, w});
    };
    const double sum = g_.sheared ? visit_sheared(x, push) : visit(x, push);
    const double scale = 1.0 / (sum * dv_);
    for (Reach& r : out_) r.w *= scale;
    return out_;
  }
  const std::vector<NodeWeight>& weights(const Vec3& x) {
    lean_.clear();
    const auto push = [&](std::size_t node, const Vec3&, const Ax&, const Ax&, const Ax&, double w) {
      lean_.push_back({node, w});
    };
    const double sum = g_.sheared ? visit_sheared(x, push) : visit(x, push);
    const double scale = 1.0 / (sum * dv_);
    for (NodeWeight& r : lean_) r.w *= scale;
    return lean_;
  }

  // An upper bound of every normalised weight: W(0) over (W at the farthest a nearest node can
  // be, half the cell's diagonal, times dV), with a margin of 2^-40 for the rounding of the
  // separable Gaussian's product against raw().
  double weight_bound() const { return k_.raw(0) / (k_.raw(g_.half_diagonal()) * dv_) * (1 + 0x1p-40); }

 private:
  struct Ax {
    int i, img;
    real_t d, d2;  // the node's coordinate relative to x along the axis, and its square
    double g;      // the Gaussian's factor along the axis (1 for Lucy)
  };
  // Calls push(node, x axis, y axis, z axis, W) for every node within the support, returns the
  // sum of W. The Gaussian is separable: its W at a node is the product of three 1D factors
  // exp(-d_a^2 / (2 w^2)), one per axis and node line, with the support tested on the squared
  // distance (the truncation stays spherical).
  template <class Push>
  double visit(const Vec3& x, Push&& push) {
    const bool gauss = k_.type == KernelType::Gaussian;
    const real_t inv2w2 = 0.5 / (k_.width * k_.width), rs2 = rs_ * rs_;
    for (int a = 0; a < 3; ++a) {
      axis_[a].clear();
      const long lo = long(std::ceil((x[a] - rs_) / h_[a] - 0.5)), hi = long(std::floor((x[a] + rs_) / h_[a] - 0.5));
      const long n = g_.n[a];
      for (long i = lo; i <= hi; ++i) {
        const long img = i >= 0 ? i / n : -((-i - 1) / n) - 1;  // floor(i / n)
        const real_t d = (real_t(i) + 0.5) * h_[a] - x[a];
        const int b = box_.local(a, int(i - img * n));
        if (b >= box_.len[a]) throw std::logic_error("coarse_grain: a point's support leaves its rank's box");
        axis_[a].push_back({b, int(img), d, d * d, gauss ? std::exp(-d * d * inv2w2) : 1.0});
      }
    }
    const std::size_t n0 = std::size_t(box_.len[0]), n01 = n0 * std::size_t(box_.len[1]);
    double sum = 0;
    for (const Ax& z : axis_[2])
      for (const Ax& y : axis_[1]) {
        const real_t dyz2 = y.d2 + z.d2;
        if (dyz2 >= rs2) continue;
        const std::size_t line = n0 * std::size_t(y.i) + n01 * std::size_t(z.i);
        if (gauss) {
          const double wyz = y.g * z.g;
          for (const Ax& xx : axis_[0])
            if (dyz2 + xx.d2 < rs2) {
              const double w = wyz * xx.g;
              if (!(w > 0)) continue;
              push(line + std::size_t(xx.i), Vec3(xx.d, y.d, z.d), xx, y, z, w);
              sum += w;
            }
        } else {
          for (const Ax& xx : axis_[0]) {
            const real_t r2 = dyz2 + xx.d2;
            if (r2 >= rs2) continue;
            const double w = k_.raw(std::sqrt(r2));
            if (!(w > 0)) continue;
            push(line + std::size_t(xx.i), Vec3(xx.d, y.d, z.d), xx, y, z, w);
            sum += w;
          }
        }
      }
    if (!(sum > 0)) throw std::logic_error("coarse_grain: a kernel reaches no node (grid not checked)");
    return sum;
  }

  // visit() on a sheared grid: along each axis the node indices within the reach of x's
  // fractional coordinate (FieldGrid::index_reach, a box that covers the real-space ball), each
  // node's offset H ds from x and its kernel weight at the real-space distance |H ds| (the
  // Gaussian is not separable in the edges' axes). Ax::d holds the fractional offset ds.
  template <class Push>
  double visit_sheared(const Vec3& x, Push&& push) {
    const bool gauss = k_.type == KernelType::Gaussian;
    const real_t inv2w2 = 0.5 / (k_.width * k_.width), rs2 = rs_ * rs_;
    const Vec3 t = g_.index_coordinate(x);
    for (int a = 0; a < 3; ++a) {
      axis_[a].clear();
      const long lo = long(std::ceil(t[a] - reach_[a] - 0.5)), hi = long(std::floor(t[a] + reach_[a] - 0.5));
      const long n = g_.n[a];
      for (long i = lo; i <= hi; ++i) {
        const long img = i >= 0 ? i / n : -((-i - 1) / n) - 1;  // floor(i / n)
        const real_t ds = (real_t(i) + 0.5 - t[a]) / real_t(n);
        const int b = box_.local(a, int(i - img * n));
        if (b >= box_.len[a]) throw std::logic_error("coarse_grain: a point's support leaves its rank's box");
        axis_[a].push_back({b, int(img), ds, 0, 1.0});
      }
    }
    const std::size_t n0 = std::size_t(box_.len[0]), n01 = n0 * std::size_t(box_.len[1]);
    double sum = 0;
    for (const Ax& z : axis_[2])
      for (const Ax& y : axis_[1]) {
        const Vec3 dyz = g_.H.col(2) * z.d + g_.H.col(1) * y.d;
        const std::size_t line = n0 * std::size_t(y.i) + n01 * std::size_t(z.i);
        for (const Ax& xx : axis_[0]) {
          const Vec3 d = dyz + g_.H.col(0) * xx.d;
          const real_t r2 = d.squaredNorm();
          if (r2 >= rs2) continue;
          const double w = gauss ? std::exp(-r2 * inv2w2) : k_.raw(std::sqrt(r2));
          if (!(w > 0)) continue;
          push(line + std::size_t(xx.i), d, xx, y, z, w);
          sum += w;
        }
      }
    if (!(sum > 0)) throw std::logic_error("coarse_grain: a kernel reaches no node (grid not checked)");
    return sum;
  }

  const FieldGrid& g_;
  const FieldKernel& k_;
  const NodeBox& box_;
  Vec3 h_, reach_ = Vec3::Zero();
  real_t rs_, dv_;
  std::array<std::vector<Ax>, 3> axis_;
  std::vector<Reach> out_;
  std::vector<NodeWeight> lean_;
};

// Symmetric tensor components: 00, 11, 22, 01, 12, 02.
constexpr int kSymI[6] = {0, 1, 2, 0, 1, 0};
constexpr int kSymJ[6] = {0, 1, 2, 1, 2, 2};

Vec3 wrap_into(const Vec3& x, const Vec3& L) {
  Vec3 r = x;
  for (int a = 0; a < 3; ++a) {
    r[a] -= L[a] * std::floor(r[a] / L[a]);
    if (r[a] >= L[a]) r[a] -= L[a];
  }
  return r;
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// Composite 3-point Gauss-Legendre rule on [0, 1] in m pieces: exact for polynomials of degree 5
// on each piece; the weights add up to 1 (to rounding), so that the volume integral of the
// contact stress is the Love-Weber sum whatever m.
constexpr double kGl[3] = {-0.77459666924148337704, 0.0, 0.77459666924148337704};
constexpr double kGw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};

// Per-slot bounds from per-slot maxima of |value| and the weight bound, agreed over the ranks.
void agree_bounds(GridSums& sums, GridSums& slab, std::vector<double> vmax, double wbound, Domain& reducer) {
  reducer.max_all(std::span<double>(vmax));
  for (double& v : vmax) v *= wbound;
  sums.set_bounds(vmax);
  slab.set_bounds(vmax);
}

// How this rank holds the grid: the box of its sums and the layers of its fields; 'ex' null or
// of one rank: the whole grid, summed by an allreduce.
struct Share {
  NodeBox box;
  Layers layers;
  GridExchange* ex = nullptr;
  std::size_t field_nodes(const FieldGrid& g) const {
    return std::size_t(g.n[0]) * std::size_t(g.n[1]) * std::size_t(layers.end - layers.first);
  }
};

bool shared(const GridExchange* ex) { return ex && ex->size() > 1; }

Share share_of(const FieldGrid& g, GridExchange* ex, const BoxBuilder& items) {
  if (!shared(ex)) return {NodeBox::whole(g), {0, g.n[2]}, nullptr};
  return {items.box(), slab_of(g.n[2], ex->rank(), ex->size()), ex};
}

// Quadrature pieces of a branch: about two per kernel width (a Gaussian's w, Lucy's c / 2).
int branch_pieces(const FieldKernel& kernel, const Vec3& b) {
  const real_t resolution = kernel.type == KernelType::Gaussian ? kernel.width : 0.5 * kernel.width;
  return std::max(1, int(std::ceil(2 * b.norm() / resolution)));
}

// The box of the nodes that the particles, the contacts' quadrature points and (with the
// networks) their contact points reach: the points spread, computed as the spreading does.
BoxBuilder items_box(const FieldGrid& grid, const FieldKernel& kernel, std::span<const CgParticle> particles,
                     std::span<const CgContact> contacts, bool networks) {
  BoxBuilder box(grid, kernel.support());
  for (const CgParticle& p : particles) box.add(grid.wrap(p.x));
  for (const CgContact& c : contacts) {
    const Vec3& b = c.rec.branch;
    const Vec3 x1 = grid.wrap(c.x1);
    const int m = branch_pieces(kernel, b);
    for (int piece = 0; piece < m; ++piece)
      for (int q = 0; q < 3; ++q) box.add(x1 + ((piece + 0.5 * (1 + kGl[q])) / m) * b);
    if (networks) box.add(x1 + (c.r1 - 0.5 * c.rec.overlap) * c.rec.normal);
  }
  return box;
}

// The sums of this rank's fields: 'sums' itself on the whole grid (summed over the ranks), or
// the slab's, into which every rank's box sums are added.
GridSums& finish_sums(GridSums& sums, GridSums& slab, const Share& sh, const FieldGrid& g, Domain& reducer) {
  if (!sh.ex) {
    sums.reduce(reducer);
    return sums;
  }
  sum_into_slabs(g, sh.box, sums.row(0), sums.slots(), sh.layers, slab.row(0), *sh.ex);
  return slab;
}

Field make_field(const std::string& name, const std::string& unit, int comps, std::size_t nodes) {
  return {name, unit, comps, std::vector<double>(nodes * std::size_t(comps), 0.0)};
}

// make_field() with the storage of a field of the same name from 'recycle' when there is one.
class FieldMaker {
 public:
  explicit FieldMaker(FieldsResult* recycle) : recycle_(recycle) {}
  Field operator()(const std::string& name, const std::string& unit, int comps, std::size_t nodes) {
    if (recycle_)
      for (Field& f : recycle_->fields)
        if (f.name == name && f.values.capacity() > 0) {
          Field out{name, unit, comps, std::move(f.values)};
          out.values.assign(nodes * std::size_t(comps), 0.0);
          return out;
        }
    return make_field(name, unit, comps, nodes);
  }

 private:
  FieldsResult* recycle_;
};

}  // namespace

real_t FieldKernel::raw(real_t r) const {
  if (type == KernelType::Gaussian) {
    if (r >= cutoff * width) return 0;
    const real_t q = r / width;
    return std::exp(-0.5 * q * q);
  }
  if (r >= width) return 0;
  const real_t q = r / width, m = 1 - q;
  return (1 + 3 * q) * m * m * m;
}

void FieldGrid::set_matrix(const Mat3& h) {
  Mat3 off = h;
  off.diagonal().setZero();
  lengths = h.diagonal();
  sheared = !off.isZero(0);
  H = sheared ? h : Mat3::Identity();
  Hinv = sheared ? Mat3(h.inverse()) : Mat3::Identity();
}

Vec3 FieldGrid::spacing() const {
  if (!sheared) return Vec3(lengths[0] / n[0], lengths[1] / n[1], lengths[2] / n[2]);
  return Vec3(H.col(0).norm() / n[0], H.col(1).norm() / n[1], H.col(2).norm() / n[2]);
}

Vec3 FieldGrid::node(int i, int j, int k) const {
  if (sheared) return H * Vec3((i + 0.5) / n[0], (j + 0.5) / n[1], (k + 0.5) / n[2]);
  const Vec3 h = spacing();
  return Vec3((i + 0.5) * h[0], (j + 0.5) * h[1], (k + 0.5) * h[2]);
}

Vec3 FieldGrid::wrap(const Vec3& x) const {
  if (!sheared) return wrap_into(x, lengths);
  return H * wrap_into(Hinv * x, Vec3::Ones());
}

double FieldGrid::layer_coordinate(const Vec3& x) const {
  const double z = sheared ? double((Hinv * x)[2]) : x[2] / lengths[2];
  return z - std::floor(z);
}

Vec3 FieldGrid::index_coordinate(const Vec3& x) const {
  const Vec3 s = Hinv * x;
  return Vec3(s[0] * n[0], s[1] * n[1], s[2] * n[2]);
}

Vec3 FieldGrid::index_reach(real_t r) const {
  return Vec3(r * Hinv.row(0).norm() * n[0], r * Hinv.row(1).norm() * n[1], r * Hinv.row(2).norm() * n[2]);
}

real_t FieldGrid::half_diagonal() const {
  if (!sheared) return 0.5 * spacing().norm();
  const Vec3 e0 = H.col(0) / n[0], e1 = H.col(1) / n[1], e2 = H.col(2) / n[2];
  real_t d = 0;
  for (const real_t a : {-1.0, 1.0})
    for (const real_t b : {-1.0, 1.0}) d = std::max(d, (e0 + a * e1 + b * e2).norm());
  return 0.5 * d;
}

std::vector<double> node_positions(const FieldGrid& grid, Layers layers) {
  std::vector<double> out;
  out.reserve(std::size_t(std::max(0, layers.end - layers.first)) * std::size_t(grid.n[0]) * std::size_t(grid.n[1]) *
              3);
  for (int k = layers.first; k < layers.end; ++k)
    for (int j = 0; j < grid.n[1]; ++j)
      for (int i = 0; i < grid.n[0]; ++i) {
        const Vec3 x = grid.node(i, j, k);
        out.insert(out.end(), {x[0], x[1], x[2]});
      }
  return out;
}

Mat3 deformed_reference_edges(const Mat3& H0, const Mat3& H1) {
  const Mat3 R = H0.inverse() * H1;
  Mat3 M;
  double off = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) M(i, j) = std::nearbyint(R(i, j)), off = std::max(off, std::abs(R(i, j) - M(i, j)));
  if (!(off <= kFlipTolerance))
    throw std::domain_error(
        "the cell deformed too much between the two instants to tell a flip of its edges from the "
        "deformation (H0^-1 H1 is " +
        num(off) + " from an integer matrix, beyond " + num(kFlipTolerance) + "): take the instants closer together");
  if (M.isIdentity(0)) return H1;
  const double det = M.determinant();
  if (std::abs(det) != 1) throw std::domain_error("the cell's edges changed by a matrix of determinant " + num(det));
  // The exact integer inverse (the adjugate over a determinant of +-1).
  Mat3 Minv;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int a = (j + 1) % 3, b = (j + 2) % 3, c = (i + 1) % 3, d = (i + 2) % 3;
      Minv(i, j) = (M(a, c) * M(b, d) - M(a, d) * M(b, c)) * det;
    }
  return H1 * Minv;
}

const Field& FieldsResult::field(const std::string& name) const {
  for (const Field& f : fields)
    if (f.name == name) return f;
  throw std::out_of_range("no field '" + name + "'");
}

std::string check_field_grid(const FieldGrid& grid, const FieldKernel& kernel, real_t min_radius) {
  for (int a = 0; a < 3; ++a)
    if (grid.n[a] < 1)
      return "the grid needs at least 1 node along each axis (cells " + std::to_string(grid.n[0]) + " " +
          std::to_string(grid.n[1]) + " " + std::to_string(grid.n[2]) + ")";
  if (grid.sheared) {
    const real_t det = grid.H.determinant();
    if (!(det > 0) || !std::isfinite(det) || !grid.Hinv.allFinite())
      return "the cell's matrix must have a positive determinant";
  } else {
    for (int a = 0; a < 3; ++a)
      if (!(grid.lengths[a] > 0) || !std::isfinite(grid.lengths[a])) return "the cell's lengths must be positive";
  }
  if (!(kernel.width > 0) || !std::isfinite(kernel.width))
    return "kernel width " + num(kernel.width) + " m: must be positive";
  if (kernel.type == KernelType::Gaussian && (!(kernel.cutoff >= 1) || !std::isfinite(kernel.cutoff)))
    return "Gaussian cut-off " + num(kernel.cutoff) + " (in widths): must be at least 1";
  if (kernel.width < min_radius)
    return "kernel width " + num(kernel.width) + " m is below the smallest sphere radius " + num(min_radius) +
        " m: the fields would resolve the inside of the spheres";
  const real_t half_diagonal = grid.half_diagonal();
  if (!(kernel.support() > half_diagonal) || !(kernel.raw(half_diagonal) > 0))
    return "the kernel's support radius " + num(kernel.support()) +
        " m does not reach the nearest node from every point (half the " +
        (grid.sheared ? "longest diagonal of a grid cell, a parallelepiped, is " : "diagonal of a grid cell is ") +
        num(half_diagonal) + " m): give more cells or a wider kernel";
  return {};
}

bool field_quantity_known(const std::string& name) {
  static const std::array<std::string_view, 11> plain = {
      "solid_fraction", "density",  "velocity",     "kinetic_stress",        "contact_stress",  "stress",
      "spin",           "networks", "displacement", "displacement_gradient", "strain_increment"};
  if (std::find(plain.begin(), plain.end(), name) != plain.end()) return true;
  for (std::string_view k : kNetworkNames)
    if (name == "contact_density_" + std::string(k) || name == "fabric_" + std::string(k)) return true;
  return false;
}

double field_bytes(const FieldGrid& grid, const FieldKernel& kernel, int ranks) {
  // 79 slots of 16 bytes (the fixed-point sums: 23, and 7 for each of the 8 classes of contacts;
  // the displacement fields' 22 reuse them), a contact's branch weight and at most 208 doubles of
  // result a node (193 of coarse_grain(), 15 of displacement_fields(), held together).
  constexpr double kSums = 79.0 * 16, kResult = 208.0 * 8;
  if (ranks <= 1) return double(grid.nodes()) * (kSums + kResult + 8);
  const double nz = grid.n[2], plane = double(grid.n[0]) * double(grid.n[1]);
  // The reach: the support, the box's margin of one node and about one more for a contact's branch.
  const double slab = std::ceil(nz / ranks),
               reach = std::ceil(grid.sheared ? grid.index_reach(kernel.support())[2]
                                              : kernel.support() / grid.spacing()[2]) +
      2;
  const double box = std::min(nz, slab + 2 * reach + 1);
  // The box's sums and branch weights, the slab's sums and fields, a layer's message in and out.
  return plane * (box * (kSums + 8) + slab * (kSums + kResult) + 2 * kSums) + 8.0 * double(grid.nodes());
}

FieldsResult coarse_grain(const FieldGrid& grid, const FieldKernel& kernel, std::span<const CgParticle> particles,
                          std::span<const CgContact> contacts, const FieldOptions& options, Domain& reducer,
                          FieldsResult* recycle, GridExchange* exchange) {
  FieldsResult out;
  out.grid = grid, out.kernel = kernel;
  const Share sh =
      share_of(grid, exchange,
               shared(exchange) ? items_box(grid, kernel, particles, contacts, options.networks) : BoxBuilder(grid, 0));
  const std::size_t N = sh.field_nodes(grid);  // the nodes of this rank's fields
  out.layers = sh.layers, out.sum_nodes = sh.box.nodes();

  // The strong / weak threshold: the global mean f_n, summed exactly (as core/fabric.cpp).
  {
    ExactSums s(1);
    for (const CgContact& c : contacts) s.add(0, c.rec.fn);
    s.normalize();
    std::vector<std::int64_t> buf(s.words().begin(), s.words().end());
    buf.push_back(std::int64_t(contacts.size()));
    buf.push_back(std::int64_t(particles.size()));
    reducer.sum_all(std::span<std::int64_t>(buf));
    std::copy(buf.begin(), buf.end() - 2, s.words().begin());
    s.normalize();
    out.contacts = buf[buf.size() - 2];
    out.particles = buf.back();
    out.strong_threshold = out.contacts > 0 ? options.strong_ratio * (s.value(0) / real_t(out.contacts)) : 0.0;
  }

  // Slots: particle sums, the contact stress, and per class of contacts (sliding, rolling,
  // strong: 8 classes) the count and n n. Each network is a union of classes (its sums are
  // the classes' integers added after the reduction: exact, the same integers as summing each
  // contact into each of its 6 networks, at a sixth of the additions).
  constexpr std::size_t kVol = 0, kM = 1, kMv = 2, kMvv = 5, kMw = 11, kFb = 14, kNet = 23, kPerNet = 7;
  constexpr std::size_t kClasses = 8;
  const std::size_t slots = options.networks ? kNet + kPerNet * kClasses : kNet;
  GridSums sums(sh.box.nodes(), slots), slab(sh.ex ? N : 0, slots, 1);
  Spreader sp(grid, kernel, sh.box);
  const auto class_of = [](bool sliding, bool rolling, bool strong) {
    return std::size_t(sliding) * 4 + std::size_t(rolling) * 2 + std::size_t(strong);
  };
  // The classes of each network, from contact_networks() itself (strong: f_n above any threshold).
  std::array<std::vector<std::size_t>, kNetworks> net_classes;
  for (std::size_t cls = 0; cls < kClasses; ++cls) {
    ContactRecord rec;
    rec.sliding = cls & 4, rec.rolling = cls & 2;
    rec.fn = (cls & 1) ? std::numeric_limits<real_t>::infinity() : -std::numeric_limits<real_t>::infinity();
    for (int net : contact_networks(rec, 0.0)) net_classes[std::size_t(net)].push_back(cls);
  }

  // Bounds of every slot's values (before the kernel weight).
  {
    std::vector<double> vmax(slots, 0.0);
    auto up = [&](std::size_t s, double v) { vmax[s] = std::max(vmax[s], std::abs(v)); };
    for (const CgParticle& p : particles) {
      up(kVol, 4.0 / 3.0 * std::numbers::pi * p.radius * p.radius * p.radius);
      up(kM, p.mass);
      for (int i = 0; i < 3; ++i) {
        up(kMv + i, p.mass * p.v[i]);
        up(kMw + i, p.mass * p.w[i]);
      }
      for (int m = 0; m < 6; ++m) up(kMvv + m, p.mass * p.v[kSymI[m]] * p.v[kSymJ[m]]);
    }
    for (const CgContact& c : contacts) {
      const Vec3 f = c.rec.force();
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) up(kFb + 3 * i + j, f[i] * c.rec.branch[j]);
    }
    if (options.networks)
      for (std::size_t s = kNet; s < slots; ++s) vmax[s] = 1;  // a count's 1, |n_i n_j| <= 1
    agree_bounds(sums, slab, vmax, sp.weight_bound(), reducer);
  }

  // Spreading.
  for (const CgParticle& p : particles) {
    double v[14];
    v[kVol] = 4.0 / 3.0 * std::numbers::pi * p.radius * p.radius * p.radius;
    v[kM] = p.mass;
    for (int i = 0; i < 3; ++i) v[kMv + i] = p.mass * p.v[i], v[kMw + i] = p.mass * p.w[i];
    for (int m = 0; m < 6; ++m) v[kMvv + m] = p.mass * p.v[kSymI[m]] * p.v[kSymJ[m]];
    for (const NodeWeight& r : sp.weights(grid.wrap(p.x))) sums.add_row(r.node, 0, v, 14, r.w);
  }
  // A contact's branch weights: at each node, the sum over the quadrature points of omega_q
  // times the point's normalised weight, summed in double in the fixed order of the points (the
  // contact alone decides it), then f (x) b times it rounded once a node and component.
  std::vector<double> branch_w(sh.box.nodes(), 0.0);
  std::vector<std::size_t> touched;
  for (const CgContact& c : contacts) {
    const Vec3 f = c.rec.force();
    const Vec3& b = c.rec.branch;
    double fb[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) fb[3 * i + j] = f[i] * b[j];
    const Vec3 x1 = grid.wrap(c.x1);
    const int m = branch_pieces(kernel, b);
    touched.clear();
    for (int piece = 0; piece < m; ++piece)
      for (int q = 0; q < 3; ++q) {
        const double s = (piece + 0.5 * (1 + kGl[q])) / m, weight = 0.5 * kGw[q] / m;
        for (const NodeWeight& r : sp.weights(x1 + s * b)) {
          double& bw = branch_w[r.node];
          if (bw == 0) touched.push_back(r.node);  // weights are positive: 0 means not reached yet
          bw += weight * r.w;
        }
      }
    for (std::size_t node : touched) {
      sums.add_row(node, kFb, fb, 9, branch_w[node]);
      branch_w[node] = 0;
    }
    if (!options.networks) continue;
    const Vec3& n = c.rec.normal;
    const Vec3 xc = x1 + (c.r1 - 0.5 * c.rec.overlap) * n;
    double nn[7] = {1.0};
    for (int k = 0; k < 6; ++k) nn[1 + k] = n[kSymI[k]] * n[kSymJ[k]];
    const std::size_t base = kNet + kPerNet * class_of(c.rec.sliding, c.rec.rolling, c.rec.fn > out.strong_threshold);
    for (const NodeWeight& r : sp.weights(xc)) sums.add_row(r.node, base, nn, kPerNet, r.w);
  }
  const GridSums& fin = finish_sums(sums, slab, sh, grid, reducer);

  // The fields.
  FieldMaker make(recycle);
  Field phi = make("solid_fraction", "1", 1, N), rho = make("density", "kg/m^3", 1, N),
        vel = make("velocity", "m/s", 3, N), kin = make("kinetic_stress", "Pa", 9, N),
        con = make("contact_stress", "Pa", 9, N), tot = make("stress", "Pa", 9, N), spin = make("spin", "rad/s", 3, N);
  std::vector<Field> dens, fab;
  if (options.networks)
    for (int k = 0; k < kNetworks; ++k) {
      dens.push_back(make("contact_density_" + std::string(kNetworkNames[k]), "1/m^3", 1, N));
      fab.push_back(make("fabric_" + std::string(kNetworkNames[k]), "1", 9, N));
    }
  for (std::size_t g = 0; g < N; ++g) {
    phi.values[g] = fin.value(g, kVol);
    const double m = fin.value(g, kM);
    rho.values[g] = m;
    Vec3 mv, mw;
    for (int i = 0; i < 3; ++i) mv[i] = fin.value(g, kMv + i), mw[i] = fin.value(g, kMw + i);
    const Vec3 v = m > 0 ? Vec3(mv / m) : Vec3::Constant(kNaN);
    for (int i = 0; i < 3; ++i) {
      vel.values[3 * g + i] = v[i];
      spin.values[3 * g + i] = m > 0 ? mw[i] / m : kNaN;
    }
    for (int k = 0; k < 6; ++k) {
      const int i = kSymI[k], j = kSymJ[k];
      // sum m v' v' W = sum m v v W - (sum m v W)(sum m v W) / (sum m W)
      const double kv = m > 0 ? fin.value(g, kMvv + k) - mv[i] * mv[j] / m : 0.0;
      kin.values[9 * g + 3 * i + j] = kin.values[9 * g + 3 * j + i] = kv;
    }
    for (int k = 0; k < 9; ++k) {
      con.values[9 * g + k] = fin.value(g, kFb + k);
      tot.values[9 * g + k] = con.values[9 * g + k] + kin.values[9 * g + k];
    }
    for (std::size_t net = 0; net < dens.size(); ++net) {
      // The network's integers: its classes' (every network slot has the same grid 2^e).
      Wide t[kPerNet] = {};
      for (std::size_t cls : net_classes[net])
        for (std::size_t k = 0; k < kPerNet; ++k) t[k] += fin.raw(g, kNet + kPerNet * cls + k);
      const double c = fin.value_of(t[0], kNet);
      dens[net].values[g] = c;
      for (int k = 0; k < 6; ++k) {
        const int i = kSymI[k], j = kSymJ[k];
        fab[net].values[9 * g + 3 * i + j] = fab[net].values[9 * g + 3 * j + i] =
            c > 0 ? fin.value_of(t[1 + k], kNet + 1 + std::size_t(k)) / c : kNaN;
      }
    }
  }
  out.fields = {std::move(phi), std::move(rho), std::move(vel), std::move(kin),
                std::move(con), std::move(tot), std::move(spin)};
  for (std::size_t net = 0; net < dens.size(); ++net) {
    out.fields.push_back(std::move(dens[net]));
    out.fields.push_back(std::move(fab[net]));
  }
  return out;
}

namespace {

// Each particle's displacement, its position wrapped into the reference cell (the image rule
// moves the displacement with it; core/coarse_grain.hpp). Orthorhombic (the grid and L1 both):
// per axis, the arithmetic of every run before sheared cells; else in fractional coordinates of
// H0 and of H1' = deformed_reference_edges(H0, H1).
struct MotionTerms {
  std::vector<Vec3> x0, u;
  std::vector<double> vol;
  bool general = false;
  Vec3 dL = Vec3::Zero();  // orthorhombic: L1 - L0
  Mat3 dH = Mat3::Zero();  // general: H1' - H0, the motion of the image shifted by H0 m is (H1' - H0) m
  double shift = 0;        // a bound of that motion over the images a kernel reaches

  MotionTerms(const FieldGrid& grid, const Mat3& H1, std::span<const CgMotion> motions, real_t rs)
      : x0(motions.size()), u(motions.size()), vol(motions.size()) {
    Mat3 off = H1;
    off.diagonal().setZero();
    general = grid.sheared || !off.isZero(0);
    const Vec3& L0 = grid.lengths;
    const Vec3 L1 = H1.diagonal();
    const Mat3 H0 = grid.matrix(), H0inv = grid.sheared ? grid.Hinv : Mat3(H0.inverse());
    const Mat3 Hr = general ? deformed_reference_edges(H0, H1) : H1, Hrinv = Hr.inverse();
    dL = L1 - L0, dH = Hr - H0;
    for (std::size_t p = 0; p < motions.size(); ++p) {
      const CgMotion& m = motions[p];
      Vec3 s0, ds, xw;
      if (general) {
        s0 = wrap_into(H0inv * m.x0, Vec3::Ones()), xw = H0 * s0;
        ds = Hrinv * m.x1 - s0;
      } else {
        xw = wrap_into(m.x0, L0), s0 = xw.cwiseQuotient(L0);
        ds = m.x1.cwiseQuotient(L1) - s0;
      }
      for (int a = 0; a < 3; ++a) ds[a] -= std::nearbyint(ds[a]);
      x0[p] = xw;
      u[p] = general ? Vec3(Hr * (s0 + ds) - xw) : Vec3(L1.cwiseProduct(s0 + ds) - xw);
      vol[p] = 4.0 / 3.0 * std::numbers::pi * m.radius * m.radius * m.radius;
    }
    // |u - shift| <= max |u| + (the images' reach + 2) max |shift of one image| (positions
    // wrapped into the cell): orthorhombic (rs / L + 2) |dL| per axis.
    if (!general)
      for (int a = 0; a < 3; ++a) shift = std::max(shift, (rs / L0[a] + 2) * std::abs(dL[a]));
    else
      for (int a = 0; a < 3; ++a) shift += (rs * H0inv.row(a).norm() + 2) * dH.col(a).cwiseAbs().maxCoeff();
  }
  // The displacement of the image of a particle of displacement 'u' shifted by -H0 img.
  Vec3 image_displacement(const Vec3& u, const std::array<int, 3>& img) const {
    Vec3 ui = u;
    if (!general)
      for (int a = 0; a < 3; ++a) ui[a] -= img[a] * dL[a];
    else ui -= dH * Vec3(img[0], img[1], img[2]);
    return ui;
  }
};

}  // namespace

FieldsResult displacement_fields(const FieldGrid& grid, const FieldKernel& kernel, const Mat3& H1,
                                 std::span<const CgMotion> motions, Domain& reducer, FieldsResult* recycle,
                                 GridExchange* exchange) {
  FieldsResult out;
  out.grid = grid, out.kernel = kernel;
  {
    std::vector<std::int64_t> n{std::int64_t(motions.size())};
    reducer.sum_all(std::span<std::int64_t>(n));
    out.particles = n[0];
  }
  // Slots: sum W V, sum W V x, sum W V u, sum W V u_i x_j, sum W V x_i x_j (x relative to the node).
  constexpr std::size_t kW = 0, kX = 1, kU = 4, kUx = 7, kXx = 16, kSlots = 22;
  const real_t rs = kernel.support();

  const MotionTerms mt(grid, H1, motions, rs);
  const std::vector<Vec3>&x0 = mt.x0, &u = mt.u;
  const std::vector<double>& vol = mt.vol;
  BoxBuilder items(grid, rs);
  if (shared(exchange))
    for (const Vec3& x : x0) items.add(x);
  const Share sh = share_of(grid, exchange, items);
  const std::size_t N = sh.field_nodes(grid);  // the nodes of this rank's fields
  out.layers = sh.layers, out.sum_nodes = sh.box.nodes();
  GridSums sums(sh.box.nodes(), kSlots), slab(sh.ex ? N : 0, kSlots, 1);
  Spreader sp(grid, kernel, sh.box);
  {
    double vmax = 0, umax = 0;
    for (std::size_t p = 0; p < motions.size(); ++p) {
      vmax = std::max(vmax, vol[p]);
      umax = std::max(umax, u[p].cwiseAbs().maxCoeff());
    }
    std::vector<double> lim{vmax, umax};
    reducer.max_all(std::span<double>(lim));
    const double V = lim[0], U = lim[1] + mt.shift;
    std::vector<double> b(kSlots);
    b[kW] = V;
    for (int i = 0; i < 3; ++i) b[kX + i] = V * rs, b[kU + i] = V * U;
    for (int k = 0; k < 9; ++k) b[kUx + k] = V * U * rs;
    for (int k = 0; k < 6; ++k) b[kXx + k] = V * rs * rs;
    for (double& v : b) v *= sp.weight_bound();
    sums.set_bounds(b);
    slab.set_bounds(b);
  }
  for (std::size_t p = 0; p < motions.size(); ++p) {
    for (const Reach& r : sp.reach(x0[p])) {
      const Vec3 x = -r.d;  // the image's position relative to the node
      const Vec3 ui = mt.image_displacement(u[p], r.img);
      const double w = vol[p] * r.w;
      sums.add(r.node, kW, w);
      for (int i = 0; i < 3; ++i) sums.add(r.node, kX + i, x[i] * w), sums.add(r.node, kU + i, ui[i] * w);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) sums.add(r.node, kUx + 3 * i + j, ui[i] * x[j] * w);
      for (int k = 0; k < 6; ++k) sums.add(r.node, kXx + k, x[kSymI[k]] * x[kSymJ[k]] * w);
    }
  }
  const GridSums& fin = finish_sums(sums, slab, sh, grid, reducer);

  FieldMaker make(recycle);
  Field disp = make("displacement", "m", 3, N), grad = make("displacement_gradient", "1", 9, N),
        strain = make("strain_increment", "1", 9, N);
  for (std::size_t g = 0; g < N; ++g) {
    const double w = fin.value(g, kW);
    Vec3 sx, su;
    Mat3 sux, sxx;
    for (int i = 0; i < 3; ++i) sx[i] = fin.value(g, kX + i), su[i] = fin.value(g, kU + i);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) sux(i, j) = fin.value(g, kUx + 3 * i + j);
    for (int k = 0; k < 6; ++k) sxx(kSymI[k], kSymJ[k]) = sxx(kSymJ[k], kSymI[k]) = fin.value(g, kXx + k);
    Mat3 G = Mat3::Constant(kNaN);
    Vec3 ubar = Vec3::Constant(kNaN);
    if (w > 0) {
      ubar = su / w;
      const Mat3 cxx = sxx - sx * sx.transpose() / w, cux = sux - su * sx.transpose() / w;
      const Eigen::SelfAdjointEigenSolver<Mat3> es(cxx, Eigen::EigenvaluesOnly);
      const Vec3 ev = es.eigenvalues();
      if (ev[0] > 1e-9 * ev[2]) G = cux * cxx.inverse();
    }
    const Mat3 E = 0.5 * (G + G.transpose());
    for (int i = 0; i < 3; ++i) {
      disp.values[3 * g + i] = ubar[i];
      for (int j = 0; j < 3; ++j) grad.values[9 * g + 3 * i + j] = G(i, j), strain.values[9 * g + 3 * i + j] = E(i, j);
    }
  }
  out.fields = {std::move(disp), std::move(grad), std::move(strain)};
  return out;
}

}  // namespace fabrica
