// The linear contact law with rolling resistance ("rrlinear" family), as specified in
// shared/spec/reference-problem.md section 2 (after Jiang, Yu & Harris 2005; Ai et al. 2011,
// Powder Technol. 206:269, type C elastic-plastic spring-dashpot rolling model; and the PFC
// linear / rrlinear models). [contact] model = "linear", the default. Units: SI.
//
//   k_n = A E / L, A = pi r^2, r = min(R1,R2), L = R1 + R2   (or k_n given directly)  [N/m]
//   k_s = k_n / kappa                                                                 [N/m]
//   f_n = k_n u_n  (+ optional normal dashpot), never tensile                          [N]
//   f_s <- rot(f_s) - k_s du_s, |f_s| <= mu_s k_n u_n   (sliding when capped)          [N]
//   1/Rbar = 1/R1 + 1/R2, k_r = k_s Rbar^2                                            [N m/rad]
//   m_r <- rot(m_r) - k_r dtheta_r, |m_r| <= mu_r Rbar k_n u_n (rolling when capped)  [N m]
//   with twisting_friction: m_t <- m_t - k_s Rbar^2 dtheta_t, |m_t| <= mu_t Rbar k_n u_n  [N m]
//
// rot() carries a stored spring vector with the contact plane: it is projected onto the new
// plane with its length kept, then turned about the normal by the mean spin of the pair.
// The Coulomb and rolling limits use the elastic normal force k_n u_n (PFC convention), so a
// dashpot never changes the slip limit. Viscous dashpots: c = 2 beta sqrt(m_eff k) (critical
// damping ratio beta) or c = eta m_eff (mass-proportional rate eta, LAMMPS/LIGGGHTS style);
// the shear dashpot is switched off while the shear spring is capped (PFC "slip" convention).
// The stored shear spring (ContactHistory::fs) is the spring force.
//
// The law is a stateless function of (parameters, geometry, history&). Rolling resistance and
// viscous damping are template switches so that a kernel built without them contains none of it.
#pragma once
#include "core/contact/lanes.hpp"
#include "core/contact/rolling.hpp"
#include "core/contact/params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

// Per-contact constants derived from the parameters and the two bodies.
struct PairConstants {
  real_t kn = 0, ks = 0, kr = 0;  // N/m, N/m, N m/rad
  real_t cn = 0, cs = 0;          // N s/m
  real_t rbar = 0;                // m
};

// Body 2 may be a wall: pass R2 = infinity and m2 = infinity.
template <bool Rolling, bool Viscous>
inline PairConstants pair_constants(const ContactLawParams& p, real_t R1, real_t R2, real_t m1, real_t m2) {
  PairConstants c;
  const bool wall = std::isinf(R2);
  if (p.stiffness_mode == NormalStiffnessMode::Direct) {
    c.kn = p.normal_stiffness;
  } else if (wall) {
    c.kn = std::numbers::pi * R1 * p.youngs_modulus;  // r = L = R1 (PFC ball-facet convention)
  } else {
    const real_t r = std::min(R1, R2);
    c.kn = std::numbers::pi * r * r * p.youngs_modulus / (R1 + R2);
  }
  c.ks = c.kn / p.stiffness_ratio;
  c.rbar = wall ? R1 : R1 * R2 / (R1 + R2);
  if constexpr (Rolling) c.kr = c.ks * c.rbar * c.rbar;
  if constexpr (Viscous) {
    const real_t meff = std::isinf(m2) ? m1 : m1 * m2 / (m1 + m2);
    c.cn = p.damping_rate_n * meff + 2.0 * p.damping_ratio_n * std::sqrt(meff * c.kn);
    c.cs = p.damping_rate_s * meff + 2.0 * p.damping_ratio_s * std::sqrt(meff * c.ks);
  }
  return c;
}

template <class T>
struct PairConstantsL {
  T kn, ks, kr, cn, cs, rbar;
  T ir{};  // I_r of the epsd rolling dashpot [kg m^2] (epsd with dashpots only)
};

// Inlined into the pair loop: returned through memory, the result of four lanes (some 450
// bytes) and the arguments cost a store and a load each (benchmarks/README.md). Under
// -ffp-contract=off inlining changes no bit.
// Roll: the rolling model (core/contact/rolling.hpp; true = elastic-plastic, false = none);
// Twist: the twisting spring-slider.
template <int Roll, bool Viscous, class T, bool Twist = false, class L = ContactLawParams>
[[gnu::always_inline]] inline ContactResultL<T> contact_law_l(const L& p, const PairConstantsL<T>& c,
                                                              const ContactKinematicsL<T>& k, ContactHistoryL<T>& h,
                                                              real_t dt) {
  using namespace simd;
  ContactResultL<T> r;
  r.e_friction = r.e_rolling = r.e_viscous = T{};
  const V3<T>& n = k.n;
  const T fn_el = c.kn * k.un;
  const T vn = dot(k.vrel, n);  // > 0 when separating
  const V3<T> vt = k.vrel - vn * n;
  const T twist = 0.5 * dot(k.w1 + k.w2, n) * dt;

  // Normal force: max(0, fn_el - c_n vn) as std::max(0.0, x) takes it, (0 < x) ? x : 0.
  T fn = fn_el;
  if constexpr (Viscous) {
    const T trial = fn_el - c.cn * vn;
    fn = select(T{} < trial, trial, T{});
    r.e_viscous = r.e_viscous + (fn - fn_el) * (-vn) * dt;
  }
  r.fn = fn;

  // Shear spring with Coulomb cap.
  const V3<T> fs_rot = carry_with_plane(h.fs, n, twist);
  const V3<T> du = vt * dt;
  V3<T> fs = fs_rot - c.ks * du;
  const mask_t<T> capped = coulomb_cap_l(fs, fs_rot, du, c.ks, T(p.friction * fn_el), r);
  h.fs = fs;
  r.fs = fs;
  if constexpr (Viscous) {
    r.fs = select(capped, r.fs, r.fs - c.cs * vt);
    r.e_viscous = select(capped, r.e_viscous, r.e_viscous + c.cs * squared_norm(vt) * dt);
  }

  if constexpr (Roll != kNoRolling) {
    rolling_l<Roll, Viscous>(p, c.kr, c.ir, c.rbar, fn_el, k, h, twist, dt, r);
  } else {
    r.rolling = all_true<T>();  // no resistance: every contact rolls freely (spec section 5)
    r.mr = zero3<T>();
  }
  if constexpr (Twist) {
    twisting_l(p.twisting_friction, c.ks * c.rbar * c.rbar, c.rbar, fn_el, k, h, dt, r);
    r.mr = r.mr + r.mt * n;
  }
  return r;
}

// One contact, in the form the tests use.
template <int Roll, bool Viscous, bool Twist = false>
inline ContactResult contact_law(const ContactLawParams& p, const PairConstants& c, const ContactKinematics& k,
                                 ContactHistory& h, real_t dt) {
  using simd::from_vec, simd::to_vec;
  const PairConstantsL<real_t> cl{c.kn, c.ks, c.kr, c.cn, c.cs, c.rbar, 0.0};
  const ContactKinematicsL<real_t> kl{from_vec(k.n), k.un, from_vec(k.vrel), from_vec(k.w1), from_vec(k.w2), k.un_prev};
  ContactHistoryL<real_t> hl{from_vec(h.fs), from_vec(h.mr), h.mt};
  const ContactResultL<real_t> rl = contact_law_l<Roll, Viscous, real_t, Twist>(p, cl, kl, hl, dt);
  h.fs = to_vec(hl.fs);
  if constexpr (Roll != kNoRolling) h.mr = to_vec(hl.mr);
  if constexpr (Twist) h.mt = hl.mt;
  return ContactResult{rl.fn,         to_vec(rl.fs), to_vec(rl.mr), rl.sliding, rl.rolling,
                       rl.e_friction, rl.e_rolling,  rl.e_viscous,  rl.mt};
}

// Elastic energy stored in the three springs of one contact [J].
inline real_t spring_energy_normal(const PairConstants& c, real_t un) { return 0.5 * c.kn * un * un; }
inline real_t spring_energy_shear(const PairConstants& c, const ContactHistory& h) {
  return 0.5 * h.fs.squaredNorm() / c.ks;
}
inline real_t spring_energy_rolling(const PairConstants& c, const ContactHistory& h) {
  return c.kr > 0 ? 0.5 * h.mr.squaredNorm() / c.kr : 0.0;
}

// The model as the kernels, records, servo and time step see it (core/contact/models.hpp
// lists the members every model has).
struct LinearRolling {
  static constexpr ContactModel kModel = ContactModel::Linear;
  static constexpr bool kPreviousOverlap = false;  // ContactKinematics::un_prev is not read
  template <class T>
  using Pair = PairConstantsL<T>;

  // Two spheres, lane by lane (rmin = min(Ri, Rj), sum_r = Ri + Rj; mi, mj only if Viscous):
  // the operations of pair_constants, so that both give the same bits.
  // 'law' a ContactLawParams or the lanes' laws of a scene of several materials (LawLanes<T>).
  template <int Roll, bool Viscous, class T, class L>
  [[gnu::always_inline]] static Pair<T> pair(const L& law, const T& Ri, const T& Rj, const T& rmin, const T& sum_r,
                                             const T& mi, const T& mj) {
    Pair<T> pc;
    if (law.stiffness_mode == NormalStiffnessMode::Direct) {
      pc.kn = T{} + law.normal_stiffness;
    } else {
      pc.kn = std::numbers::pi * rmin * rmin * law.youngs_modulus / sum_r;
    }
    pc.ks = pc.kn / law.stiffness_ratio;
    pc.kr = pc.cn = pc.cs = T{};
    pc.ir = T{};
    pc.rbar = Ri * Rj / sum_r;  // (left out of a kernel that reads it nowhere)
    if constexpr (Roll != kNoRolling) pc.kr = rolling_stiffness<Roll>(law, pc.kn, pc.ks, pc.rbar);
    if constexpr (Viscous) {
      const T meff = mi * mj / (mi + mj);
      pc.cn = law.damping_rate_n * meff + 2.0 * law.damping_ratio_n * simd::sqrt(meff * pc.kn);
      pc.cs = law.damping_rate_s * meff + 2.0 * law.damping_ratio_s * simd::sqrt(meff * pc.ks);
      if constexpr (Roll == kEpsd) pc.ir = rolling_inertia(mi, Ri, mj, Rj);
    }
    return pc;
  }
  // One contact; body 2 a wall when R2 = m2 = infinity.
  template <int Roll, bool Viscous>
  static Pair<real_t> constants(const ContactLawParams& law, real_t R1, real_t R2, real_t m1, real_t m2) {
    const PairConstants c = pair_constants<Roll != kNoRolling, Viscous>(law, R1, R2, m1, m2);
    Pair<real_t> p{c.kn, c.ks, c.kr, c.cn, c.cs, c.rbar, 0.0};
    if constexpr (Roll != kNoRolling && Roll != kElasticPlastic)
      p.kr = rolling_stiffness<Roll>(law, p.kn, p.ks, p.rbar);
    if constexpr (Roll == kEpsd && Viscous)
      p.ir = std::isinf(m2) ? rolling_inertia_wall(m1, R1) : rolling_inertia(m1, R1, m2, R2);
    return p;
  }
  static Pair<real_t> lane(const Pair<simd::d4>& c, int l) {
    return {c.kn[l], c.ks[l], c.kr[l], c.cn[l], c.cs[l], c.rbar[l], c.ir[l]};
  }
  static Pair<real_t> lane(const Pair<real_t>& c, int) { return c; }

  template <int Roll, bool Viscous, class T, bool Twist = false, class L = ContactLawParams>
  [[gnu::always_inline]] static ContactResultL<T> evaluate(const L& law, const Pair<T>& c,
                                                           const ContactKinematicsL<T>& k, ContactHistoryL<T>& h,
                                                           real_t dt) {
    return contact_law_l<Roll, Viscous, T, Twist, L>(law, c, k, h, dt);
  }

  // The state of one contact of overlap un with stored springs h.
  static real_t normal_force(const Pair<real_t>& c, real_t un) { return c.kn * un; }  // elastic [N]
  static Vec3 shear_force(const Pair<real_t>&, real_t, const Vec3& stored) { return stored; }
  // Tangent stiffnesses [N/m] and dashpots [N s/m] at overlap un (the servo's response).
  static real_t normal_stiffness(const Pair<real_t>& c, real_t) { return c.kn; }
  static real_t shear_stiffness(const Pair<real_t>& c, real_t) { return c.ks; }
  static real_t normal_dashpot(const Pair<real_t>& c, real_t) { return c.cn; }
  static real_t shear_dashpot(const Pair<real_t>& c, real_t) { return c.cs; }
  static real_t rolling_limit(const ContactLawParams& law, const Pair<real_t>& c, real_t un) {
    return law.rolling_friction * c.rbar * (c.kn * un);
  }
  // Energies [J].
  static real_t energy_normal(const Pair<real_t>& c, real_t un) { return 0.5 * c.kn * un * un; }
  static real_t energy_shear(const Pair<real_t>& c, real_t, const Vec3& stored) {
    return 0.5 * stored.squaredNorm() / c.ks;
  }
  // c.kr is that of the pair's rolling model (0 for the constant torque: no spring).
  static real_t energy_rolling(const ContactLawParams&, const Pair<real_t>& c, real_t, const Vec3& mr) {
    return c.kr > 0 ? 0.5 * mr.squaredNorm() / c.kr : 0.0;
  }
  static real_t energy_twisting(const Pair<real_t>& c, real_t, real_t mt) {
    return 0.5 * mt * mt / (c.ks * c.rbar * c.rbar);
  }
};

}  // namespace fabrica
