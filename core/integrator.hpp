// Velocity Verlet for translation and rotation of spheres (isotropic inertia, so no
// orientation is needed): half-kick, drift, forces, half-kick. Forces in the second half
// therefore see the half-step velocity, as in LAMMPS' nve/sphere.
//
// Local (non-viscous, PFC-style) damping, when alpha > 0, replaces each force and torque
// component F_k by F_k - alpha |F_k| sign(v_k); it runs as a separate pass only when enabled.
#pragma once
#include "core/cell.hpp"
#include "core/particles.hpp"

namespace fabrica {

// v += dt/2 f/m, w += dt/2 t/I for owned particles.
void half_kick(Particles& p, real_t dt);

// x += dt v (owned particles), then the cell deforms by dt and positions follow affinely.
void drift_and_deform(Particles& p, PeriodicCell& cell, real_t dt);

// Applies local damping to f and t of owned particles; returns the work the damping forces do
// against the motion over the two half-kicks they act in [J] (exact for velocity Verlet).
real_t apply_local_damping(Particles& p, real_t alpha, real_t dt);

}  // namespace fabrica
