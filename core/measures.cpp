#include "core/measures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace fabrica {

real_t kinetic_energy(const Particles& p) {
  real_t e = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    e += p.mass[a] * p.v[a].squaredNorm() + p.inertia(a) * p.w[a].squaredNorm();
  return 0.5 * e;
}

void deviatoric_invariants(const Mat3& sigma, real_t& p, real_t& q) {
  p = sigma.trace() / 3.0;
  const Mat3 s = sigma - p * Mat3::Identity();
  q = std::sqrt(1.5 * s.cwiseProduct(s).sum());
}

MacroState reduce_macro_state(const Particles& p, const PeriodicCell& cell, const ContactSums& sums,
                              const Dissipation& diss, Domain& domain) {
  const std::size_t n = p.n_owned();
  std::int64_t nonrattlers = 0, c2 = 0;
  for (std::size_t a = 0; a < n; ++a) {
    const int c = sums.contacts_per_particle[a];
    if (c >= 2) ++nonrattlers, c2 += c;
  }
  enum : int {
    kFb = 0,
    kContacts = 9,
    kSliding,
    kRolling,
    kWall,
    kEn,
    kEs,
    kEr,
    kFc,
    kFp,
    kNonRattlers,
    kC2,
    kN,
    kKin,
    kVs,
    kDf,
    kDr,
    kDv,
    kDl,
    kOv,
    kGw,
    kCount
  };
  double v[kCount];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) v[kFb + 3 * a + b] = sums.fb(a, b) + sums.fb_walls(a, b);
  v[kContacts] = double(sums.contacts);
  v[kSliding] = double(sums.sliding);
  v[kRolling] = double(sums.rolling);
  v[kWall] = double(sums.wall_contacts);
  v[kEn] = sums.e_normal;
  v[kEs] = sums.e_shear;
  v[kEr] = sums.e_rolling;
  v[kFc] = sums.sum_contact_force;
  v[kFp] = sums.sum_particle_force;
  v[kNonRattlers] = double(nonrattlers);
  v[kC2] = double(c2);
  v[kN] = double(n);
  v[kKin] = kinetic_energy(p);
  v[kVs] = p.solid_volume();
  v[kDf] = diss.friction;
  v[kDr] = diss.rolling;
  v[kDv] = diss.viscous;
  v[kDl] = diss.local;
  v[kOv] = sums.sum_overlap;
  v[kGw] = sums.work_gravity;
  domain.sum_all(std::span<double>(v, kCount));
  // The walls' forces (the same wall count on every rank: a collective only with walls).
  std::vector<double> wf(3 * sums.wall_force.size());
  for (std::size_t w = 0; w < sums.wall_force.size(); ++w)
    for (int k = 0; k < 3; ++k) wf[3 * w + k] = sums.wall_force[w][k];
  if (!wf.empty()) domain.sum_all(std::span<double>(wf));

  // Sanity figures: the global maxima and their owners' ids (ties: the largest ids win).
  GlobalId nonfinite = std::numeric_limits<GlobalId>::max();
  real_t vmax2 = -1;
  std::size_t fast = n;
  for (std::size_t a = 0; a < n; ++a) {
    if (!p.x[a].allFinite() || !p.v[a].allFinite() || !p.w[a].allFinite()) nonfinite = std::min(nonfinite, p.id[a]);
    const real_t v2 = p.v[a].squaredNorm();
    if (v2 > vmax2 || (v2 == vmax2 && p.id[a] > p.id[fast])) vmax2 = v2, fast = a;
  }
  double mx[3] = {sums.max_overlap_ratio, -double(nonfinite), vmax2};
  domain.max_all(std::span<double>(mx, 3));
  const real_t max_ratio = mx[0], bad = -mx[1];
  const bool mine = sums.max_overlap_a >= 0 && sums.max_overlap_ratio == max_ratio;
  const bool fastest_here = fast < n && vmax2 == mx[2];
  double ids[2] = {mine ? double(sums.max_overlap_a) : -1.0, fastest_here ? double(p.id[fast]) : -1.0};
  domain.max_all(std::span<double>(ids, 2));
  // Second round: the partner of the largest overlap, and the fastest particle's v and w, from
  // their owners (everyone else sends -1e300).
  double second[7];
  std::fill(second, second + 7, -1e300);
  if (mine && double(sums.max_overlap_a) == ids[0]) second[0] = double(sums.max_overlap_b);
  if (fastest_here && double(p.id[fast]) == ids[1])
    for (int k = 0; k < 3; ++k) second[1 + k] = p.v[fast][k], second[4 + k] = p.w[fast][k];
  domain.max_all(std::span<double>(second, 7));
  const real_t ida = ids[0], idb = second[0];

  MacroState m;
  m.volume = cell.volume();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) m.stress(a, b) = v[kFb + 3 * a + b] / m.volume;
  deviatoric_invariants(m.stress, m.p, m.q);
  const double N = v[kN];
  m.contacts = std::int64_t(v[kContacts]);
  m.sliding = std::int64_t(v[kSliding]);
  m.rolling = std::int64_t(v[kRolling]);
  m.wall_contacts = std::int64_t(v[kWall]);
  m.wall_force.resize(sums.wall_force.size());
  for (std::size_t w = 0; w < m.wall_force.size(); ++w) m.wall_force[w] = Vec3(wf[3 * w], wf[3 * w + 1], wf[3 * w + 2]);
  m.coordination = N > 0 ? 2.0 * v[kContacts] / N : 0.0;
  m.mech_coordination = v[kNonRattlers] > 0 ? v[kC2] / v[kNonRattlers] : 0.0;
  m.kinetic = v[kKin];
  m.e_normal = v[kEn];
  m.e_shear = v[kEs];
  m.e_rolling = v[kEr];
  m.dissipated = {v[kDf], v[kDr], v[kDv], v[kDl]};
  const double nc = v[kContacts] + v[kWall];
  m.unbalanced = (nc > 0 && v[kFc] > 0) ? (v[kFp] / N) / (v[kFc] / nc) : 0.0;
  m.void_ratio = m.volume / v[kVs] - 1.0;
  m.particles = std::int64_t(N);
  m.mean_overlap = v[kContacts] > 0 ? v[kOv] / v[kContacts] : 0.0;
  m.max_overlap_ratio = max_ratio;
  m.gravity_work = v[kGw];
  m.max_overlap_a = GlobalId(ida);
  m.max_overlap_b = ida >= 0 ? GlobalId(idb) : -1;
  m.first_nonfinite = bad < real_t(std::numeric_limits<GlobalId>::max()) ? GlobalId(bad) : -1;
  m.fastest = GlobalId(ids[1]);
  if (m.fastest >= 0) {
    m.fastest_v = Vec3(second[1], second[2], second[3]);
    m.fastest_w = Vec3(second[4], second[5], second[6]);
  }
  return m;
}

real_t energy_books(const MacroState& m) {
  const Dissipation& d = m.dissipated;
  return m.kinetic + m.e_normal + m.e_shear + m.e_rolling + d.friction + d.rolling + d.viscous + d.local;
}

std::string diagnose(const MacroState& m, std::int64_t step, real_t max_overlap_ratio, real_t kinetic_runaway) {
  std::ostringstream s;
  s.precision(6);
  if (m.first_nonfinite >= 0 || !std::isfinite(m.kinetic) || !std::isfinite(m.p)) {
    s << "numerical blow-up at step " << step << ": ";
    if (m.first_nonfinite >= 0)
      s << "particle " << m.first_nonfinite << " has a non-finite position, velocity or spin; ";
    s << "kinetic energy " << m.kinetic << " J, p " << m.p << " Pa";
  } else if (m.max_overlap_ratio > max_overlap_ratio) {
    s << "numerical blow-up at step " << step << ": overlap of particles " << m.max_overlap_a << " and "
      << m.max_overlap_b << " is " << m.max_overlap_ratio << " of the smaller radius (limit " << max_overlap_ratio
      << "); the time step is too large for the stiffness, or the specimen was generated with "
         "overlaps";
  } else if (kinetic_runaway > 0 &&
             (m.kinetic > kinetic_runaway * m.energy_input || energy_books(m) > kinetic_runaway * m.energy_input)) {
    s << "numerical blow-up at step " << step << ": kinetic energy " << m.kinetic
      << " J, or the stored + dissipated energy, exceeds " << kinetic_runaway
      << " times the energy put into the system, " << m.energy_input
      << " J (initial kinetic + elastic energy + boundary work + work of gravity); fastest "
         "particle "
      << m.fastest << ": velocity (" << m.fastest_v[0] << ", " << m.fastest_v[1] << ", " << m.fastest_v[2]
      << ") m/s, |v| " << m.fastest_v.norm() << " m/s, spin (" << m.fastest_w[0] << ", " << m.fastest_w[1] << ", "
      << m.fastest_w[2] << ") rad/s; stored + dissipated energy " << energy_books(m)
      << " J; the time step is too large for the stiffness";
  }
  return s.str();
}

}  // namespace fabrica
