// Velocity Verlet for translation and rotation of spheres (isotropic inertia, so no
// orientation is needed): half-kick, drift, forces, half-kick. Forces in the second half
// therefore see the half-step velocity, as in LAMMPS' nve/sphere.
//
// Local (non-viscous, PFC-style) damping, when alpha > 0, replaces each force and torque
// component F_k by F_k - alpha |F_k| sign(v_k); it runs as a separate pass only when enabled.
#pragma once
#include "core/cell.hpp"
#include "core/particles.hpp"

#include <limits>
#include <vector>

namespace fabrica {

// The inverse masses and moments of inertia of particles [first, first + n) into im and iI:
// the expressions of Particles::inv_mass and inv_inertia, over the contiguous mass and radius
// arrays, so that the divisions vectorise (four to an instruction with AVX2); at large N the
// pass waits on memory and they cost nothing (benchmarks/README.md, "The moment of inertia and
// the inverse masses derived, not stored").
inline void inverse_masses(const Particles& p, std::size_t first, std::size_t n, real_t* im, real_t* iI) {
  const real_t* m = p.mass.data() + first;
  const real_t* R = p.radius.data() + first;
  for (std::size_t k = 0; k < n; ++k) {
    im[k] = 1.0 / m[k];
    iI[k] = 1.0 / (0.4 * m[k] * R[k] * R[k]);
  }
}
// How many particles a half kick takes its inverses for at a time (inverse_masses' room).
inline constexpr std::size_t kKickBlock = 64;

// v += h f/m and w += h t/I (h = dt/2, im = 1/m, iI = 1/I): the one arithmetic of every half kick.
inline void kick(real_t h, real_t im, real_t iI, const Vec3& f, const Vec3& t, Vec3& v, Vec3& w) {
  v += (h * im) * f;
  w += (h * iI) * t;
}

// x advanced over dt at velocity v, then (Deform) scaled by the cell's deformation s of the
// step: the one arithmetic of every drift, the owned particles' and the ghosts' copies of them
// (which the MPI domain advances itself, parallel/mpi_domain.cpp, so that they stay their
// owners' bits without being sent).
template <bool Deform>
inline Vec3 drifted(Vec3 x, const Vec3& v, real_t dt, const Vec3& s) {
  x += dt * v;
  if constexpr (Deform) x = x.cwiseProduct(s);
  return x;
}
// The same in a sheared cell: x advanced, then mapped by the step's deformation F.
inline Vec3 drifted_sheared(Vec3 x, const Vec3& v, real_t dt, const Mat3& F) {
  x += dt * v;
  return F * x;
}

// m = the larger of m and x, a non-finite x counting as infinity (so that the maximum over the
// ranks is exact and the same on each): the rebuild check's maxima.
inline void raise_max(real_t& m, real_t x) {
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  m = x <= m ? m : (x < inf ? x : inf);
}

// v += dt/2 f/m, w += dt/2 t/I for owned particles.
void half_kick(Particles& p, real_t dt);

// x += dt v (owned particles), then the cell deforms by dt and positions follow affinely;
// returns the cell's deformation over the step (scale factors of ones if it does not strain).
CellStep drift_and_deform(Particles& p, PeriodicCell& cell, real_t dt);

// What the start of a step measures on the way (kick_drift_check).
struct StepStart {
  real_t max_d2 = 0;         // the largest |x - ref|^2 since the last rebuild (non-finite: infinity)
  real_t max_v2 = 0;         // the largest |v|^2 after the kick (non-finite: infinity)
  real_t gravity_power = 0;  // sum of m g . v after the kick [W]
  CellStep deformation;      // the cell's deformation over the step (drifted())
};

// The start of a step in one pass over the owned particles, for a run without driven
// particles: with 'pending', first the previous step's closing half_kick (left to this pass,
// Simulation::step), then half_kick, then gravity's power with the kicked velocity, then
// drift_and_deform, then the rebuild check's maxima (the reference positions s_ref are
// fractions of the cell, compared with x at the deformed cell's edges); last, f = m g and
// t = 0, the values the force computation starts from (ForceContext::owned_ready). The same
// values, bit for bit, as those loops one after another: each particle's arithmetic is the
// same and the power is summed in the same order. At 10^6 spheres the arrays leave the cache,
// and separate loops read them once each.
StepStart kick_drift_check(Particles& p, PeriodicCell& cell, real_t dt, const std::vector<Vec3>& s_ref,
                           const Vec3& gravity, bool pending);

// Applies local damping to f and t of owned particles; returns the work the damping forces do
// against the motion over the two half-kicks they act in [J] (exact for velocity Verlet).
real_t apply_local_damping(Particles& p, real_t alpha, real_t dt);

}  // namespace fabrica
