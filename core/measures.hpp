// Macroscopic measures of the cell. Sign convention everywhere: compression positive.
//   sigma_ij = (1/V) sum_c f_i^c b_j^c      (Love-Weber; f on the body the branch points to)
//   p = sigma_kk / 3,  q = sqrt(3/2 s_ij s_ij),  s = sigma - p I
//   Z = 2 C / N (all particles), Z_m = 2 C' / N' without rattlers (fewer than 2 contacts)
#pragma once
#include "core/domain.hpp"
#include "core/forces.hpp"

#include <string>
#include <vector>

namespace fabrica {

struct MacroState {
  Mat3 stress = Mat3::Zero();    // Pa
  real_t p = 0, q = 0;           // Pa
  real_t coordination = 0;       // Z
  real_t mech_coordination = 0;  // Z_m
  std::int64_t contacts = 0, sliding = 0, rolling = 0;
  real_t kinetic = 0;                               // J: translational (fluctuating) + rotational
  real_t e_normal = 0, e_shear = 0, e_rolling = 0;  // J
  Dissipation dissipated;                           // J, cumulative
  real_t unbalanced = 0;                            // mean |F_particle| / mean |F_contact|
  real_t volume = 0;                                // m^3
  real_t void_ratio = 0;
  std::int64_t particles = 0;  // over all ranks
  // Sanity: the largest overlap relative to the smaller radius and its two bodies, and the
  // first particle (lowest id) with a non-finite position, velocity or spin (-1 if none).
  real_t mean_overlap = 0;  // m, over particle-particle contacts
  real_t max_overlap_ratio = 0;
  GlobalId max_overlap_a = -1, max_overlap_b = -1;
  GlobalId first_nonfinite = -1;
  // The fastest particle (largest |v|, fluctuating velocity; ties: the largest id) and its
  // velocity and spin, for the kinetic-energy runaway guard.
  GlobalId fastest = -1;
  Vec3 fastest_v = Vec3::Zero(), fastest_w = Vec3::Zero();  // m/s, rad/s
  // Energy put into the system since the simulation was built [J]: the stored energy at
  // construction (kinetic + elastic) + boundary work of the deforming cell + work of gravity
  // (filled by Simulation; see Simulation::energy_input).
  real_t energy_input = 0;
  real_t gravity_work = 0;  // J, cumulative work of gravity (reduced)
  // Walls (core/contact_list.hpp): contacts with walls are counted apart (not in 'contacts',
  // Z or the fabric); their forces are in 'stress' (the arm from the sphere's centre to the
  // contact point, over the cell volume).
  std::int64_t wall_contacts = 0;
  std::vector<Vec3> wall_force;  // N, the spheres' force on each wall
  real_t wall_work = 0;          // J, cumulative work of the moving walls (filled by Simulation)
  real_t drive_work = 0;         // J, cumulative work of the drive of driven particles (idem)
};

// A message naming the step, the particle ids and the values if the state is not physical;
// empty if the state is sane. The same on every rank (it reads reduced values only). Checked:
//  - non-finite positions, velocities or spins;
//  - an overlap above max_overlap_ratio of the smaller radius;
//  - kinetic energy, or stored + dissipated energy (energy_books), above kinetic_runaway *
//    m.energy_input (when kinetic_runaway > 0). Energy conservation gives
//    kinetic <= kinetic + elastic + dissipated = input, since the elastic energy and the
//    dissipation are never negative; an unstable integration creates energy from nothing, which
//    shows as kinetic energy, or, once friction has absorbed it, as excess dissipation. The
//    factor covers the known errors of the energy account (docs/verification.md, section 15).
// Kinetic + elastic energy + cumulative dissipation [J]; equals m.energy_input without
// numerical error.
real_t energy_books(const MacroState& m);

std::string diagnose(const MacroState& m, std::int64_t step, real_t max_overlap_ratio, real_t kinetic_runaway = 0);

real_t kinetic_energy(const Particles& p);
void deviatoric_invariants(const Mat3& sigma, real_t& p, real_t& q);

// Reduces this rank's sums over all ranks of the domain (one sum_all of a small array) and
// assembles the macroscopic state. Collective.
MacroState reduce_macro_state(const Particles& p, const PeriodicCell& cell, const ContactSums& sums,
                              const Dissipation& diss, Domain& domain);

}  // namespace fabrica
