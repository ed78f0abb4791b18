#include "core/integrator.hpp"

#include <cmath>

namespace fabrica {

void half_kick(Particles& p, real_t dt) {
  const real_t h = 0.5 * dt;
  const std::size_t n = p.n_owned();
  for (std::size_t a = 0; a < n; ++a) {
    p.v[a] += (h * p.inv_mass[a]) * p.f[a];
    p.w[a] += (h * p.inv_inertia[a]) * p.t[a];
  }
}

void drift_and_deform(Particles& p, PeriodicCell& cell, real_t dt) {
  const std::size_t n = p.n_owned();
  if (cell.strain_rate().isZero()) {
    for (std::size_t a = 0; a < n; ++a) p.x[a] += dt * p.v[a];
    return;
  }
  const Vec3 s = cell.deform(dt);
  for (std::size_t a = 0; a < n; ++a) p.x[a] = (p.x[a] + dt * p.v[a]).cwiseProduct(s);
}

real_t apply_local_damping(Particles& p, real_t alpha, real_t dt) {
  real_t work = 0;
  const std::size_t n = p.n_owned();
  for (std::size_t a = 0; a < n; ++a) {
    for (int k = 0; k < 3; ++k) {
      const real_t df = alpha * std::abs(p.f[a][k]);
      const real_t dm = alpha * std::abs(p.t[a][k]);
      // Velocity at the force evaluation is the half-step one; sign(0) = 0.
      const real_t sv = (p.v[a][k] > 0) - (p.v[a][k] < 0);
      const real_t sw = (p.w[a][k] > 0) - (p.w[a][k] < 0);
      p.f[a][k] -= df * sv;
      p.t[a][k] -= dm * sw;
      work += (df * std::abs(p.v[a][k]) + dm * std::abs(p.w[a][k])) * dt;
    }
  }
  return work;
}

}  // namespace fabrica
