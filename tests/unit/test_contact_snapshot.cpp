// Contact records (core/contact_snapshot.hpp) against the engine's own measures on a sheared
// polydisperse packing with sliding and rolling contacts: the records' Love-Weber stress
// (1/V) sum f (x) b equals the measured stress (relative 1e-12, rounding only; no dashpots, so
// the records' forces are the whole contact forces), and the numbers of contacts, sliding and
// rolling contacts are those the force loop counted (exactly).
#include "core/contact_snapshot.hpp"
#include "core/generate.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <cstdio>

namespace fabrica {
namespace {

void check(real_t mu_r) {
  Random rng(5);
  std::vector<real_t> d = fractal_diameters(400, 1.9, 0.01, 0.05, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  const real_t L = std::cbrt(vs / 0.35);
  const PeriodicCell big(Vec3::Constant(L));
  Particles p = random_packing(d, test::kRho, big, rng);
  SimulationParams sp;
  sp.law.youngs_modulus = 50e6;
  sp.law.friction = 0.3;
  sp.law.rolling_friction = mu_r;
  sp.skin = 0.002;
  sp.dt = 0.3 * critical_time_step(p, sp.law, false);
  sp.local_damping = 0.2;
  Simulation sim(std::move(p), big, sp);
  // Compress isotropically to a nominal solid fraction of 0.67, then shear at constant volume.
  const int n1 = 3000, n2 = 2000;
  sim.cell().set_strain_rate(Vec3::Constant(std::log(0.81) / (n1 * sp.dt)));
  for (int s = 0; s < n1; ++s) sim.step();
  const real_t r = 0.1 / (n2 * sp.dt);
  sim.cell().set_strain_rate(Vec3(-r, 0.5 * r, 0.5 * r));
  for (int s = 0; s < n2; ++s) sim.step(s == n2 - 1);
  const MacroState& m = sim.macro();
  const auto recs = contact_records(sim.particles(), sim.cell(), sim.params().law, sim.pairs());
  Mat3 fb = Mat3::Zero();
  std::int64_t sliding = 0, rolling = 0;
  for (const ContactRecord& c : recs) {
    ASSERT_LT(c.id1, c.id2);
    ASSERT_NEAR(c.normal.norm(), 1.0, 1e-14);
    ASSERT_NEAR(c.ft.dot(c.normal), 0.0, 1e-9 * (c.fn + c.ft.norm()));
    fb += c.force() * c.branch.transpose();
    sliding += c.sliding;
    rolling += c.rolling;
  }
  const Mat3 sigma = fb / sim.cell().volume();
  const real_t err = (sigma - m.stress).cwiseAbs().maxCoeff() / m.stress.cwiseAbs().maxCoeff();
  std::printf("[snapshot] mu_r = %.2f: %zu records (%lld measured), %lld sliding (%lld), %lld "
              "rolling (%lld), p = %.3e Pa, max |sigma_rec - sigma| / max |sigma| = %.2e\n",
              mu_r, recs.size(), (long long)m.contacts, (long long)sliding,
              (long long)m.sliding, (long long)rolling, (long long)m.rolling, m.p, err);
  EXPECT_EQ(std::int64_t(recs.size()), m.contacts);
  EXPECT_EQ(sliding, m.sliding);
  EXPECT_EQ(rolling, m.rolling);
  EXPECT_LT(err, 1e-12);
  // The scene exercised what it claims to.
  EXPECT_GT(m.contacts, 500);
  EXPECT_GT(sliding, 5);
  if (mu_r > 0) {
    EXPECT_GT(rolling, 5);
    EXPECT_LT(rolling, m.contacts);
  }
}

TEST(ContactSnapshot, RecordsReproduceStressAndCountsWithoutRolling) { check(0.0); }
TEST(ContactSnapshot, RecordsReproduceStressAndCountsWithRolling) { check(0.05); }

}  // namespace
}  // namespace fabrica
