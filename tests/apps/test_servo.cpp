// The servo (apps/servo.hpp) over a range of stiffnesses and sizes, driven through TriaxialRun:
// consolidation to the target within 0.5 % on every axis and at rest (unbalanced-force ratio
// below [triaxial] unbalanced_tolerance), then the lateral stresses held within 1 % of the
// target over every row of a short shear (eps_1 = 0.01, a row every 100 steps). Specimens of
// the study's gradation (10-60 mm), loose (consolidated with mu_s = 1) and dense (mu_s = 0),
// E = 1e7 and 1e10 Pa, k_n = 1e5, 1e8 and 1e9 N/m, 100 to 1000 spheres; and the case of issue 13:
// a 108-sphere FCC lattice at k_n = 1e8 N/m, where the old servo's default fixed gains made p
// alternate between 31 and 149 kPa and the run end as a "numerical blow-up": the stiffness
// servo consolidates it, and the same fixed gains now stop with what they saw.
#include "apps/servo.hpp"
#include "apps/triaxial.hpp"
#include "tests/apps/fcc_lattice.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"
#include "parallel/mpi_context.hpp"

#include <fmt/core.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

namespace fabrica {
namespace {

// [contact] stiffness line, e.g. "youngs_modulus = 1e7" or "normal_stiffness = 1e9".
std::string scene_text(int count, const std::string& stiffness, real_t mu_cons, const std::string& extra = "",
                       real_t d_max = 0.060, real_t fraction = 0.30, long max_steps = 600000) {
  return fmt::format(R"(
[particles]
source = "generate"
count = {}
fractal_dimension = 1.9
d_min = 0.010
d_max = {}
seed = 7
solid_fraction = {}
aspect = [2.0, 1.0, 1.0]
density = 2650.0

[contact]
{}
stiffness_ratio = 1.0
friction = 0.3

[run]
time_step_fraction = 0.25
skin = 0.001
output_every = 100

[triaxial]
confining_pressure = 200e3
consolidation_friction = {}
max_strain_rate = 2.0
axial_strain_rate = 0.5
axial_strain = 0.01
max_stage_steps = {}
{}
)",
                     count, d_max, fraction, stiffness, mu_cons, max_steps, extra);
}

struct Outcome {
  StageResult cons, eq, sh;
  double seconds = 0;
};

Outcome run(const std::string& text, const std::string& label) {
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = parse_scene(text, label);
  Setup s = make_setup(scene);
  Simulation sim(std::move(s.particles), s.cell, s.params);
  TriaxialRun r(scene, sim, 0.02, 2650, nullptr, nullptr);
  Outcome o;
  o.cons = r.consolidate();
  o.eq = r.equilibrate(0.0);
  o.sh = r.shear(0.0);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const TriaxialSpec& tx = scene.triaxial;
  const MacroState& m = o.cons.state;
  real_t worst = 0;
  for (int k = 0; k < 3; ++k)
    worst = std::max(worst, std::abs(m.stress(k, k) - tx.confining_pressure) / tx.confining_pressure);
  std::printf(
      "[servo] %s: consolidated in %lld steps (error %.3f %%, unbalanced %.1e, e %.3f), "
      "equilibrated in %lld, sheared in %lld: lateral error <= %.3f %%, energy error "
      "<= %.2e (%.1f s)\n",
      label.c_str(), (long long)o.cons.steps, 100 * worst, m.unbalanced, m.void_ratio, (long long)o.eq.steps,
      (long long)o.sh.steps, 100 * o.sh.max_lateral_error, std::max(o.cons.max_energy_error, o.sh.max_energy_error),
      o.seconds);
  EXPECT_LT(worst, 0.005) << label;
  EXPECT_LT(m.unbalanced, tx.unbalanced_tolerance) << label;
  EXPECT_LT(o.sh.max_lateral_error, 0.01) << label;
  EXPECT_GE(o.sh.strain[0], tx.axial_strain) << label;
  return o;
}

// 500 and 400 spheres: with 200 of the 10-60 mm gradation the consolidated cell is 99 mm wide,
// below 2 (2 Rmax + skin) = 121 mm, where two spheres can touch through two periodic images
// (the run stops then: CellTooSmallForTheGradationStops). The stiff dense specimen takes
// about 530,000 steps to come to rest (E = 1e10 makes the step 30 times shorter than at 1e7).
TEST(Servo, SoftLoose) { run(scene_text(500, "youngs_modulus = 1e7", 1.0), "E 1e7, 500 loose"); }
TEST(Servo, StiffDense) {
  run(scene_text(400, "youngs_modulus = 1e10", 0.1, "", 0.060, 0.30, 1500000), "E 1e10, 400 dense");
}

// 200 spheres of 10-60 mm consolidated: the cell shrinks below 2 (2 Rmax + skin) on axis 2 and
// the stage stops there with the guard's message. (These were the servo tests' specimens once:
// a sphere then ran into another through its second periodic image unseen, and the energy
// account showed energy never put in - the guard's 1.5 x input - in some roundings.)
TEST(Servo, CellTooSmallForTheGradationStops) {
  const Scene scene = parse_scene(scene_text(200, "youngs_modulus = 1e7", 1.0), "small.toml");
  fabrica::Setup s = make_setup(scene);
  Simulation sim(std::move(s.particles), s.cell, s.params);
  TriaxialRun r(scene, sim, 0.02, 2650, nullptr, nullptr);
  try {
    r.consolidate();
    FAIL() << "the consolidation went through";
  } catch (const BlowUpError& e) {
    const std::string m = e.what();
    std::printf("[servo] %s\n", m.c_str());
    for (const char* part :
         {"cannot go on at step", "the periodic cell has shrunk to L", "2 (2 Rmax + skin) = 0.121", "larger specimen"})
      EXPECT_NE(m.find(part), std::string::npos) << part << " missing in: " << m;
    const Vec3& L = sim.cell().lengths();
    EXPECT_LE(L.minCoeff(), 2 * (0.06 + 0.001)) << "stopped with every axis above the limit";
  }
}
TEST(Servo, SoftSpringsDense) { run(scene_text(100, "normal_stiffness = 1e5", 0.1, "", 0.02), "k_n 1e5, 100 dense"); }
TEST(Servo, SoftSpringsLoose) { run(scene_text(100, "normal_stiffness = 1e5", 1.0, "", 0.02), "k_n 1e5, 100 loose"); }
TEST(Servo, StiffSpringsDense) {
  run(scene_text(200, "normal_stiffness = 1e8", 0.1, "", 0.04, 0.45), "k_n 1e8, 200 dense");
}
// k_n = 1e9 N/m: the time step falls as sqrt(m / k_n) while the rearrangements of a packing
// take a time set by the masses and the pressure, not the stiffness, so the steps to rest grow
// as sqrt(k_n): 721,098 here (600,000 were not enough). The loose 100 spheres of 10-20 mm come
// to rest too, after 2,935,698 steps, but then hold the lateral stress in shear only within
// 2-3 % (docs/triaxial.md, "The servo": open).
TEST(Servo, VeryStiffSpringsDense) {
  run(scene_text(200, "normal_stiffness = 1e9", 0.1, "", 0.04, 0.45, 4000000), "k_n 1e9, 200 dense");
}
TEST(Servo, ThousandSpheres) { run(scene_text(1000, "youngs_modulus = 1e8", 1.0), "E 1e8, 1000 loose"); }

// The issue's lattice: 108 spheres (3 x 3 x 3 FCC cells), R = 10 mm, k_n = k_s = 1e8 N/m, nearest
// neighbours 1e-9 m closer than touching (p = 0.7 kPa), target 100 kPa.
const char* kFccScene = R"(
[run]
output_every = 100
[triaxial]
confining_pressure = 100e3
max_stage_steps = 200000
)";

// specimen_response against its closed form on the lattice: with k_s = k_n the cross terms
// vanish and M_kk = (1/V) sum_c k_n d_k^2 = 4 k_n / a (every sphere has 12 neighbours at
// (+-a/2, +-a/2, 0) and permutations: sum of d_k^2 over a sphere's 6 contacts = a^2, V = N a^3 / 4);
// C has the same form with the dashpot coefficient c = eta m / 2 in place of k_n (zero without
// dashpots).
TEST(Servo, StiffnessOfAnFccLattice) {
  for (const real_t eta : {0.0, 1.9e5}) {
    Fcc f;
    f.damping_rate = eta;
    Simulation sim = f.make();
    ASSERT_EQ(sim.macro().contacts, 108 * 6);
    const SpecimenResponse R = specimen_response(sim);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(R.stiffness(k, k), f.stiffness(), 1e-9 * f.stiffness()) << k;
      if (eta == 0) EXPECT_EQ(R.viscosity(k, k), 0.0) << k;
      else EXPECT_NEAR(R.viscosity(k, k), f.viscosity(), 1e-9 * f.viscosity()) << k;
      for (int l = 0; l < 3; ++l)
        if (l != k) {
          EXPECT_NEAR(R.stiffness(k, l), 0.0, 1e-9 * f.stiffness()) << k << l;
          EXPECT_NEAR(R.viscosity(k, l), 0.0, 1e-9 * f.viscosity()) << k << l;
        }
    }
  }
}

// The stiffness servo consolidates the issue's lattice to 0.5 % and at rest.
TEST(Servo, ConsolidatesTheFccLattice) {
  const Fcc f;
  Simulation sim = f.make();
  const Scene scene = parse_scene(kFccScene, "fcc.toml");
  TriaxialRun r(scene, sim, 2 * f.R, 2650, nullptr, nullptr);
  const StageResult c = r.consolidate();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(c.state.stress(k, k), 100e3, 0.005 * 100e3) << k;
  EXPECT_LT(c.state.unbalanced, scene.triaxial.unbalanced_tolerance);
  std::printf("[servo] FCC lattice, k_n = 1e8 N/m: consolidated to p = %.1f Pa in %lld steps\n", c.state.p,
              (long long)c.steps);
}

// Strong dashpots: the lattice's viscosity C = 5 S T (T the servo interval of 2 steps; eta =
// 9.5e4 1/s, beta = 0.35, at a time step of 0.05 sqrt(m / k_n)). A rate held over T moves the
// stress by (S T + C) rate, most of it at once through the dashpots; a gain from the stiffness
// alone (C left out) over-corrected every update, the rate alternated between the caps and the
// stage never came to rest (as the 108,672-sphere benchmark scene did: docs/triaxial.md, "The
// servo"). With C in the gain the lattice consolidates to 0.5 % and at rest.
TEST(Servo, ConsolidatesAStronglyDampedFccLattice) {
  Fcc f;
  f.dt_fraction = 0.05;
  const real_t dt = f.dt_fraction * std::sqrt(f.mass() / f.kn), T = 2 * dt;
  f.damping_rate = 4 * f.kn * dt * 5 / f.mass();  // C = (4 / a) (eta m / 2) = 5 (4 k_n / a) T
  Simulation sim = f.make();
  ASSERT_EQ(sim.params().dt, dt);
  EXPECT_NEAR(f.viscosity(), 5 * f.stiffness() * T, 1e-9 * f.viscosity());
  const Scene scene = parse_scene(kFccScene, "fcc.toml");
  TriaxialRun r(scene, sim, 2 * f.R, 2650, nullptr, nullptr);
  const StageResult c = r.consolidate();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(c.state.stress(k, k), 100e3, 0.005 * 100e3) << k;
  EXPECT_LT(c.state.unbalanced, scene.triaxial.unbalanced_tolerance);
  std::printf(
      "[servo] FCC lattice, k_n = 1e8 N/m, eta = %.4g 1/s (C = %.2f S T): consolidated to "
      "p = %.1f Pa in %lld steps\n",
      f.damping_rate, f.viscosity() / (f.stiffness() * T), c.state.p, (long long)c.steps);
}

// The old default fixed gains (4 /s, 2000 /s^2) on the same lattice: the loop gain is about 3,
// the servo over-corrects for ever; the stage stops with what it saw, not as a blow-up.
TEST(Servo, FixedGainsThatCannotConvergeStopWithWhatTheySaw) {
  const Fcc f;
  Simulation sim = f.make();
  const Scene scene =
      parse_scene(std::string(kFccScene) + "servo_gain = 4.0\nservo_integral_gain = 2000.0\n", "fcc.toml");
  TriaxialRun r(scene, sim, 2 * f.R, 2650, nullptr, nullptr);
  try {
    r.consolidate();
    FAIL() << "the consolidation converged";
  } catch (const std::exception& e) {
    const std::string m = e.what();
    std::printf("[servo] %s\n", m.c_str());
    for (const char* part : {"fcc.toml", "consolidation stage stopped", "cannot converge", "loop gain",
                             "p = ", "target 100000 Pa", "stiffness"})
      EXPECT_NE(m.find(part), std::string::npos) << part << " missing in: " << m;
    EXPECT_EQ(m.find("blow-up"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace fabrica
