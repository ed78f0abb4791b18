#include "core/forces.hpp"

#include "core/contact_law.hpp"

#include <algorithm>
#include <array>
#include <limits>

namespace fabrica {
namespace {

// Out of the loop's way: reached only by an overlap beyond the geometric limit.
[[gnu::cold, gnu::noinline]] void note_overlap(OverlapAlarm* alarm, real_t un, real_t radius,
                                               GlobalId a, GlobalId b) {
  if (!alarm) return;
  const real_t ratio = un / radius;
  if (ratio > alarm->ratio) *alarm = OverlapAlarm{ratio, un, radius, a, b};
}

template <bool Rolling, bool Viscous, bool Measure>
void pair_forces(Particles& P, const PeriodicCell& cell, const ForceContext& ctx, PairList& pl,
                 Dissipation& diss, ContactSums* sums) {
  const Vec3& L = cell.lengths();
  const Vec3& edot = cell.strain_rate();
  std::array<Vec3, 27> shift;
  for (int c = 0; c < 27; ++c) shift[c] = image_offset(c, L);
  const ContactLawParams& law = ctx.law;
  const real_t dt = ctx.dt;

  const Vec3* x = P.x.data();
  const Vec3* v = P.v.data();
  const Vec3* w = P.w.data();
  const real_t* R = P.radius.data();
  const real_t* m = P.mass.data();
  Vec3* f = P.f.data();
  Vec3* t = P.t.data();
  const Index* pi = pl.i.data();
  const Index* pj = pl.j.data();
  const std::uint8_t* img = pl.image.data();
  std::uint8_t* touching = pl.touching.data();
  Vec3* fs = pl.fs.data();
  Vec3* mr = Rolling ? pl.mr.data() : nullptr;

  real_t e_fric = 0, e_roll = 0, e_visc = 0;
  const std::size_t np = pl.size();
  const std::size_t n_owned = P.n_owned();
  // The pairs follow a space-filling curve (neighbor.hpp), so most partners are near in memory,
  // but the curve's jumps and the second body of each pair are not: fetch the positions and
  // radii of the pair kAhead places on. Changes no result (it paid 7 % of the whole step on
  // dense-13584 when the list was in id order, benchmarks/README.md).
  constexpr std::size_t kAhead = 8;
  for (std::size_t q = 0; q < np; ++q) {
    if (q + kAhead < np) {
      const Index ia = pi[q + kAhead], ja = pj[q + kAhead];
      __builtin_prefetch(&x[ia]);
      __builtin_prefetch(&x[ja]);
      __builtin_prefetch(&R[ia]);
      __builtin_prefetch(&R[ja]);
    }
    const Index i = pi[q], j = pj[q];
    const Vec3 d = x[j] + shift[img[q]] - x[i];
    const real_t sum_r = R[i] + R[j];
    const real_t r2 = d.squaredNorm();
    if (r2 >= sum_r * sum_r) {
      if (touching[q]) {  // the contact opens: the energy left in its springs is lost
        touching[q] = 0;
        const PairConstants c = pair_constants<Rolling, false>(law, R[i], R[j], m[i], m[j]);
        const real_t own_i = std::size_t(i) < n_owned ? 1.0 : 0.0;
        e_fric += own_i * 0.5 * fs[q].squaredNorm() / c.ks;
        fs[q].setZero();
        if constexpr (Rolling) {
          e_roll += own_i * 0.5 * mr[q].squaredNorm() / c.kr;
          mr[q].setZero();
        }
      }
      continue;
    }
    touching[q] = 1;
    const real_t dist = std::sqrt(r2);
    ContactKinematics k;
    k.n = d / dist;
    k.un = sum_r - dist;
    if (k.un > kMaxOverlapRatio * std::min(R[i], R[j]) && std::size_t(i) < n_owned) [[unlikely]]
      note_overlap(ctx.alarm, k.un, std::min(R[i], R[j]), P.id[i], P.id[j]);
    const real_t a1 = R[i] - 0.5 * k.un, a2 = R[j] - 0.5 * k.un;
    k.w1 = w[i];
    k.w2 = w[j];
    k.vrel = v[j] - v[i] + edot.cwiseProduct(d) - (a2 * w[j] + a1 * w[i]).cross(k.n);
    const PairConstants c = pair_constants<Rolling, Viscous>(law, R[i], R[j], m[i], m[j]);
    ContactHistory h;
    h.fs = fs[q];
    if constexpr (Rolling) h.mr = mr[q];
    // Assigned, not initialised, on purpose. The law is out of line here and returns its
    // 96-byte result through memory, writing fn with an 8-byte store, fs.xy with a 16-byte one
    // and fs.z with an 8-byte one. Initialised in place, GCC 12 reads fs back for the cross
    // product with 16-byte loads that straddle two of those stores ({fn, fs.x}, {fs.y, fs.z}),
    // so store-to-load forwarding fails twice per contact: 6 to 7 % of this loop with the
    // features off (benchmarks/README.md, "Zero cost of unused features"). Assigned, the
    // result is copied with loads that match the law's stores. Same arithmetic, same bits.
    ContactResult r;
    r = contact_law<Rolling, Viscous>(law, c, k, h, dt);
    fs[q] = h.fs;
    if constexpr (Rolling) mr[q] = h.mr;

    const Vec3 F = r.fn * k.n + r.fs;  // on j
    const Vec3 nxfs = k.n.cross(r.fs);
    f[j] += F;
    f[i] -= F;
    if constexpr (Rolling) {
      t[j] += r.mr - a2 * nxfs;
      t[i] -= r.mr + a1 * nxfs;
    } else {
      t[j] -= a2 * nxfs;
      t[i] -= a1 * nxfs;
    }
    // A pair between an owned particle and a ghost is computed on both ranks; its energy and
    // its share of the measures belong to the rank that owns body i (the lower id).
    const real_t own_i = std::size_t(i) < n_owned ? 1.0 : 0.0;
    e_fric += own_i * r.e_friction;
    if constexpr (Rolling) e_roll += own_i * r.e_rolling;
    if constexpr (Viscous) e_visc += own_i * r.e_viscous;
    if constexpr (Measure) {
      if (own_i != 0.0) {
        sums->fb.noalias() += F * d.transpose();
        ++sums->contacts;
        sums->sliding += r.sliding;
        sums->rolling += r.rolling;
        sums->e_normal += spring_energy_normal(c, k.un);
        sums->e_shear += spring_energy_shear(c, h);
        if constexpr (Rolling) sums->e_rolling += spring_energy_rolling(c, h);
        sums->sum_contact_force += F.norm();
        ++sums->contacts_per_particle[i];
        sums->sum_overlap += k.un;
        const real_t ratio = k.un / std::min(R[i], R[j]);
        if (ratio > sums->max_overlap_ratio) {
          sums->max_overlap_ratio = ratio;
          sums->max_overlap_a = P.id[i];
          sums->max_overlap_b = P.id[j];
        }
      }
      if (std::size_t(j) < n_owned) ++sums->contacts_per_particle[j];
    }
  }
  diss.friction += e_fric;
  diss.rolling += e_roll;
  diss.viscous += e_visc;
}

// Sphere (body 1) against a plane (body 2) moving at the wall's velocity, with the wall's own
// law or the scene's.
template <bool Rolling, bool Viscous, bool Measure>
void wall_forces(Particles& P, const ForceContext& ctx, WallContactList& wl, Dissipation& diss,
                 ContactSums* sums, real_t* wall_power) {
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  real_t power = 0;
  for (std::size_t q = 0; q < wl.size(); ++q) {
    const Index i = wl.i[q];
    const Wall& W = ctx.walls[wl.wall[q]];
    const ContactLawParams& law = W.own_law ? W.law : ctx.law;
    const real_t dist = (P.x[i] - W.point).dot(W.normal);
    const real_t R = P.radius[i];
    if (dist >= R) {
      if (wl.touching[q]) {  // the contact opens: the energy left in its springs is lost
        wl.touching[q] = 0;
        const PairConstants c = pair_constants<Rolling, false>(law, R, inf, P.mass[i], inf);
        diss.friction += 0.5 * wl.fs[q].squaredNorm() / c.ks;
        wl.fs[q].setZero();
        if constexpr (Rolling) {
          if (c.kr > 0) diss.rolling += 0.5 * wl.mr[q].squaredNorm() / c.kr;
          wl.mr[q].setZero();
        }
      }
      continue;
    }
    wl.touching[q] = 1;
    ContactKinematics k;
    k.n = -W.normal;
    k.un = R - dist;
    if (k.un > kMaxOverlapRatio * R) [[unlikely]]
      note_overlap(ctx.alarm, k.un, R, P.id[i], GlobalId(-1 - wl.wall[q]));
    const real_t a1 = R - 0.5 * k.un;
    k.w1 = P.w[i];
    k.w2 = Vec3::Zero();
    k.vrel = W.velocity - P.v[i] - a1 * P.w[i].cross(k.n);
    const PairConstants c = pair_constants<Rolling, Viscous>(law, R, inf, P.mass[i], inf);
    ContactHistory h;
    h.fs = wl.fs[q];
    if constexpr (Rolling) h.mr = wl.mr[q];
    const ContactResult r = contact_law<Rolling, Viscous>(law, c, k, h, ctx.dt);
    wl.fs[q] = h.fs;
    if constexpr (Rolling) wl.mr[q] = h.mr;
    const Vec3 F = r.fn * k.n + r.fs;  // on the wall
    P.f[i] -= F;
    P.t[i] -= r.mr + a1 * k.n.cross(r.fs);
    power -= F.dot(W.velocity);
    diss.friction += r.e_friction;
    diss.rolling += r.e_rolling;
    diss.viscous += r.e_viscous;
    if constexpr (Measure) {
      ++sums->wall_contacts;
      sums->fb_walls.noalias() += F * (a1 * k.n).transpose();
      sums->wall_force[wl.wall[q]] += F;
      sums->sum_contact_force += F.norm();  // walls count in the mean contact force too
      if (k.un / R > sums->max_overlap_ratio) {
        sums->max_overlap_ratio = k.un / R;
        sums->max_overlap_a = P.id[i];
        sums->max_overlap_b = -1 - wl.wall[q];
      }
      sums->e_normal += spring_energy_normal(c, k.un);
      sums->e_shear += spring_energy_shear(c, h);
      if constexpr (Rolling) sums->e_rolling += spring_energy_rolling(c, h);
      ++sums->contacts_per_particle[i];
    }
  }
  if (wall_power) *wall_power = power;
}

template <bool Rolling, bool Viscous, bool Measure>
void all_forces(Particles& p, const PeriodicCell& cell, const ForceContext& ctx, PairList& pl,
                WallContactList& wl, Dissipation& diss, ContactSums* sums, real_t* wall_power) {
  pair_forces<Rolling, Viscous, Measure>(p, cell, ctx, pl, diss, sums);
  if (wl.size() != 0) wall_forces<Rolling, Viscous, Measure>(p, ctx, wl, diss, sums, wall_power);
  else if (wall_power) *wall_power = 0;
}

using Kernel = void (*)(Particles&, const PeriodicCell&, const ForceContext&, PairList&,
                        WallContactList&, Dissipation&, ContactSums*, real_t*);

// Table indexed by rolling * 4 + viscous * 2 + measure.
constexpr std::array<Kernel, 8> kKernels = {
    all_forces<false, false, false>, all_forces<false, false, true>,
    all_forces<false, true, false>,  all_forces<false, true, true>,
    all_forces<true, false, false>,  all_forces<true, false, true>,
    all_forces<true, true, false>,   all_forces<true, true, true>,
};

}  // namespace

void compute_forces(Particles& p, const PeriodicCell& cell, const ForceContext& ctx,
                    PairList& pairs, WallContactList& wall_contacts, Dissipation& diss,
                    ContactSums* sums, real_t* wall_power) {
  const std::size_t n = p.size();
  if (ctx.gravity.isZero()) {
    for (std::size_t a = 0; a < n; ++a) p.f[a].setZero();
  } else {
    for (std::size_t a = 0; a < n; ++a) p.f[a] = p.mass[a] * ctx.gravity;
  }
  for (std::size_t a = 0; a < n; ++a) p.t[a].setZero();
  if (sums) {
    *sums = ContactSums{};
    sums->contacts_per_particle.assign(n, 0);
    sums->wall_force.assign(ctx.walls.size(), Vec3::Zero());
  }
  // A wall's own law may need rolling resistance or dashpots that the scene's does not: the
  // pair loop then runs with them at the scene's zero values (mu_r = 0: no rolling moment).
  bool rolling = ctx.law.rolling(), viscous = ctx.law.viscous();
  for (const Wall& w : ctx.walls)
    if (w.own_law) rolling = rolling || w.law.rolling(), viscous = viscous || w.law.viscous();
  const int k = 4 * rolling + 2 * viscous + (sums != nullptr);
  kKernels[k](p, cell, ctx, pairs, wall_contacts, diss, sums, wall_power);
  if (sums)
    for (std::size_t a = 0; a < p.n_owned(); ++a) sums->sum_particle_force += p.f[a].norm();
}

}  // namespace fabrica
