// The energy account of a straining cell (Simulation::boundary_work) against its closed form.
// A simple cubic lattice of equal spheres with linear springs, no friction slip, no damping,
// strained along the three axes at piecewise-constant rates (changed every 'interval' steps,
// as a servo does, and measured only then) stays affine: every sphere has two opposite,
// equal contacts per axis, so the net forces vanish and no kinetic energy appears. The stored
// elastic energy is then a function of the cell alone,
//   E = sum_k n^3 k_n u_k^2 / 2,   u_k = 2 R - L_k / n   (n^3 contacts along each axis),
// and the boundary work must equal its change. Tolerance: |W - (E - E0)| < 1e-6 of the largest
// E along the path, at every measurement, for measuring intervals 1, 5 and 25 (the trapezoid
// of the step is exact to O((edot dt)^2), about 1e-10 here).
#include "core/generate.hpp"
#include "core/simulation.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace fabrica {
namespace {

struct Lattice {
  int n = 3;
  real_t R = 0.01, kn = 1e6;
  real_t elastic(const Vec3& L) const {
    real_t e = 0;
    for (int k = 0; k < 3; ++k) {
      const real_t u = std::max<real_t>(0, 2 * R - L[k] / n);
      e += n * n * n * 0.5 * kn * u * u;
    }
    return e;
  }
};

// The largest |W - (E - E0)| over the measurements, relative to the largest E, and the final W.
struct Account {
  real_t error, work;
};
Account account_error(int interval, bool every_step_measured) {
  const Lattice lat;
  const real_t a0 = 2 * lat.R - 2e-6;
  Particles p = simple_cubic(lat.n, lat.R, a0, test::kRho);
  SimulationParams sp;
  sp.law = test::direct_law(lat.kn, 0.5);
  sp.dt = 0.2 * critical_time_step(p, sp.law, false);
  sp.skin = 0.1 * lat.R;
  Simulation sim(std::move(p), PeriodicCell(Vec3::Constant(lat.n * a0)), sp);
  const real_t E0 = lat.elastic(sim.cell().lengths());
  EXPECT_NEAR(sim.macro().e_normal, E0, 1e-9 * E0);
  // Rates of a few 1e-4 per step of strain: loading to about 8 times the initial overlap,
  // then a partial unloading, each axis on its own schedule.
  const int steps = 3000;
  const real_t base = 4e-4 / (steps * sp.dt);  // 1/s
  real_t worst = 0, emax = E0;
  for (int s = 0; s < steps; ++s) {
    if (s % interval == 0) {
      const real_t t = real_t(s) / steps;
      Vec3 r;
      for (int k = 0; k < 3; ++k) r[k] = -base * (t < 0.7 ? 1.0 + 0.5 * std::sin(9 * t + 2 * k) : -1.5 - 0.5 * k);
      sim.cell().set_strain_rate(r);
    }
    const bool measure = every_step_measured || (s + 1) % interval == 0;
    sim.step(measure);
    if (!measure) continue;
    const real_t E = lat.elastic(sim.cell().lengths());
    emax = std::max(emax, E);
    EXPECT_NEAR(sim.macro().e_normal, E, 1e-9 * E);  // the lattice is affine
    worst = std::max(worst, std::abs(sim.boundary_work() - (E - E0)));
    EXPECT_NEAR(sim.macro().energy_input, sim.macro().e_normal + sim.macro().kinetic, 1e-6 * E);
  }
  const MacroState& m = sim.macro();
  std::printf(
      "[energy account] interval %d%s: W = %.9e J, E - E0 = %.9e J (max E %.3e J), "
      "error %.2e of max E, kinetic %.1e J\n",
      interval, every_step_measured ? " (every step measured)" : "", sim.boundary_work(),
      lat.elastic(sim.cell().lengths()) - E0, emax, worst / emax, m.kinetic);
  EXPECT_LT(m.kinetic, 1e-12 * emax);
  return {worst / emax, sim.boundary_work()};
}

TEST(EnergyAccount, AffineLatticeAtAnyMeasuringInterval) {
  for (int interval : {1, 5, 25}) EXPECT_LT(account_error(interval, false).error, 1e-6) << interval;
}

// Measuring changes nothing in the account: the same path measured at every step gives the
// same work, bit for bit (a straining step sums the same virial whether it measures or not).
TEST(EnergyAccount, IndependentOfMeasuring) {
  const Account a = account_error(25, false), b = account_error(25, true);
  EXPECT_EQ(a.work, b.work);
}

}  // namespace
}  // namespace fabrica
