#include "core/coarse_grain.hpp"

#include "core/exact_sum.hpp"

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
  GridSums(std::size_t nodes, std::size_t slots) : slots_(slots), acc_(nodes * slots, 0), e_(slots, 0) {}

  // bound[s]: an upper bound of |term| over every term of slot s on every rank.
  void set_bounds(std::span<const double> bound) {
    for (std::size_t s = 0; s < slots_; ++s)
      e_[s] = bound[s] > 0 && std::isfinite(bound[s]) ? std::ilogb(bound[s]) + 1 - 84 : 0;
  }

  void add(std::size_t node, std::size_t slot, double x) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(x);
    const int field = int((bits >> 52) & 0x7ff);
    if (field == 0x7ff) throw std::domain_error("coarse_grain: non-finite term");
    if (field == 0) return;  // zero or subnormal: far below the grid
    std::uint64_t mant = (bits & ((std::uint64_t(1) << 52) - 1)) | (std::uint64_t(1) << 52);
    const int pos = field - 1075 - e_[slot];  // |x| 2^-e = mant 2^pos
    Wide v;
    if (pos < 0) {
      if (pos <= -53) return;
      v = Wide(mant >> -pos);
    } else {
      if (pos > 40) throw std::logic_error("coarse_grain: a term exceeds its slot's bound");
      v = Wide(mant) << pos;
    }
    Wide& a = acc_[node * slots_ + slot];
    a += (bits >> 63) ? -v : v;
  }

  // Sums the grids of every rank, exactly: each 128-bit integer as four 32-bit digits in int64
  // words (the top one signed), summed as integers, in chunks of at most 2^18 slots.
  void reduce(Domain& reducer) {
    const std::size_t total = acc_.size(), chunk = std::size_t(1) << 18;
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
  double value(std::size_t node, std::size_t slot) const {
    const Wide a = acc_[node * slots_ + slot];
    return std::ldexp(static_cast<double>(a), e_[slot]);
  }

 private:
  std::size_t slots_;
  std::vector<Wide> acc_;
  std::vector<int> e_;
};

// The nodes a kernel centred at x reaches, with their normalised weights (sum w dV = 1).
struct Reach {
  std::size_t node;
  Vec3 d;                  // X_node - x (the node's position relative to the image of x it sees), m
  std::array<int, 3> img;  // the image: the node sees x - img (.) L
  double w;                // 1/m^3
};

class Spreader {
 public:
  Spreader(const FieldGrid& g, const FieldKernel& k) : g_(g), k_(k), h_(g.spacing()), rs_(k.support()) {}

  // Fills 'out' with the nodes within the support of x (any real position), in a fixed order.
  const std::vector<Reach>& reach(const Vec3& x) {
    out_.clear();
    for (int a = 0; a < 3; ++a) {
      axis_[a].clear();
      const long lo = long(std::ceil((x[a] - rs_) / h_[a] - 0.5)), hi = long(std::floor((x[a] + rs_) / h_[a] - 0.5));
      const long n = g_.n[a];
      for (long i = lo; i <= hi; ++i) {
        const long img = i >= 0 ? i / n : -((-i - 1) / n) - 1;  // floor(i / n)
        axis_[a].push_back({int(i - img * n), int(img), (real_t(i) + 0.5) * h_[a] - x[a]});
      }
    }
    double sum = 0;
    for (const Ax& z : axis_[2])
      for (const Ax& y : axis_[1])
        for (const Ax& xx : axis_[0]) {
          const Vec3 d(xx.d, y.d, z.d);
          const real_t r = d.norm();
          if (r >= rs_) continue;
          const double w = k_.raw(r);
          if (!(w > 0)) continue;
          const std::size_t node =
              std::size_t(xx.i) + std::size_t(g_.n[0]) * (std::size_t(y.i) + std::size_t(g_.n[1]) * std::size_t(z.i));
          out_.push_back({node, d, {xx.img, y.img, z.img}, w});
          sum += w;
        }
    if (!(sum > 0)) throw std::logic_error("coarse_grain: a kernel reaches no node (grid not checked)");
    const double scale = 1.0 / (sum * g_.cell_volume());
    for (Reach& r : out_) r.w *= scale;
    return out_;
  }

  // An upper bound of every normalised weight: W(0) over (W at the farthest a nearest node can
  // be, half the cell's diagonal, times dV).
  double weight_bound() const { return k_.raw(0) / (k_.raw(0.5 * h_.norm()) * g_.cell_volume()); }

 private:
  struct Ax {
    int i, img;
    real_t d;
  };
  const FieldGrid& g_;
  const FieldKernel& k_;
  Vec3 h_;
  real_t rs_;
  std::array<std::vector<Ax>, 3> axis_;
  std::vector<Reach> out_;
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
void agree_bounds(GridSums& sums, std::vector<double> vmax, double wbound, Domain& reducer) {
  reducer.max_all(std::span<double>(vmax));
  for (double& v : vmax) v *= wbound;
  sums.set_bounds(vmax);
}

Field make_field(const std::string& name, const std::string& unit, int comps, std::size_t nodes) {
  return {name, unit, comps, std::vector<double>(nodes * std::size_t(comps), 0.0)};
}

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

Vec3 FieldGrid::node(int i, int j, int k) const {
  const Vec3 h = spacing();
  return Vec3((i + 0.5) * h[0], (j + 0.5) * h[1], (k + 0.5) * h[2]);
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
  for (int a = 0; a < 3; ++a)
    if (!(grid.lengths[a] > 0) || !std::isfinite(grid.lengths[a])) return "the cell's lengths must be positive";
  if (!(kernel.width > 0) || !std::isfinite(kernel.width))
    return "kernel width " + num(kernel.width) + " m: must be positive";
  if (kernel.type == KernelType::Gaussian && (!(kernel.cutoff >= 1) || !std::isfinite(kernel.cutoff)))
    return "Gaussian cut-off " + num(kernel.cutoff) + " (in widths): must be at least 1";
  if (kernel.width < min_radius)
    return "kernel width " + num(kernel.width) + " m is below the smallest sphere radius " + num(min_radius) +
        " m: the fields would resolve the inside of the spheres";
  const real_t half_diagonal = 0.5 * grid.spacing().norm();
  if (!(kernel.support() > half_diagonal) || !(kernel.raw(half_diagonal) > 0))
    return "the kernel's support radius " + num(kernel.support()) +
        " m does not reach the nearest node from every point (half the diagonal of a grid cell is " +
        num(half_diagonal) + " m): give more cells or a wider kernel";
  return {};
}

bool field_quantity_known(const std::string& name) {
  static const std::array<std::string_view, 8> plain = {"solid_fraction", "density", "velocity", "kinetic_stress",
                                                        "contact_stress", "stress",  "spin",     "networks"};
  if (std::find(plain.begin(), plain.end(), name) != plain.end()) return true;
  for (std::string_view k : kNetworkNames)
    if (name == "contact_density_" + std::string(k) || name == "fabric_" + std::string(k)) return true;
  return false;
}

double field_bytes(const FieldGrid& grid) {
  // 128 slots of 16 bytes (the fixed-point sums) and at most 193 doubles of result a node.
  return double(grid.nodes()) * (128.0 * 16 + 193.0 * 8);
}

FieldsResult coarse_grain(const FieldGrid& grid, const FieldKernel& kernel, std::span<const CgParticle> particles,
                          std::span<const CgContact> contacts, const FieldOptions& options, Domain& reducer) {
  FieldsResult out;
  out.grid = grid, out.kernel = kernel;
  const std::size_t N = grid.nodes();
  const Vec3& L = grid.lengths;

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

  // Slots: particle sums, the contact stress, per network the count and n n.
  constexpr std::size_t kVol = 0, kM = 1, kMv = 2, kMvv = 5, kMw = 11, kFb = 14, kNet = 23, kPerNet = 7;
  const std::size_t slots = options.networks ? kNet + kPerNet * kNetworks : kNet;
  GridSums sums(N, slots);
  Spreader sp(grid, kernel);

  // Quadrature pieces of a branch: about two per kernel width (a Gaussian's w, Lucy's c / 2).
  const real_t resolution = kernel.type == KernelType::Gaussian ? kernel.width : 0.5 * kernel.width;
  auto pieces = [&](const Vec3& b) { return std::max(1, int(std::ceil(2 * b.norm() / resolution))); };

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
      for (std::size_t k = 0; k < std::size_t(kNetworks); ++k)
        for (std::size_t m = 0; m < kPerNet; ++m) vmax[kNet + kPerNet * k + m] = 1;  // |n_i n_j| <= 1
    agree_bounds(sums, vmax, sp.weight_bound(), reducer);
  }

  // Spreading.
  for (const CgParticle& p : particles) {
    const double vol = 4.0 / 3.0 * std::numbers::pi * p.radius * p.radius * p.radius;
    for (const Reach& r : sp.reach(wrap_into(p.x, L))) {
      sums.add(r.node, kVol, vol * r.w);
      sums.add(r.node, kM, p.mass * r.w);
      for (int i = 0; i < 3; ++i) {
        sums.add(r.node, kMv + i, p.mass * p.v[i] * r.w);
        sums.add(r.node, kMw + i, p.mass * p.w[i] * r.w);
      }
      for (int m = 0; m < 6; ++m) sums.add(r.node, kMvv + m, p.mass * p.v[kSymI[m]] * p.v[kSymJ[m]] * r.w);
    }
  }
  for (const CgContact& c : contacts) {
    const Vec3 f = c.rec.force();
    const Vec3& b = c.rec.branch;
    double fb[9];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) fb[3 * i + j] = f[i] * b[j];
    const Vec3 x1 = wrap_into(c.x1, L);
    const int m = pieces(b);
    for (int piece = 0; piece < m; ++piece)
      for (int q = 0; q < 3; ++q) {
        const double s = (piece + 0.5 * (1 + kGl[q])) / m, weight = 0.5 * kGw[q] / m;
        for (const Reach& r : sp.reach(x1 + s * b))
          for (int k = 0; k < 9; ++k) sums.add(r.node, kFb + std::size_t(k), fb[k] * (weight * r.w));
      }
    if (!options.networks) continue;
    const Vec3& n = c.rec.normal;
    const Vec3 xc = x1 + (c.r1 - 0.5 * c.rec.overlap) * n;
    double nn[6];
    for (int k = 0; k < 6; ++k) nn[k] = n[kSymI[k]] * n[kSymJ[k]];
    const std::array<int, kPartitions> nets = contact_networks(c.rec, out.strong_threshold);
    for (const Reach& r : sp.reach(xc))
      for (int net : nets) {
        const std::size_t base = kNet + kPerNet * std::size_t(net);
        sums.add(r.node, base, r.w);
        for (int k = 0; k < 6; ++k) sums.add(r.node, base + 1 + std::size_t(k), nn[k] * r.w);
      }
  }
  sums.reduce(reducer);

  // The fields.
  Field phi = make_field("solid_fraction", "1", 1, N), rho = make_field("density", "kg/m^3", 1, N),
        vel = make_field("velocity", "m/s", 3, N), kin = make_field("kinetic_stress", "Pa", 9, N),
        con = make_field("contact_stress", "Pa", 9, N), tot = make_field("stress", "Pa", 9, N),
        spin = make_field("spin", "rad/s", 3, N);
  std::vector<Field> dens, fab;
  if (options.networks)
    for (int k = 0; k < kNetworks; ++k) {
      dens.push_back(make_field("contact_density_" + std::string(kNetworkNames[k]), "1/m^3", 1, N));
      fab.push_back(make_field("fabric_" + std::string(kNetworkNames[k]), "1", 9, N));
    }
  for (std::size_t g = 0; g < N; ++g) {
    phi.values[g] = sums.value(g, kVol);
    const double m = sums.value(g, kM);
    rho.values[g] = m;
    Vec3 mv, mw;
    for (int i = 0; i < 3; ++i) mv[i] = sums.value(g, kMv + i), mw[i] = sums.value(g, kMw + i);
    const Vec3 v = m > 0 ? Vec3(mv / m) : Vec3::Constant(kNaN);
    for (int i = 0; i < 3; ++i) {
      vel.values[3 * g + i] = v[i];
      spin.values[3 * g + i] = m > 0 ? mw[i] / m : kNaN;
    }
    for (int k = 0; k < 6; ++k) {
      const int i = kSymI[k], j = kSymJ[k];
      // sum m v' v' W = sum m v v W - (sum m v W)(sum m v W) / (sum m W)
      const double kv = m > 0 ? sums.value(g, kMvv + k) - mv[i] * mv[j] / m : 0.0;
      kin.values[9 * g + 3 * i + j] = kin.values[9 * g + 3 * j + i] = kv;
    }
    for (int k = 0; k < 9; ++k) {
      con.values[9 * g + k] = sums.value(g, kFb + k);
      tot.values[9 * g + k] = con.values[9 * g + k] + kin.values[9 * g + k];
    }
    for (std::size_t net = 0; net < dens.size(); ++net) {
      const std::size_t base = kNet + kPerNet * net;
      const double c = sums.value(g, base);
      dens[net].values[g] = c;
      for (int k = 0; k < 6; ++k) {
        const int i = kSymI[k], j = kSymJ[k];
        fab[net].values[9 * g + 3 * i + j] = fab[net].values[9 * g + 3 * j + i] =
            c > 0 ? sums.value(g, base + 1 + std::size_t(k)) / c : kNaN;
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

FieldsResult displacement_fields(const FieldGrid& grid, const FieldKernel& kernel, const Vec3& L1,
                                 std::span<const CgMotion> motions, Domain& reducer) {
  FieldsResult out;
  out.grid = grid, out.kernel = kernel;
  const std::size_t N = grid.nodes();
  const Vec3& L0 = grid.lengths;
  const Vec3 dL = L1 - L0;
  {
    std::vector<std::int64_t> n{std::int64_t(motions.size())};
    reducer.sum_all(std::span<std::int64_t>(n));
    out.particles = n[0];
  }
  // Slots: sum W V, sum W V x, sum W V u, sum W V u_i x_j, sum W V x_i x_j (x relative to the node).
  constexpr std::size_t kW = 0, kX = 1, kU = 4, kUx = 7, kXx = 16, kSlots = 22;
  GridSums sums(N, kSlots);
  Spreader sp(grid, kernel);
  const real_t rs = kernel.support();

  // Each particle's displacement, its position wrapped into the reference cell (the image
  // rule moves the displacement with it).
  std::vector<Vec3> x0(motions.size()), u(motions.size());
  std::vector<double> vol(motions.size());
  for (std::size_t p = 0; p < motions.size(); ++p) {
    const CgMotion& m = motions[p];
    const Vec3 xw = wrap_into(m.x0, L0);
    const Vec3 s0 = xw.cwiseQuotient(L0);
    Vec3 ds = m.x1.cwiseQuotient(L1) - s0;
    for (int a = 0; a < 3; ++a) ds[a] -= std::nearbyint(ds[a]);
    x0[p] = xw;
    u[p] = L1.cwiseProduct(s0 + ds) - xw;
    vol[p] = 4.0 / 3.0 * std::numbers::pi * m.radius * m.radius * m.radius;
  }
  {
    double vmax = 0, umax = 0;
    for (std::size_t p = 0; p < motions.size(); ++p) {
      vmax = std::max(vmax, vol[p]);
      umax = std::max(umax, u[p].cwiseAbs().maxCoeff());
    }
    // |u - k (.) dL| <= max |u| + (rs / L + 2) max |dL| (positions wrapped into [0, L0)).
    double shift = 0;
    for (int a = 0; a < 3; ++a) shift = std::max(shift, (rs / L0[a] + 2) * std::abs(dL[a]));
    std::vector<double> lim{vmax, umax};
    reducer.max_all(std::span<double>(lim));
    const double V = lim[0], U = lim[1] + shift;
    std::vector<double> b(kSlots);
    b[kW] = V;
    for (int i = 0; i < 3; ++i) b[kX + i] = V * rs, b[kU + i] = V * U;
    for (int k = 0; k < 9; ++k) b[kUx + k] = V * U * rs;
    for (int k = 0; k < 6; ++k) b[kXx + k] = V * rs * rs;
    for (double& v : b) v *= sp.weight_bound();
    sums.set_bounds(b);
  }
  for (std::size_t p = 0; p < motions.size(); ++p) {
    for (const Reach& r : sp.reach(x0[p])) {
      const Vec3 x = -r.d;  // the image's position relative to the node
      Vec3 ui = u[p];
      for (int a = 0; a < 3; ++a) ui[a] -= r.img[a] * dL[a];
      const double w = vol[p] * r.w;
      sums.add(r.node, kW, w);
      for (int i = 0; i < 3; ++i) sums.add(r.node, kX + i, x[i] * w), sums.add(r.node, kU + i, ui[i] * w);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) sums.add(r.node, kUx + 3 * i + j, ui[i] * x[j] * w);
      for (int k = 0; k < 6; ++k) sums.add(r.node, kXx + k, x[kSymI[k]] * x[kSymJ[k]] * w);
    }
  }
  sums.reduce(reducer);

  Field disp = make_field("displacement", "m", 3, N), grad = make_field("displacement_gradient", "1", 9, N),
        strain = make_field("strain_increment", "1", 9, N);
  for (std::size_t g = 0; g < N; ++g) {
    const double w = sums.value(g, kW);
    Vec3 sx, su;
    Mat3 sux, sxx;
    for (int i = 0; i < 3; ++i) sx[i] = sums.value(g, kX + i), su[i] = sums.value(g, kU + i);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) sux(i, j) = sums.value(g, kUx + 3 * i + j);
    for (int k = 0; k < 6; ++k) sxx(kSymI[k], kSymJ[k]) = sxx(kSymJ[k], kSymI[k]) = sums.value(g, kXx + k);
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
