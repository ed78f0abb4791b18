// Linear contact law with rolling resistance ("rrlinear" family), as specified in
// shared/spec/reference-problem.md section 2 (after Jiang, Yu & Harris 2005; Ai et al. 2011,
// Powder Technol. 206:269, "type A" elastic-plastic spring-dashpot rolling model; and the
// PFC linear / rrlinear models). Units: SI.
//
//   k_n = A E / L, A = pi r^2, r = min(R1,R2), L = R1 + R2   (or k_n given directly)  [N/m]
//   k_s = k_n / kappa                                                                 [N/m]
//   f_n = k_n u_n  (+ optional normal dashpot), never tensile                          [N]
//   f_s <- rot(f_s) - k_s du_s, |f_s| <= mu_s k_n u_n   (sliding when capped)          [N]
//   1/Rbar = 1/R1 + 1/R2, k_r = k_s Rbar^2                                            [N m/rad]
//   m_r <- rot(m_r) - k_r dtheta_r, |m_r| <= mu_r Rbar k_n u_n (rolling when capped)  [N m]
//
// rot() carries a stored spring vector with the contact plane: it is projected onto the new
// plane with its length kept, then turned about the normal by the mean spin of the pair.
// The Coulomb and rolling limits use the elastic normal force k_n u_n (PFC convention), so a
// dashpot never changes the slip limit. Viscous dashpots: c = 2 beta sqrt(m_eff k) (critical
// damping ratio beta) or c = eta m_eff (mass-proportional rate eta, LAMMPS/LIGGGHTS style);
// the shear dashpot is switched off while the shear spring is capped (PFC "slip" convention).
//
// The law is a stateless function of (parameters, geometry, history&). Rolling resistance and
// viscous damping are template switches so that a kernel built without them contains none of it.
#pragma once
#include "core/simd.hpp"
#include "core/types.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

enum class NormalStiffnessMode { Deformability, Direct };

struct ContactLawParams {
  NormalStiffnessMode stiffness_mode = NormalStiffnessMode::Deformability;
  real_t youngs_modulus = 100e6;   // E [Pa], deformability mode
  real_t normal_stiffness = 0.0;   // k_n [N/m], direct mode
  real_t stiffness_ratio = 1.0;    // kappa = k_n / k_s [-]
  real_t friction = 0.3;           // mu_s [-]
  real_t rolling_friction = 0.0;   // mu_r [-]
  real_t damping_ratio_n = 0.0;    // beta_n [-], critical damping ratio of the normal dashpot
  real_t damping_ratio_s = 0.0;    // beta_s [-]
  real_t damping_rate_n = 0.0;     // eta_n [1/s], c_n = eta_n m_eff (alternative to beta_n)
  real_t damping_rate_s = 0.0;     // eta_s [1/s]

  bool rolling() const { return rolling_friction > 0.0; }
  bool viscous() const {
    return damping_ratio_n > 0 || damping_ratio_s > 0 || damping_rate_n > 0 || damping_rate_s > 0;
  }
};

// Per-contact constants derived from the parameters and the two bodies.
struct PairConstants {
  real_t kn = 0, ks = 0, kr = 0;  // N/m, N/m, N m/rad
  real_t cn = 0, cs = 0;          // N s/m
  real_t rbar = 0;                // m
};

// Body 2 may be a wall: pass R2 = infinity and m2 = infinity.
template <bool Rolling, bool Viscous>
inline PairConstants pair_constants(const ContactLawParams& p, real_t R1, real_t R2, real_t m1,
                                    real_t m2) {
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
  if constexpr (Rolling) {
    c.rbar = wall ? R1 : R1 * R2 / (R1 + R2);
    c.kr = c.ks * c.rbar * c.rbar;
  }
  if constexpr (Viscous) {
    const real_t meff = std::isinf(m2) ? m1 : m1 * m2 / (m1 + m2);
    c.cn = p.damping_rate_n * meff + 2.0 * p.damping_ratio_n * std::sqrt(meff * c.kn);
    c.cs = p.damping_rate_s * meff + 2.0 * p.damping_ratio_s * std::sqrt(meff * c.ks);
  }
  return c;
}

// Shear and rolling springs of one contact; oriented from the body with the lower id to the
// other (the canonical order), so that every rank stores the same numbers.
struct ContactHistory {
  Vec3 fs = Vec3::Zero();  // shear spring force acting on body 2 [N]
  Vec3 mr = Vec3::Zero();  // rolling spring moment acting on body 2 [N m]
};

struct ContactKinematics {
  Vec3 n;        // unit normal from body 1 to body 2
  real_t un;     // overlap [m], > 0
  Vec3 vrel;     // velocity of body 2 relative to body 1 at the contact point [m/s]
  Vec3 w1, w2;   // spins [rad/s]
};

// The one classification of a contact into the sub-networks of spec section 5, shared by the
// force loop's counts (ContactSums) and the contact records (core/contact_snapshot.cpp): a
// spring of squared length 'norm2' is at its limit when |spring| >= (1 - 1e-9) limit (a capped
// spring equals the limit up to the rounding of one rescaling). With a zero limit every
// contact is at it: at mu_s = 0 every contact slides (no tangential force can be held, the
// friction is fully mobilised whatever the tangential motion), at mu_r = 0 every contact rolls.
constexpr real_t kLimitTolerance = 1e-9;
inline bool at_limit(real_t norm2, real_t limit) {
  const real_t l = (1.0 - kLimitTolerance) * limit;
  return norm2 >= l * l;
}

struct ContactResult {
  real_t fn;          // normal force (elastic + dashpot, >= 0) on body 2 along n [N]
  Vec3 fs;            // total shear force on body 2 (spring + dashpot) [N]
  Vec3 mr;            // rolling moment on body 2 [N m]
  bool sliding;       // the shear spring at the Coulomb limit (at_limit)
  bool rolling;       // the rolling spring at its limit (at_limit; always true when mu_r = 0)
  real_t e_friction;  // energy dissipated by slip this step [J]
  real_t e_rolling;   // energy dissipated by rolling slip this step [J]
  real_t e_viscous;   // energy dissipated by the dashpots this step [J]
};

// The law below is written once over a lane type T (core/simd.hpp): T = double evaluates one
// contact, T = simd::d4 four at once, with the same operations in the same order on every lane,
// so both give the same bits (the branches of the scalar form are masks and select()). The
// order of every sum and product is also that of the Eigen expressions the law was first
// written with (a.dot(b) = (a0 b0 + a1 b1) + a2 b2), so the results are those of that form.
template <class T> struct PairConstantsL {
  T kn, ks, kr, cn, cs, rbar;
};
template <class T> struct ContactKinematicsL {
  simd::V3<T> n;
  T un;
  simd::V3<T> vrel, w1, w2;
};
template <class T> struct ContactHistoryL {
  simd::V3<T> fs, mr;
};
template <class T> struct ContactResultL {
  T fn;
  simd::V3<T> fs, mr;
  simd::mask_t<T> sliding, rolling;
  T e_friction, e_rolling, e_viscous;
};

// Keeps |a| after projecting onto the plane normal to n and turning it about n by angle phi.
template <class T>
inline simd::V3<T> carry_with_plane(const simd::V3<T>& a, const simd::V3<T>& n, const T& phi) {
  using namespace simd;
  const T old2 = squared_norm(a);
  const mask_t<T> zero = old2 == 0.0;
  if (all(zero)) return a;
  V3<T> b = a - dot(a, n) * n;
  b = b + phi * cross(n, b);
  const T new2 = squared_norm(b);
  const V3<T> kept = select(new2 > 0.0, b * simd::sqrt(old2 / new2), zero3<T>());
  return select(zero, a, kept);
}
inline Vec3 carry_with_plane(const Vec3& a, const Vec3& n, real_t phi) {
  return simd::to_vec(carry_with_plane<real_t>(simd::from_vec(a), simd::from_vec(n), phi));
}

// at_limit() over lanes.
template <class T> inline simd::mask_t<T> at_limit_l(const T& norm2, const T& limit) {
  const T l = (1.0 - kLimitTolerance) * limit;
  return norm2 >= l * l;
}

// Inlined into the pair loop: returned through memory, the result of four lanes (some 450
// bytes) and the arguments cost a store and a load each (benchmarks/README.md). Under
// -ffp-contract=off inlining changes no bit.
template <bool Rolling, bool Viscous, class T>
[[gnu::always_inline]] inline ContactResultL<T> contact_law_l(const ContactLawParams& p, const PairConstantsL<T>& c,
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
  const T cap = p.friction * fn_el;
  const T fs2 = squared_norm(fs);
  // Capped when the trial force exceeds the cap; classified from the trial force, which is the
  // spring itself when not capped and beyond the limit when capped (the same as at_limit of
  // the capped spring, the test contact_records applies).
  const mask_t<T> capped = fs2 > cap * cap;
  r.sliding = at_limit_l(fs2, cap);
  if (any(capped)) {
    const V3<T> fs_cap = fs * (cap / simd::sqrt(fs2));
    const V3<T> slip = du + (fs_cap - fs_rot) / c.ks;
    r.e_friction = select(capped, -0.5 * dot(fs_rot + fs_cap, slip), r.e_friction);
    fs = select(capped, fs_cap, fs);
  }
  h.fs = fs;
  r.fs = fs;
  if constexpr (Viscous) {
    r.fs = select(capped, r.fs, r.fs - c.cs * vt);
    r.e_viscous = select(capped, r.e_viscous, r.e_viscous + c.cs * squared_norm(vt) * dt);
  }

  // Rolling spring with its cap: the bending part of the relative rotation only.
  if constexpr (Rolling) {
    const V3<T> mr_rot = carry_with_plane(h.mr, n, twist);
    V3<T> dth = (k.w2 - k.w1) * dt;
    dth = dth - dot(dth, n) * n;
    V3<T> mr = mr_rot - c.kr * dth;
    const T rcap = p.rolling_friction * c.rbar * fn_el;
    const T mr2 = squared_norm(mr);
    r.rolling = at_limit_l(mr2, rcap);  // as for sliding
    const mask_t<T> rcapped = mr2 > rcap * rcap;
    if (any(rcapped)) {
      const V3<T> mr_cap = mr * (rcap / simd::sqrt(mr2));
      const V3<T> slip = dth + (mr_cap - mr_rot) / c.kr;
      r.e_rolling = select(rcapped, -0.5 * dot(mr_rot + mr_cap, slip), r.e_rolling);
      mr = select(rcapped, mr_cap, mr);
    }
    h.mr = mr;
    r.mr = mr;
  } else {
    r.rolling = all_true<T>();  // no resistance: every contact rolls freely (spec section 5)
    r.mr = zero3<T>();
  }
  return r;
}

// One contact, in the form the wall loop and the tests use.
template <bool Rolling, bool Viscous>
inline ContactResult contact_law(const ContactLawParams& p, const PairConstants& c,
                                 const ContactKinematics& k, ContactHistory& h, real_t dt) {
  using simd::from_vec, simd::to_vec;
  const PairConstantsL<real_t> cl{c.kn, c.ks, c.kr, c.cn, c.cs, c.rbar};
  const ContactKinematicsL<real_t> kl{from_vec(k.n), k.un, from_vec(k.vrel), from_vec(k.w1),
                                      from_vec(k.w2)};
  ContactHistoryL<real_t> hl{from_vec(h.fs), from_vec(h.mr)};
  const ContactResultL<real_t> rl = contact_law_l<Rolling, Viscous>(p, cl, kl, hl, dt);
  h.fs = to_vec(hl.fs);
  if constexpr (Rolling) h.mr = to_vec(hl.mr);
  ContactResult r;
  r.fn = rl.fn;
  r.fs = to_vec(rl.fs);
  r.mr = to_vec(rl.mr);
  r.sliding = rl.sliding;
  r.rolling = rl.rolling;
  r.e_friction = rl.e_friction;
  r.e_rolling = rl.e_rolling;
  r.e_viscous = rl.e_viscous;
  return r;
}

// Elastic energy stored in the three springs of one contact [J].
inline real_t spring_energy_normal(const PairConstants& c, real_t un) { return 0.5 * c.kn * un * un; }
inline real_t spring_energy_shear(const PairConstants& c, const ContactHistory& h) {
  return 0.5 * h.fs.squaredNorm() / c.ks;
}
inline real_t spring_energy_rolling(const PairConstants& c, const ContactHistory& h) {
  return c.kr > 0 ? 0.5 * h.mr.squaredNorm() / c.kr : 0.0;
}

}  // namespace fabrica
