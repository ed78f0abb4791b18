#include "core/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fabrica {

void half_kick(Particles& p, real_t dt) {
  const real_t h = 0.5 * dt;
  const std::size_t n = p.n_owned();
  real_t im[kKickBlock], iI[kKickBlock];
  for (std::size_t a0 = 0; a0 < n; a0 += kKickBlock) {
    const std::size_t nb = std::min(kKickBlock, n - a0);
    inverse_masses(p, a0, nb, im, iI);
    for (std::size_t k = 0; k < nb; ++k) kick(h, im[k], iI[k], p.f[a0 + k], p.t[a0 + k], p.v[a0 + k], p.w[a0 + k]);
  }
}

CellStep drift_and_deform(Particles& p, PeriodicCell& cell, real_t dt) {
  const std::size_t n = p.n_owned();
  if (!cell.deforming()) {
    for (std::size_t a = 0; a < n; ++a) p.x[a] = drifted<false>(p.x[a], p.v[a], dt, Vec3::Ones());
    return CellStep{};
  }
  const CellStep step = cell.deform(dt);
  if (step.sheared)
    for (std::size_t a = 0; a < n; ++a) p.x[a] = drifted_sheared(p.x[a], p.v[a], dt, step.F);
  else
    for (std::size_t a = 0; a < n; ++a) p.x[a] = drifted<true>(p.x[a], p.v[a], dt, step.scale);
  return step;
}

namespace {
// Deform: 0 none, 1 orthorhombic (the step's scale factors), 2 sheared (its matrix F; the
// references s_ref mapped by the cell matrix H).
template <int Deform, bool Gravity, bool Pending>
StepStart kick_drift_check(Particles& p, const CellStep& step, const PeriodicCell& cell, real_t dt,
                           const std::vector<Vec3>& s_ref, const Vec3& g) {
  const Vec3& L = cell.lengths();
  const Mat3 H = cell.matrix();
  const real_t h = 0.5 * dt;
  const std::size_t n = p.n_owned();
  StepStart r;
  real_t im[kKickBlock], iI[kKickBlock];
  for (std::size_t a = 0; a < n; ++a) {
    const std::size_t k = a % kKickBlock;
    if (k == 0) inverse_masses(p, a, std::min(kKickBlock, n - a), im, iI);
    Vec3 v = p.v[a], w = p.w[a];
    if constexpr (Pending) kick(h, im[k], iI[k], p.f[a], p.t[a], v, w);
    kick(h, im[k], iI[k], p.f[a], p.t[a], v, w);
    p.v[a] = v;
    p.w[a] = w;
    if constexpr (Gravity) r.gravity_power += p.mass[a] * g.dot(v);
    Vec3 x;
    if constexpr (Deform == 2) x = drifted_sheared(p.x[a], v, dt, step.F);
    else x = drifted<Deform == 1>(p.x[a], v, dt, step.scale);
    p.x[a] = x;
    if constexpr (Deform == 2) raise_max(r.max_d2, (x - H * s_ref[a]).squaredNorm());
    else raise_max(r.max_d2, (x - s_ref[a].cwiseProduct(L)).squaredNorm());
    raise_max(r.max_v2, v.squaredNorm());
    if constexpr (Gravity) p.f[a] = p.mass[a] * g;
    else p.f[a].setZero();
    p.t[a].setZero();
  }
  return r;
}
}  // namespace

StepStart kick_drift_check(Particles& p, PeriodicCell& cell, real_t dt, const std::vector<Vec3>& s_ref,
                           const Vec3& gravity, bool pending) {
  const CellStep step = cell.deforming() ? cell.deform(dt) : CellStep{};
  // A sheared cell that does not deform still maps its references through H.
  const int deform = cell.sheared() ? 2 : cell.deforming() ? 1 : 0;
  using F =
      StepStart (*)(Particles&, const CellStep&, const PeriodicCell&, real_t, const std::vector<Vec3>&, const Vec3&);
  static constexpr F table[12] = {
      kick_drift_check<0, false, false>, kick_drift_check<0, false, true>,  kick_drift_check<0, true, false>,
      kick_drift_check<0, true, true>,   kick_drift_check<1, false, false>, kick_drift_check<1, false, true>,
      kick_drift_check<1, true, false>,  kick_drift_check<1, true, true>,   kick_drift_check<2, false, false>,
      kick_drift_check<2, false, true>,  kick_drift_check<2, true, false>,  kick_drift_check<2, true, true>};
  StepStart r = table[4 * deform + 2 * !gravity.isZero() + pending](p, step, cell, dt, s_ref, gravity);
  r.deformation = step;
  return r;
}

real_t apply_local_damping(Particles& p, real_t alpha, real_t dt) {
  real_t work = 0;
  const std::size_t n = p.n_owned();
  for (std::size_t a = 0; a < n; ++a) {
    const real_t im = p.inv_mass(a), iI = p.inv_inertia(a);
    for (int k = 0; k < 3; ++k) {
      const real_t df = alpha * std::abs(p.f[a][k]);
      const real_t dm = alpha * std::abs(p.t[a][k]);
      // Velocity at the force evaluation is the half-step one; sign(0) = 0.
      const real_t sv = (p.v[a][k] > 0) - (p.v[a][k] < 0);
      const real_t sw = (p.w[a][k] > 0) - (p.w[a][k] < 0);
      p.f[a][k] -= df * sv;
      p.t[a][k] -= dm * sw;
      // The damping force acts over the half-kick that ends this step and the one that starts
      // the next (the force is unchanged in between); its work over them is exactly
      // F_d . v_end dt, v_end = v + (dt / 2) f / m the velocity at the end of this step (the
      // mean of the three velocities, weighted 1, 2, 1). Booked with v, the half-step velocity,
      // it is over-counted where the velocity reverses within those kicks.
      const real_t v_end = p.v[a][k] + 0.5 * dt * im * p.f[a][k];
      const real_t w_end = p.w[a][k] + 0.5 * dt * iI * p.t[a][k];
      work += (df * sv * v_end + dm * sw * w_end) * dt;
    }
  }
  return work;
}

}  // namespace fabrica
