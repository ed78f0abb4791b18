// Critical time-step estimates of the contact models.
//
// The linear law with rolling resistance: for every sphere i and every partner it could meet (a sphere of the smallest, the same or
// the largest radius of the scene, and a wall if there are walls), the single-contact limits
//   translation: sqrt(m_i / k_n), sqrt(m_i / k_s)
//   rotation:    sqrt(I_i / (k_s R_i^2 + k_r))   (the shear spring acting on the arm R_i plus
//                                                 the rolling spring)
// are taken, reduced by (sqrt(1 + beta^2) - beta) for a dashpot of damping ratio beta (the
// central-difference limit of a damped oscillator), and the smallest over all is returned.
// This is the PFC-style estimate sqrt(m/k); a dense packing with Z contacts per sphere is
// stable only below roughly this estimate times 1/sqrt(Z/2), which is why the time step is a
// user fraction of it (docs/verification.md derives both).
//
// Hertz-Mindlin: the Rayleigh time step pi R sqrt(rho / G) / (0.1631 nu + 0.8766) of the
// smallest sphere (G = E / (2 (1 + nu))), the time a Rayleigh wave takes across it and the
// estimate LIGGGHTS and EDEM check against. A Hertz contact stiffens with its overlap, so no
// stiffness-based estimate holds for every overlap; docs/verification.md compares the
// Rayleigh estimate with sqrt(m / k_n) at the overlaps of a run and with the measured limit.
#pragma once
#include "core/contact_law.hpp"
#include "core/particles.hpp"

namespace fabrica {

// With several materials ('materials' not empty), over every law a sphere may meet (linear) or
// every material's elastic constants (Hertz-Mindlin).
real_t critical_time_step(const Particles& p, const ContactLawParams& law, bool walls,
                          const Materials* materials = nullptr);
// The Rayleigh time step of one sphere of radius R and density rho of the law's material [s].
real_t rayleigh_time_step(real_t radius, real_t density, const ContactLawParams& law);
// The same over a part of the particles (one rank's), with the smallest and largest radius of
// all of them as the partners: the minimum over the ranks of this is the whole set's estimate.
real_t critical_time_step(const Particles& p, const ContactLawParams& law, bool walls, real_t rmin, real_t rmax,
                          const Materials* materials = nullptr);

}  // namespace fabrica
