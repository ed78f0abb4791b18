// A small specimen for the tests of a sheared cell's input and output (checkpoints, snapshots,
// XDMF; issue 42): n spheres of diameters 8 to 12 mm placed at random at a solid fraction of 0.35
// and compressed isotropically to about 0.61 (serially), with friction and rolling resistance;
// then simple shear, planes normal to axis 1 sliding along axis 2 (g21), which passes a flip of
// the cell (PeriodicCell::kFlipRatio = 0.6 of the edge) on its way to a shear strain of 0.8.
#pragma once
#include "core/generate.hpp"
#include "core/simulation.hpp"
#include "core/timestep.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>
#include <vector>

namespace fabrica::test {

// The start of a sheared run: particles, an orthorhombic cell at rest and the parameters.
struct ShearedStart {
  Particles particles;
  PeriodicCell cell;
  SimulationParams params;
};

inline ShearedStart sheared_start(int n = 600, std::uint64_t seed = 42) {
  Random rng(seed);
  std::vector<real_t> d(static_cast<std::size_t>(n));
  real_t vs = 0;
  for (real_t& x : d) {
    x = 0.008 + 0.004 * rng.uniform();
    vs += std::numbers::pi / 6 * x * x * x;
  }
  const PeriodicCell cell(Vec3::Constant(std::cbrt(vs / 0.35)));
  Particles p = random_packing(d, 2650.0, cell, rng);
  SimulationParams sp;
  sp.law.youngs_modulus = 50e6;
  sp.law.friction = 0.4;
  sp.law.rolling_friction = 0.1;
  sp.skin = 0.001;
  sp.dt = 0.3 * critical_time_step(p, sp.law, false);
  Simulation sim(std::move(p), cell, sp);
  const int steps = 1500;
  sim.cell().set_strain_rate(Vec3::Constant(std::log(0.83) / (steps * sp.dt)));
  for (int k = 0; k < steps; ++k) sim.step();
  sim.cell().set_strain_rate(Vec3::Zero());
  return {sim.particles(), sim.cell(), sim.params()};
}

// Simple shear at the engineering rate that reaches 'gamma' in 'steps' steps (g21 = rate).
inline void simple_shear(Simulation& sim, real_t gamma, std::int64_t steps) {
  Mat3 g = Mat3::Zero();
  g(1, 0) = gamma / (real_t(steps) * sim.params().dt);
  sim.cell().set_velocity_gradient(g);
}

}  // namespace fabrica::test
