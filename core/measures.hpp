// Macroscopic measures of the cell. Sign convention everywhere: compression positive.
//   sigma_ij = (1/V) sum_c f_i^c b_j^c      (Love-Weber; f on the body the branch points to)
//   p = sigma_kk / 3,  q = sqrt(3/2 s_ij s_ij),  s = sigma - p I
//   Z = 2 C / N (all particles), Z_m = 2 C' / N' without rattlers (fewer than 2 contacts)
#pragma once
#include "core/domain.hpp"
#include "core/forces.hpp"

#include <string>

namespace fabrica {

struct MacroState {
  Mat3 stress = Mat3::Zero();  // Pa
  real_t p = 0, q = 0;         // Pa
  real_t coordination = 0;     // Z
  real_t mech_coordination = 0;// Z_m
  std::int64_t contacts = 0, sliding = 0, rolling = 0;
  real_t kinetic = 0;          // J: translational (fluctuating) + rotational
  real_t e_normal = 0, e_shear = 0, e_rolling = 0;  // J
  Dissipation dissipated;      // J, cumulative
  real_t unbalanced = 0;       // mean |F_particle| / mean |F_contact|
  real_t volume = 0;           // m^3
  real_t void_ratio = 0;
  std::int64_t particles = 0;  // over all ranks
  // Sanity: the largest overlap relative to the smaller radius and its two bodies, and the
  // first particle (lowest id) with a non-finite position, velocity or spin (-1 if none).
  real_t mean_overlap = 0;  // m, over particle-particle contacts
  real_t max_overlap_ratio = 0;
  GlobalId max_overlap_a = -1, max_overlap_b = -1;
  GlobalId first_nonfinite = -1;
};

// A message naming the step, the particle ids and the values if the state is not physical
// (non-finite values, or an overlap above max_overlap_ratio of the smaller radius); empty if
// the state is sane. The same on every rank (it reads reduced values only).
std::string diagnose(const MacroState& m, std::int64_t step, real_t max_overlap_ratio);

real_t kinetic_energy(const Particles& p);
void deviatoric_invariants(const Mat3& sigma, real_t& p, real_t& q);

// Reduces this rank's sums over all ranks of the domain (one sum_all of a small array) and
// assembles the macroscopic state. Collective.
MacroState reduce_macro_state(const Particles& p, const PeriodicCell& cell,
                              const ContactSums& sums, const Dissipation& diss, Domain& domain);

}  // namespace fabrica
