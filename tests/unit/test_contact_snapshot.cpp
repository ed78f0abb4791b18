// Contact records (core/contact_snapshot.hpp) against the engine's own measures on a sheared
// polydisperse packing with sliding and rolling contacts: the records' Love-Weber stress
// (1/V) sum f (x) b equals the measured stress (relative 1e-12, rounding only; no dashpots, so
// the records' forces are the whole contact forces), and the numbers of contacts, sliding and
// rolling contacts are those the force loop counted (exactly); the two share one
// classification, checked by hand on one contact at mu_s = 0 and mu_r = 0.
#include "core/contact_snapshot.hpp"
#include "core/generate.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <cstdio>

namespace fabrica {
namespace {

void check(real_t mu_r, real_t mu_s = 0.3) {
  Random rng(5);
  std::vector<real_t> d = fractal_diameters(400, 1.9, 0.01, 0.05, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  const real_t L = std::cbrt(vs / 0.35);
  const PeriodicCell big(Vec3::Constant(L));
  Particles p = random_packing(d, test::kRho, big, rng);
  SimulationParams sp;
  sp.law.youngs_modulus = 50e6;
  sp.law.friction = mu_s;
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
  std::printf(
      "[snapshot] mu_r = %.2f: %zu records (%lld measured), %lld sliding (%lld), %lld "
      "rolling (%lld), p = %.3e Pa, max |sigma_rec - sigma| / max |sigma| = %.2e\n",
      mu_r, recs.size(), (long long)m.contacts, (long long)sliding, (long long)m.sliding, (long long)rolling,
      (long long)m.rolling, m.p, err);
  EXPECT_EQ(std::int64_t(recs.size()), m.contacts);
  EXPECT_EQ(sliding, m.sliding);
  EXPECT_EQ(rolling, m.rolling);
  EXPECT_LT(err, 1e-12);
  // The scene exercised what it claims to.
  EXPECT_GT(m.contacts, mu_s > 0 ? 500 : 300);  // frictionless: 325, denser but fewer contacts
  EXPECT_GT(sliding, 5);
  if (mu_s == 0) {
    EXPECT_EQ(sliding, m.contacts);  // frictionless: every contact slides
  }
  if (mu_r > 0) {
    EXPECT_GT(rolling, 5);
    EXPECT_LT(rolling, m.contacts);
  }
}

// One classification of sliding and rolling (at_limit, core/contact_law.hpp) for the force
// loop's counts and the records, checked by hand on one contact: R1 = 1 cm, R2 = 2 cm, overlap
// u_n = 0.1 mm, E = 50 MPa, both spheres at rest. By hand k_n = pi r^2 E / (R1 + R2) =
// pi 1e-4 5e7 / 0.03 = 523,598.776 N/m, f_n = k_n u_n = 52.3598776 N, f_t = 0 and m_r = 0.
// At mu_s = 0 the Coulomb limit is 0 and |f_t| = 0 is at it: the contact slides (before the
// shared test, the force loop counted it as sticking because its trial force did not exceed
// 0, while the records said sliding). At mu_r = 0 it rolls. At mu_s = 0.3, mu_r = 0.1 it
// neither slides nor rolls (0 < 0.3 f_n, 0 < 0.1 Rbar f_n). After one step with a tangential
// velocity of 0.1 m/s at mu_s = 0 it still slides, with f_t = 0 exactly.
struct OneContact {
  std::int64_t contacts, sliding, rolling;
  ContactRecord rec;
};
OneContact one_contact(real_t mu_s, real_t mu_r, const Vec3& v2, bool step) {
  const real_t R1 = 0.01, R2 = 0.02, un = 1e-4;
  Particles p = test::make_particles({{0, R1, test::kRho, Vec3(0.05, 0.1, 0.1), Vec3::Zero(), Vec3::Zero()},
                                      {1, R2, test::kRho, Vec3(0.05 + R1 + R2 - un, 0.1, 0.1), v2, Vec3::Zero()}});
  SimulationParams sp;
  sp.law.youngs_modulus = 50e6;
  sp.law.friction = mu_s;
  sp.law.rolling_friction = mu_r;
  sp.skin = 0.002;
  sp.dt = 1e-7;
  Simulation sim(std::move(p), PeriodicCell(Vec3::Constant(0.2)), sp);
  if (step) sim.step(true);
  const auto recs = contact_records(sim.particles(), sim.cell(), sim.params().law, sim.pairs());
  EXPECT_EQ(recs.size(), 1u);
  return {sim.macro().contacts, sim.macro().sliding, sim.macro().rolling, recs.empty() ? ContactRecord{} : recs[0]};
}

TEST(ContactClassification, ByHandAtZeroAndNonzeroFriction) {
  const real_t fn_hand = 52.3598776;  // N, above
  {
    const OneContact c = one_contact(0.0, 0.0, Vec3::Zero(), false);
    EXPECT_NEAR(c.rec.fn / fn_hand, 1.0, 1e-8);  // the overlap as a difference of positions
    EXPECT_EQ(c.rec.ft, Vec3::Zero());
    EXPECT_EQ(c.contacts, 1);
    EXPECT_EQ(c.sliding, 1);
    EXPECT_EQ(c.rolling, 1);
    EXPECT_TRUE(c.rec.sliding);
    EXPECT_TRUE(c.rec.rolling);
  }
  {
    const OneContact c = one_contact(0.0, 0.0, Vec3(0, 0.1, 0), true);
    EXPECT_EQ(c.rec.ft, Vec3::Zero());
    EXPECT_EQ(c.sliding, 1);
    EXPECT_TRUE(c.rec.sliding);
  }
  {
    const OneContact c = one_contact(0.3, 0.1, Vec3::Zero(), false);
    EXPECT_NEAR(c.rec.fn / fn_hand, 1.0, 1e-8);
    EXPECT_EQ(c.contacts, 1);
    EXPECT_EQ(c.sliding, 0);
    EXPECT_EQ(c.rolling, 0);
    EXPECT_FALSE(c.rec.sliding);
    EXPECT_FALSE(c.rec.rolling);
  }
  // The law itself, away from any simulation: a trial force within 1e-9 of the limit is at it,
  // one 1e-6 below is not, and a zero limit is always reached.
  EXPECT_TRUE(at_limit(0.0, 0.0));
  EXPECT_TRUE(at_limit(std::pow(1 - 0.5e-9, 2), 1.0));
  EXPECT_FALSE(at_limit(std::pow(1 - 1e-6, 2), 1.0));
}

TEST(ContactSnapshot, RecordsReproduceStressAndCountsWithoutRolling) { check(0.0); }
TEST(ContactSnapshot, RecordsReproduceStressAndCountsWithRolling) { check(0.05); }
TEST(ContactSnapshot, RecordsReproduceStressAndCountsFrictionless) { check(0.0, 0.0); }

}  // namespace
}  // namespace fabrica
