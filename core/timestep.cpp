#include "core/timestep.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

namespace {
real_t damping_factor(real_t beta) { return std::sqrt(1.0 + beta * beta) - beta; }

// One sphere against each of its possible partners, with the law 'law'.
real_t linear_time_step(const Particles& p, std::size_t a, const ContactLawParams& law, bool walls, real_t rmin,
                        real_t rmax) {
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  real_t best = inf;
  {
    const real_t R = p.radius[a], m = p.mass[a], I = p.inertia(a);
    const real_t partners[4] = {rmin, R, rmax, inf};
    for (int q = 0; q < (walls ? 4 : 3); ++q) {
      const real_t R2 = partners[q];
      // Partner mass scales with its volume at the same density.
      const real_t m2 = std::isinf(R2) ? inf : m * (R2 / R) * (R2 / R) * (R2 / R);
      const PairConstants c = pair_constants<true, true>(law, R, R2, m, m2);
      const real_t meff = std::isinf(m2) ? m : m * m2 / (m + m2);
      const real_t beta_n = (c.cn > 0) ? c.cn / (2 * std::sqrt(meff * c.kn)) : 0.0;
      const real_t beta_s = (c.cs > 0) ? c.cs / (2 * std::sqrt(meff * c.ks)) : 0.0;
      const real_t kr = law.rolling() ? c.kr : 0.0;
      best = std::min(best, std::sqrt(m / c.kn) * damping_factor(beta_n));
      best = std::min(best, std::sqrt(m / c.ks) * damping_factor(beta_s));
      best = std::min(best, std::sqrt(I / (c.ks * R * R + kr)) * damping_factor(beta_s));
    }
  }
  return best;
}

// The laws sphere a may meet: the scene's, or with several materials every pair of its own
// material with any (walls' included).
template <class F>
void each_law(const Particles& p, std::size_t a, const ContactLawParams& law, const Materials* materials, F&& f) {
  if (!materials || materials->empty()) return f(law);
  for (std::size_t b = 0; b < materials->size(); ++b) f(materials->pair(p.material[a], b));
}
}  // namespace

real_t rayleigh_time_step(real_t radius, real_t density, const ContactLawParams& law) {
  const real_t nu = law.poisson_ratio;
  const real_t G = law.youngs_modulus / (2.0 * (1.0 + nu));
  return std::numbers::pi * radius * std::sqrt(density / G) / (0.1631 * nu + 0.8766);
}

real_t critical_time_step(const Particles& p, const ContactLawParams& law, bool walls, const Materials* materials) {
  return critical_time_step(p, law, walls, p.min_radius(), p.max_radius(), materials);
}

real_t critical_time_step(const Particles& p, const ContactLawParams& law, bool walls, real_t rmin, real_t rmax,
                          const Materials* materials) {
  real_t best = std::numeric_limits<real_t>::infinity();
  if (law.model == ContactModel::Linear) {
    for (std::size_t a = 0; a < p.n_owned(); ++a)
      each_law(p, a, law, materials,
               [&](const ContactLawParams& l) { best = std::min(best, linear_time_step(p, a, l, walls, rmin, rmax)); });
    return best;
  }
  // Hertz-Mindlin: the Rayleigh time of every sphere of this share (its own density), of its
  // material and, with several, of every material's elastic constants (a stiffer partner's).
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const real_t R = p.radius[a];
    const real_t rho = p.mass[a] / (4.0 / 3.0 * std::numbers::pi * R * R * R);
    if (!materials || materials->empty()) best = std::min(best, rayleigh_time_step(R, rho, law));
    else
      for (const ContactLawParams& l : materials->laws) best = std::min(best, rayleigh_time_step(R, rho, l));
  }
  return best;
}

}  // namespace fabrica
