// The FCC lattice of issue 13 for the apps tests: 108 spheres (3 x 3 x 3 FCC cells), R = 10 mm,
// k_n = k_s = 1e8 N/m, nearest neighbours 1e-9 m closer than touching (p = 0.7 kPa). Every
// sphere is equivalent by symmetry: the lattice deforms affinely with the cell and stays at
// rest; its stiffness is M_kl = (4 k_n / a) delta_kl, and with dashpots c_n = c_s = c its
// viscosity C_kl = (4 c / a) delta_kl (tests/apps/test_servo.cpp).
#pragma once
#include "core/simulation.hpp"

#include <cmath>
#include <numbers>
#include <string>

namespace fabrica {

struct Fcc {
  static constexpr real_t R = 0.01, kn = 1e8;
  real_t a = 2 * std::sqrt(2.0) * R - 1e-9 * std::sqrt(2.0);  // lattice constant
  real_t damping_rate = 0;                                    // eta of both dashpots, 1/s (c = eta m_eff = eta m / 2)
  real_t dt_fraction = 0.1;                                   // time step / sqrt(m / k_n)
  Simulation make() const {
    Particles p;
    const Vec3 basis[4] = {Vec3(0, 0, 0), Vec3(0.5, 0.5, 0), Vec3(0.5, 0, 0.5), Vec3(0, 0.5, 0.5)};
    GlobalId id = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          for (const Vec3& b : basis) p.add({id++, R, 2650.0, (Vec3(i, j, k) + b + Vec3::Constant(0.25)) * a});
    SimulationParams sp;
    sp.law.stiffness_mode = NormalStiffnessMode::Direct;
    sp.law.normal_stiffness = kn;
    sp.law.stiffness_ratio = 1.0;
    sp.law.damping_rate_n = sp.law.damping_rate_s = damping_rate;
    const real_t m = 2650.0 * 4.0 / 3.0 * std::numbers::pi * R * R * R;
    sp.dt = dt_fraction * std::sqrt(m / kn);
    sp.skin = 0.001;
    return Simulation(std::move(p), PeriodicCell(Vec3::Constant(3 * a)), sp);
  }
  real_t stiffness() const { return 4 * kn / a; }  // M_kk, Pa
  real_t mass() const { return 2650.0 * 4.0 / 3.0 * std::numbers::pi * R * R * R; }
  real_t viscosity() const { return 4 * damping_rate * mass() / 2 / a; }  // C_kk, Pa s
};

// A [[stage]] list for the lattice: a consolidation to 100 kPa (at rest), then 'stage' (a
// [[stage]] table's body).
inline std::string lattice_stage_scene(const std::string& stage) {
  return "\n[run]\noutput_every = 10\n\n[[stage]]\ntype = \"isotropic\"\npressure = 100e3\nfriction = 1e3\n"
         "end = { at_rest = true }\n\n[[stage]]\n" +
      stage + "\n";
}

}  // namespace fabrica
