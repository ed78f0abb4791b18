// Hertz-Mindlin: the Hertzian normal contact of elastic spheres with the no-slip Mindlin
// tangential stiffness, a Coulomb cap, Tsuji's viscous damping and the elastic-plastic rolling
// spring. [contact] model = "hertz_mindlin". Units: SI. After Hertz 1882, Mindlin 1949, Tsuji,
// Tanaka & Ishida 1992 (Powder Technol. 71:239), Di Renzo & Di Maio 2004 (Chem. Eng. Sci.
// 59:525), and as LIGGGHTS (model hertz tangential history) and LAMMPS (hertz/material,
// mindlin) ship it.
//
//   one material (E, nu); a sphere and a wall are of the same material:
//   E* = E / (2 (1 - nu^2)),  G* = E / (4 (2 - nu)(1 + nu))                              [Pa]
//   two materials (core/contact/materials.hpp): 1/E* = sum (1 - nu_i^2) / E_i,
//   1/G* = sum 2 (2 - nu_i)(1 + nu_i) / E_i
//   R* = R1 R2 / (R1 + R2) (a wall: R* = R1),  m* likewise                         [m], [kg]
//   f_n = 4/3 E* sqrt(R*) u_n^{3/2}  (+ dashpot), never tensile                           [N]
//   k_n = df_n/du_n = 2 E* sqrt(R* u_n),   k_t = 8 G* sqrt(R* u_n)                        [N/m]
//   c_n = 2 sqrt(5/6) beta_n sqrt(m* k_n),  c_t = 2 sqrt(5/6) beta_s sqrt(m* k_t)        [N s/m]
//   f_t <- s rot(f_t) - k_t du_t,  |f_t| <= mu_s f_n,el                                     [N]
//   the rolling resistance of core/contact/rolling.hpp with k_n, k_t above (elastic_plastic:
//   k_r = k_t Rbar^2, Rbar = R*), its stored moment scaled as f_t: m_r <- s rot(m_r) - k_r dtheta_r;
//   the twisting spring likewise: m_t <- s m_t - k_t Rbar^2 dtheta_t, |m_t| <= mu_t Rbar f_n,el
//
// The tangential spring is Mindlin's no-slip spring in incremental form, stored as a force
// (ContactHistory::fs, as the linear law's): each increment is taken at the step's stiffness
// (the mean of k_t(u_n,prev) and k_t(u_n) while the contact loads, the midpoint rule; k_t(u_n)
// while it unloads), and when the contact unloads its stored force is scaled by
// s = k_t(u_n) / k_t(u_n,prev) = sqrt(u_n / u_n,prev), the ratio of the contact radii, so that
// it vanishes with the contact (Thornton, Cummins & Cleary 2011, Powder Technol. 210:189;
// LAMMPS' mindlin/rescale); s = 1
// while it loads. u_n,prev is the overlap one step before, which the kernels compute from the
// positions before this step's drift (ContactKinematics::un_prev), so that no state is stored
// beyond the linear law's: checkpoints, migration and ghosts carry the same springs.
// The rolling spring is scaled alike. A spring of stiffness k at a fixed force holds
// |f|^2 / (2k): the energy it loses as k changes (the stored force kept while k grows, scaled
// while k shrinks) is the micro-slip of Mindlin & Deresiewicz's annulus, booked with the
// Coulomb (rolling) slip, so that the energy balance closes; nothing is created. LIGGGHTS keeps a
// displacement instead (its force k_t delta follows k_t both ways, which creates energy as a
// contact loads: a consolidation at 200 kPa met the kinetic-runaway guard).
//
// beta_n follows from restitution_normal through the exact restitution of the damped Hertz
// impact with the no-tension clamp (core/restitution.hpp, hertz_clamped_restitution), not
// LIGGGHTS' beta = -ln e / sqrt(ln^2 e + pi^2), which gives e = 0.55 for an input of 0.5 with the
// clamp (docs/verification.md); without restitution_shear, beta_s = beta_n (LIGGGHTS).
#pragma once
#include "core/contact/lanes.hpp"
#include "core/contact/rolling.hpp"
#include "core/contact/params.hpp"

#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

template <class T>
struct HertzPairL {
  T kn0;   // 2 E* sqrt(R*): k_n = kn0 sqrt(u_n) [N/m^1.5]
  T kt0;   // 8 G* sqrt(R*): k_t = kt0 sqrt(u_n) [N/m^1.5]
  T dn;    // 2 sqrt(5/6) beta_n sqrt(m*): c_n = dn sqrt(k_n) [kg^0.5]
  T ds;    // 2 sqrt(5/6) beta_s sqrt(m*)
  T rbar;  // R* [m]
  T ir;    // I_r of the epsd rolling dashpot [kg m^2] (epsd with dashpots only)
};

struct HertzMindlin {
  static constexpr ContactModel kModel = ContactModel::HertzMindlin;
  static constexpr bool kPreviousOverlap = true;  // reads ContactKinematics::un_prev
  template <class T>
  using Pair = HertzPairL<T>;

  // The effective moduli of two bodies of one material [Pa], or of the pair of two materials
  // that the mixing rule set (core/contact/materials.hpp).
  static real_t effective_modulus(const ContactLawParams& law) {
    if (law.pair_estar > 0) return law.pair_estar;
    const real_t nu = law.poisson_ratio;
    return law.youngs_modulus / (2.0 * (1.0 - nu * nu));
  }
  static real_t effective_shear_modulus(const ContactLawParams& law) {
    if (law.pair_gstar > 0) return law.pair_gstar;
    const real_t nu = law.poisson_ratio;
    return law.youngs_modulus / (4.0 * (2.0 - nu) * (1.0 + nu));
  }
  // Lane by lane in a scene of several materials (the pair's, computed as above).
  template <class T>
  static const T& effective_modulus(const LawLanes<T>& law) {
    return law.estar;
  }
  template <class T>
  static const T& effective_shear_modulus(const LawLanes<T>& law) {
    return law.gstar;
  }
  static constexpr real_t kTsuji = 1.8257418583505538;  // 2 sqrt(5/6)

  // 'law' a ContactLawParams or the lanes' laws of a scene of several materials (LawLanes<T>).
  template <int Roll, bool Viscous, class T, class L>
  [[gnu::always_inline]] static Pair<T> pair(const L& law, const T& Ri, const T& Rj, const T&, const T& sum_r,
                                             const T& mi, const T& mj) {
    Pair<T> c;
    const T rstar = Ri * Rj / sum_r;
    const T sr = simd::sqrt(rstar);
    c.kn0 = (2.0 * effective_modulus(law)) * sr;
    c.kt0 = (8.0 * effective_shear_modulus(law)) * sr;
    c.dn = c.ds = c.ir = T{};
    c.rbar = rstar;
    if constexpr (Viscous) {
      const T sm = simd::sqrt(mi * mj / (mi + mj));
      c.dn = (kTsuji * law.damping_ratio_n) * sm;
      c.ds = (kTsuji * law.damping_ratio_s) * sm;
      if constexpr (Roll == kEpsd) c.ir = rolling_inertia(mi, Ri, mj, Rj);
    }
    return c;
  }
  template <int Roll, bool Viscous>
  static Pair<real_t> constants(const ContactLawParams& law, real_t R1, real_t R2, real_t m1, real_t m2) {
    if (!std::isinf(R2)) return pair<Roll, Viscous, real_t>(law, R1, R2, std::min(R1, R2), R1 + R2, m1, m2);
    Pair<real_t> c;  // a wall: R* = R1, m* = m1
    const real_t sr = std::sqrt(R1);
    c.kn0 = (2.0 * effective_modulus(law)) * sr;
    c.kt0 = (8.0 * effective_shear_modulus(law)) * sr;
    c.rbar = R1;
    c.dn = Viscous ? (kTsuji * law.damping_ratio_n) * std::sqrt(m1) : 0.0;
    c.ds = Viscous ? (kTsuji * law.damping_ratio_s) * std::sqrt(m1) : 0.0;
    c.ir = Roll == kEpsd && Viscous ? rolling_inertia_wall(m1, R1) : 0.0;
    return c;
  }
  static Pair<real_t> lane(const Pair<simd::d4>& c, int l) {
    return {c.kn0[l], c.kt0[l], c.dn[l], c.ds[l], c.rbar[l], c.ir[l]};
  }
  // k_r / k_t of the rolling model (a constant of the pair: both stiffnesses grow as sqrt(u_n)).
  template <int Roll, class T, class L>
  static T rolling_per_shear(const L& law, const Pair<T>& c) {
    return rolling_stiffness<Roll>(law, c.kn0, c.kt0, c.rbar) / c.kt0;
  }
  static Pair<real_t> lane(const Pair<real_t>& c, int) { return c; }

  template <int Roll, bool Viscous, class T, bool Twist = false, class L = ContactLawParams>
  [[gnu::always_inline]] static ContactResultL<T> evaluate(const L& law, const Pair<T>& c,
                                                           const ContactKinematicsL<T>& k, ContactHistoryL<T>& h,
                                                           real_t dt) {
    using namespace simd;
    ContactResultL<T> r;
    r.e_friction = r.e_rolling = r.e_viscous = T{};
    const V3<T>& n = k.n;
    const T su = simd::sqrt(k.un);
    const T kn = c.kn0 * su;
    const T kt = c.kt0 * su;
    const T fn_el = (2.0 / 3.0) * kn * k.un;
    const T vn = dot(k.vrel, n);  // > 0 when separating
    const V3<T> vt = k.vrel - vn * n;
    const T twist = 0.5 * dot(k.w1 + k.w2, n) * dt;

    // The overlap one step before: not positive on the step a contact forms.
    const T up = k.un_prev;
    T fn = fn_el;
    if constexpr (Viscous) {
      const T trial = fn_el - c.dn * simd::sqrt(kn) * vn;
      fn = select(T{} < trial, trial, T{});
      // On the step it forms, the dashpot's force rose from 0 at the start of the step: its work
      // is booked with the mean of the two, as the cell's boundary work takes the mean stress
      // (EnergyBook::close_step, core/energy_account.cpp). Booked whole, a loose specimen's first
      // contact showed twice the boundary work it was given and met the kinetic-runaway guard.
      const T w = select(up > 0.0, T{} + 1.0, T{} + 0.5);
      r.e_viscous = r.e_viscous + w * ((fn - fn_el) * (-vn) * dt);
    }
    r.fn = fn;

    // Unloading (u_n below its value one step before): the stored springs are scaled by
    // s = k_t / k_t,prev; the energy |f|^2 / 2k they lose to the change of k is booked as slip.
    const T ktp = c.kt0 * simd::sqrt(select(up > 0.0, up, T{}));
    const mask_t<T> unload = up > k.un;
    const mask_t<T> was = ktp > 0.0;
    const T ktp_safe = select(was, ktp, T{} + 1.0), kt_safe = select(kt > 0.0, kt, T{} + 1.0);
    const T sc = select(unload, kt / ktp_safe, T{} + 1.0);
    // The energy a spring of stiffness k_prev (k now) and squared length f2 loses.
    auto lost = [&](const T& f2, const T& r2) {  // r2 = k_r / k_t for the rolling spring, else 1
      const T before = select(was, 0.5 * f2 / (ktp_safe * r2), T{});
      const T after =
          select(unload, 0.5 * f2 * kt / (ktp_safe * ktp_safe * r2), select(kt > 0.0, 0.5 * f2 / (kt_safe * r2), T{}));
      return before - after;
    };
    const T fr2 = squared_norm(h.fs);
    r.e_friction = lost(fr2, T{} + 1.0);
    // The increment of a loading step is taken at the step's mean stiffness k_m = (k_t + k_t,prev)
    // / 2, the midpoint rule for dF = -k_t(u_n(t)) du (at the end's k_t the error was first order
    // in dt and large at the default time step; docs/verification.md "Oblique impact in partial
    // slip" measures both); an unloading step's at the
    // end's k_t, with which the scaling s advances F / k_t by -du exactly. The work the increment
    // does on the spring, (|f|^2 - |f_0|^2) / 2k_m, is not what the spring then holds at k_t,
    // (|f|^2 - |f_0|^2) / 2k_t: the difference (first order in the step's change of k) is booked
    // with the slip, as 'lost' is, so that the books close as before.
    const T kinc = select(unload, kt, 0.5 * (kt + ktp));
    const T kinc_safe = select(kinc > 0.0, kinc, T{} + 1.0);
    const T dk = select(unload, T{}, 0.5 / kinc_safe - 0.5 / kt_safe);
    const V3<T> fs_rot = carry_with_plane(h.fs * sc, n, twist);
    const V3<T> du = vt * dt;
    V3<T> fs = fs_rot - kinc * du;
    const mask_t<T> capped = coulomb_cap_l(fs, fs_rot, du, kinc_safe, T(law.friction * fn_el), r);
    r.e_friction = r.e_friction + (squared_norm(fs) - squared_norm(fs_rot)) * dk;
    h.fs = fs;
    r.fs = fs;
    if constexpr (Viscous) {
      const T ct = c.ds * simd::sqrt(kt);
      r.fs = select(capped, r.fs, r.fs - ct * vt);
      r.e_viscous = select(capped, r.e_viscous, r.e_viscous + ct * squared_norm(vt) * dt);
    }

    if constexpr (Roll == kConstantTorque) {
      rolling_l<Roll, Viscous>(law, T{}, T{}, c.rbar, fn_el, k, h, twist, dt, r);
    } else if constexpr (Roll != kNoRolling) {
      // k_r from the current stiffnesses, the stored moment scaled as the shear spring; at
      // u_n = 0 (a contact that touches to rounding) k_r = 0 and the cap is 0: the floor keeps
      // the slip's energy finite there.
      const T q = rolling_per_shear<Roll>(law, c);
      const T e_lost = lost(squared_norm(h.mr), q);
      h.mr = h.mr * sc;
      const T m0 = squared_norm(h.mr);  // kept by the carry with the plane
      const T kr = kinc * q;
      const T kr_safe = select(kr > 0.0, kr, T{} + std::numeric_limits<real_t>::min());
      rolling_l<Roll, Viscous>(law, kr_safe, c.ir, c.rbar, fn_el, k, h, twist, dt, r);
      r.e_rolling = r.e_rolling + e_lost + (squared_norm(h.mr) - m0) * (dk / q);
    } else {
      r.rolling = all_true<T>();
      r.mr = zero3<T>();
    }
    if constexpr (Twist) {  // k_t,w = k_t R*^2, its stored moment scaled as the shear spring's
      const T r2 = c.rbar * c.rbar;
      const T e_lost = lost(h.mt * h.mt, r2);
      h.mt = h.mt * sc;
      const T m0 = h.mt * h.mt;
      const T ktw = kinc * r2;
      const T ktw_safe = select(ktw > 0.0, ktw, T{} + std::numeric_limits<real_t>::min());
      twisting_l(law.twisting_friction, ktw_safe, c.rbar, fn_el, k, h, dt, r);
      r.e_rolling = r.e_rolling + e_lost + (h.mt * h.mt - m0) * (dk / r2);
      r.mr = r.mr + r.mt * n;
    }
    return r;
  }

  static real_t normal_force(const Pair<real_t>& c, real_t un) { return (2.0 / 3.0) * (c.kn0 * std::sqrt(un)) * un; }
  static Vec3 shear_force(const Pair<real_t>&, real_t, const Vec3& stored) { return stored; }
  static real_t normal_stiffness(const Pair<real_t>& c, real_t un) { return c.kn0 * std::sqrt(un); }
  static real_t shear_stiffness(const Pair<real_t>& c, real_t un) { return c.kt0 * std::sqrt(un); }
  static real_t normal_dashpot(const Pair<real_t>& c, real_t un) { return c.dn * std::sqrt(normal_stiffness(c, un)); }
  static real_t shear_dashpot(const Pair<real_t>& c, real_t un) { return c.ds * std::sqrt(shear_stiffness(c, un)); }
  static real_t rolling_limit(const ContactLawParams& law, const Pair<real_t>& c, real_t un) {
    return law.rolling_friction * c.rbar * normal_force(c, un);
  }
  // 8/15 E* sqrt(R*) u^{5/2} = 2/5 f_n u; the tangential and rolling springs at the current
  // stiffness. At u_n = 0 (a contact that opens) the springs have been scaled down with the
  // contact on its way out; what is left in them at its last step is not booked (0 is returned).
  static real_t energy_normal(const Pair<real_t>& c, real_t un) { return 0.4 * normal_force(c, un) * un; }
  static real_t energy_shear(const Pair<real_t>& c, real_t un, const Vec3& stored) {
    const real_t kt = shear_stiffness(c, un);
    return kt > 0 ? 0.5 * stored.squaredNorm() / kt : 0.0;
  }
  static real_t energy_rolling(const ContactLawParams& law, const Pair<real_t>& c, real_t un, const Vec3& mr) {
    real_t q = 0;  // k_r / k_t; the constant torque stores no energy
    if (law.rolling_model == RollingModel::ElasticPlastic) q = rolling_per_shear<kElasticPlastic>(law, c);
    if (law.rolling_model == RollingModel::Epsd) q = rolling_per_shear<kEpsd>(law, c);
    const real_t kr = shear_stiffness(c, un) * q;
    return kr > 0 ? 0.5 * mr.squaredNorm() / kr : 0.0;
  }
  static real_t energy_twisting(const Pair<real_t>& c, real_t un, real_t mt) {
    const real_t ktw = shear_stiffness(c, un) * c.rbar * c.rbar;
    return ktw > 0 ? 0.5 * mt * mt / ktw : 0.0;
  }
};

}  // namespace fabrica
