#include "core/measures.hpp"

#include <cmath>

namespace fabrica {

real_t kinetic_energy(const Particles& p) {
  real_t e = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    e += p.mass[a] * p.v[a].squaredNorm() + p.inertia[a] * p.w[a].squaredNorm();
  return 0.5 * e;
}

void deviatoric_invariants(const Mat3& sigma, real_t& p, real_t& q) {
  p = sigma.trace() / 3.0;
  const Mat3 s = sigma - p * Mat3::Identity();
  q = std::sqrt(1.5 * s.cwiseProduct(s).sum());
}

MacroState macro_state(const Particles& p, const PeriodicCell& cell, const ContactSums& sums,
                       const Dissipation& diss) {
  MacroState m;
  m.volume = cell.volume();
  m.stress = sums.fb / m.volume;
  deviatoric_invariants(m.stress, m.p, m.q);
  const std::size_t n = p.n_owned();
  m.contacts = sums.contacts;
  m.sliding = sums.sliding;
  m.rolling = sums.rolling;
  m.coordination = n ? 2.0 * double(sums.contacts) / double(n) : 0.0;
  std::int64_t nonrattlers = 0, c2 = 0;
  for (std::size_t a = 0; a < n; ++a) {
    const int c = sums.contacts_per_particle[a];
    if (c >= 2) ++nonrattlers, c2 += c;
  }
  m.mech_coordination = nonrattlers ? double(c2) / double(nonrattlers) : 0.0;
  m.kinetic = kinetic_energy(p);
  m.e_normal = sums.e_normal;
  m.e_shear = sums.e_shear;
  m.e_rolling = sums.e_rolling;
  m.dissipated = diss;
  const std::int64_t nc = sums.contacts + sums.wall_contacts;
  m.unbalanced = (nc > 0 && sums.sum_contact_force > 0)
                     ? (sums.sum_particle_force / double(n)) / (sums.sum_contact_force / double(nc))
                     : 0.0;
  m.void_ratio = m.volume / p.solid_volume() - 1.0;
  return m;
}

}  // namespace fabrica
