// Rolling resistance, composed with either normal model ([contact] rolling_model, docs/scene.md
// "Rolling resistance models"). Units: SI. With Rbar = R1 R2 / (R1 + R2) (a wall: R1), f_n the
// elastic normal force, w_r the bending part of the relative spin w2 - w1 (its component along
// n, the twist, excluded) and the moment m_r acting on body 2:
//
//  "elastic_plastic" (the default; the reference study's law, PFC rrlinear, Ai et al. 2011
//     type C without its dashpot; Iwashita & Oda 1998, Jiang, Yu & Harris 2005):
//       m_r <- rot(m_r) - k_r w_r dt, |m_r| <= mu_r Rbar f_n,  k_r = k_s Rbar^2 (k_s the
//       model's current tangential stiffness);
//  "epsd" (Ai, Chen, Rotter & Ooi 2011, Powder Technol. 206:269, type C; LIGGGHTS' epsd):
//       the same spring with k_r = 2.25 k_n mu_r^2 Rbar^2 (k_n the model's current normal
//       stiffness) and a rolling dashpot -c_r w_r, c_r = eta_r 2 sqrt(I_r k_r),
//       1/I_r = 1/(I_1 + m_1 R_1^2) + 1/(I_2 + m_2 R_2^2) (a wall: its term 0), switched off
//       while the spring is at its limit (full mobilisation);
//  "constant_torque" (Ai et al. 2011 type A; Zhou et al. 1999): m_r = -mu_r Rbar f_n w_r / |w_r|,
//       no spring, 0 when w_r = 0. It cannot hold a sphere at rest: the moment flips with the sign
//       of w_r every step or so about w_r = 0, the oscillation Ai et al. report
//       (docs/verification.md shows it).
//
// The stored rolling spring (ContactHistory::mr) holds m_r; for "constant_torque" it holds the
// last moment, read by the contact records and the sub-network classification only.
//
// Twisting resistance ([contact] twisting_friction mu_t > 0), with any rolling model or none: a
// spring-slider on the twist, the relative spin about the normal w_t = (w2 - w1) . n (Iwashita &
// Oda 1998's rotational springs about the normal; Jiang, Shen & Wang 2015, Comput. Geotech.
// 65:147; LAMMPS' twisting sds with its stiffness and limit given as here):
//       m_t <- m_t - k_t,w w_t dt,  |m_t| <= mu_t Rbar f_n,  k_t,w = k_s Rbar^2
// (k_s the model's current tangential stiffness), acting on body 2 along n (and its opposite on
// body 1), stored in ContactHistory::mt. Its slip is booked with the rolling slip and its
// elastic energy with the rolling springs'. Its stiffness is within the rotational bound of the
// critical time step (k_s R^2 + k_r, core/timestep.cpp) since Rbar <= R.
#pragma once
#include "core/contact/lanes.hpp"
#include "core/contact/params.hpp"

#include <cmath>

namespace fabrica {

// The rolling resistance a kernel is built for: none, or one of the models (a template
// argument, so that a kernel contains only its own).
// kNoRolling, or 1 + the scene's RollingModel (core/forces.cpp picks the kernel by it).
enum : int { kNoRolling = 0, kElasticPlastic = 1, kEpsd = 2, kConstantTorque = 3 };

// k_r [N m/rad] from the contact's current k_n, k_s [N/m] and Rbar [m] (0 for the constant torque).
template <int Roll, class T, class L>
inline T rolling_stiffness(const L& law, const T& kn, const T& ks, const T& rbar) {
  if constexpr (Roll == kEpsd) return (2.25 * law.rolling_friction * law.rolling_friction) * kn * rbar * rbar;
  else if constexpr (Roll == kConstantTorque) return T{};
  else return ks * rbar * rbar;
}

// I_r [kg m^2] of the epsd dashpot: solid spheres, I + m R^2 = 7/5 m R^2 (a wall:
// rolling_inertia_wall, the sphere's term alone).
template <class T>
inline T rolling_inertia(const T& m1, const T& R1, const T& m2, const T& R2) {
  const T a = 1.4 * m1 * R1 * R1, b = 1.4 * m2 * R2 * R2;
  return a * b / (a + b);
}
inline real_t rolling_inertia_wall(real_t m1, real_t R1) { return 1.4 * m1 * R1 * R1; }

// The elastic-plastic rolling spring (Iwashita & Oda 1998; Jiang, Yu & Harris 2005; Ai et al.
// 2011 type C; PFC rrlinear), the same for every normal model: the bending part of the
// relative rotation loads m_r <- rot(m_r) - k_r dtheta_r, capped at mu_r Rbar f_n (f_n the
// elastic normal force), the energy of the rolling slip booked in r.e_rolling. 'twist' is the
// angle the stored moment is turned by with the contact plane.
template <class T, class M>
[[gnu::always_inline]] inline void rolling_spring_l(const M& mu_r, const T& kr, const T& rbar, const T& fn_el,
                                                    const ContactKinematicsL<T>& k, ContactHistoryL<T>& h,
                                                    const T& twist, real_t dt, ContactResultL<T>& r) {
  using namespace simd;
  const V3<T>& n = k.n;
  const V3<T> mr_rot = carry_with_plane(h.mr, n, twist);
  V3<T> dth = (k.w2 - k.w1) * dt;
  dth = dth - dot(dth, n) * n;
  V3<T> mr = mr_rot - kr * dth;
  const T rcap = mu_r * rbar * fn_el;
  const T mr2 = squared_norm(mr);
  r.rolling = at_limit_l(mr2, rcap);  // as for sliding
  const mask_t<T> rcapped = mr2 > rcap * rcap;
  if (any(rcapped)) {
    const V3<T> mr_cap = mr * (rcap / simd::sqrt(mr2));
    const V3<T> slip = dth + (mr_cap - mr_rot) / kr;
    r.e_rolling = select(rcapped, -0.5 * dot(mr_rot + mr_cap, slip), r.e_rolling);
    mr = select(rcapped, mr_cap, mr);
  }
  h.mr = mr;
  r.mr = mr;
}

// The twisting spring-slider (above): stiffness ktw = k_s Rbar^2 (> 0), cap mu_t Rbar f_n,el; the
// slip's energy added to r.e_rolling, the moment to r.mt (the caller adds mt n to r.mr).
template <class T, class M>
[[gnu::always_inline]] inline void twisting_l(const M& mu_t, const T& ktw, const T& rbar, const T& fn_el,
                                              const ContactKinematicsL<T>& k, ContactHistoryL<T>& h, real_t dt,
                                              ContactResultL<T>& r) {
  using namespace simd;
  const T dth = dot(k.w2 - k.w1, k.n) * dt;
  T mt = h.mt - ktw * dth;
  const T cap = mu_t * rbar * fn_el;
  const mask_t<T> capped = mt * mt > cap * cap;
  if (any(capped)) {
    const T mt_cap = select(mt > 0.0, cap, -cap);
    const T slip = dth + (mt_cap - h.mt) / ktw;
    r.e_rolling = select(capped, r.e_rolling - 0.5 * (h.mt + mt_cap) * slip, r.e_rolling);
    mt = select(capped, mt_cap, mt);
  }
  h.mt = mt;
  r.mt = mt;
}

// The rolling resistance of model Roll (not kNoRolling), with the contact's k_r and, for the
// epsd dashpot (Viscous), I_r.
template <int Roll, bool Viscous, class T, class L>
[[gnu::always_inline]] inline void rolling_l(const L& law, const T& kr, const T& ir, const T& rbar, const T& fn_el,
                                             const ContactKinematicsL<T>& k, ContactHistoryL<T>& h, const T& twist,
                                             real_t dt, ContactResultL<T>& r) {
  using namespace simd;
  if constexpr (Roll == kConstantTorque) {
    V3<T> wr = k.w2 - k.w1;
    wr = wr - dot(wr, k.n) * k.n;
    const T w2 = squared_norm(wr);
    const T cap = law.rolling_friction * rbar * fn_el;
    const mask_t<T> moving = w2 > 0.0;
    const T w = simd::sqrt(select(moving, w2, T{} + 1.0));
    const T sc = select(moving, cap / w, T{});
    r.mr = wr * (-sc);
    h.mr = r.mr;
    r.rolling = moving;                               // at its limit whenever the pair rolls
    r.e_rolling = select(moving, cap * w * dt, T{});  // -m_r . w_r dt
  } else {
    rolling_spring_l(law.rolling_friction, kr, rbar, fn_el, k, h, twist, dt, r);
    if constexpr (Roll == kEpsd && Viscous) {
      V3<T> wr = k.w2 - k.w1;
      wr = wr - dot(wr, k.n) * k.n;
      const T cr = (2.0 * law.rolling_damping) * simd::sqrt(ir * kr);
      r.mr = select(r.rolling, r.mr, r.mr - cr * wr);
      r.e_viscous = select(r.rolling, r.e_viscous, r.e_viscous + cr * squared_norm(wr) * dt);
    }
  }
}

}  // namespace fabrica
