// What every contact model shares: the kinematics of a contact, its stored springs, the result
// of one evaluation, the carry of a spring with the contact plane and the sub-network
// classification, each written once over a lane type T (core/simd.hpp): T = double evaluates
// one contact, T = simd::d4 four at once, with the same operations in the same order on every
// lane, so both give the same bits (the branches of the scalar form are masks and select()).
// The order of every sum and product is also that of the Eigen expressions the linear law was
// first written with (a.dot(b) = (a0 b0 + a1 b1) + a2 b2), so its results are those of that form.
#pragma once
#include "core/simd.hpp"
#include "core/types.hpp"

namespace fabrica {

// Shear, rolling and twisting springs of one contact; oriented from the body with the lower id
// to the other (the canonical order), so that every rank stores the same numbers. Every model
// stores the springs' forces and moments (Hertz-Mindlin's incremental, at its current stiffness).
struct ContactHistory {
  Vec3 fs = Vec3::Zero();  // shear spring force acting on body 2 [N]
  Vec3 mr = Vec3::Zero();  // rolling spring moment acting on body 2 [N m]
  real_t mt = 0;           // twisting spring moment acting on body 2, along n [N m]
};

struct ContactKinematics {
  Vec3 n;       // unit normal from body 1 to body 2
  real_t un;    // overlap [m], > 0
  Vec3 vrel;    // velocity of body 2 relative to body 1 at the contact point [m/s]
  Vec3 w1, w2;  // spins [rad/s]
  // The overlap one step before [m] (<= 0 on the step a contact forms), from the positions
  // before this step's drift; set only for a model with kPreviousOverlap (Hertz-Mindlin).
  real_t un_prev = 0;
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
  Vec3 mr;            // moment on body 2 [N m]: rolling, plus the twisting mt n
  bool sliding;       // the shear spring at the Coulomb limit (at_limit)
  bool rolling;       // the rolling spring at its limit (at_limit; always true when mu_r = 0)
  real_t e_friction;  // energy dissipated by slip this step [J]
  real_t e_rolling;   // energy dissipated by rolling (and twisting) slip this step [J]
  real_t e_viscous;   // energy dissipated by the dashpots this step [J]
  real_t mt = 0;      // the twisting moment on body 2 along n (included in mr) [N m]
};

template <class T>
struct ContactKinematicsL {
  simd::V3<T> n;
  T un;
  simd::V3<T> vrel, w1, w2;
  T un_prev;  // as ContactKinematics::un_prev
};
template <class T>
struct ContactHistoryL {
  simd::V3<T> fs, mr;
  T mt{};
};
template <class T>
struct ContactResultL {
  T fn;
  simd::V3<T> fs, mr;
  simd::mask_t<T> sliding, rolling;
  T e_friction, e_rolling, e_viscous;
  T mt{};
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
template <class T>
inline simd::mask_t<T> at_limit_l(const T& norm2, const T& limit) {
  const T l = (1.0 - kLimitTolerance) * limit;
  return norm2 >= l * l;
}

// The Coulomb cap of a shear spring, the same for every model: the trial force fs (the stored
// force carried with the plane, fs_rot, less k du) is brought back to 'cap' along itself where
// it exceeds it; the slip, du less the spring's elastic change (fs_cap - fs_rot) / k, dissipates
// the mean force times it, added to r.e_friction. Classified from the trial force, which is the
// spring itself when not capped and beyond the limit when capped (the same as at_limit of the
// capped spring, the test contact_records applies). Returns the capped lanes.
template <class T>
[[gnu::always_inline]] inline simd::mask_t<T> coulomb_cap_l(simd::V3<T>& fs, const simd::V3<T>& fs_rot,
                                                            const simd::V3<T>& du, const T& k, const T& cap,
                                                            ContactResultL<T>& r) {
  using namespace simd;
  const T fs2 = squared_norm(fs);
  const mask_t<T> capped = fs2 > cap * cap;
  r.sliding = at_limit_l(fs2, cap);
  if (any(capped)) {
    const V3<T> fs_cap = fs * (cap / simd::sqrt(fs2));
    const V3<T> slip = du + (fs_cap - fs_rot) / k;
    r.e_friction = select(capped, r.e_friction - 0.5 * dot(fs_rot + fs_cap, slip), r.e_friction);
    fs = select(capped, fs_cap, fs);
  }
  return capped;
}

}  // namespace fabrica
