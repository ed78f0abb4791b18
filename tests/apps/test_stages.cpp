// The loading stages (apps/stage_run.hpp, apps/stage_control.hpp, apps/stage_end.hpp) on the
// affine elastic FCC lattice (tests/apps/fcc_lattice.hpp), against closed forms: the lattice's
// stiffness is M = c I, c = 4 k_n / a (k_s = k_n: a strain of one axis changes only that axis'
// stress, by c times the strain). Friction is raised to 1e3 by the stages (no contact slides),
// so the response is elastic. Each stage is given as a [[stage]] table and read by parse_scene.
#include "apps/plain_run.hpp"
#include "apps/stage_end.hpp"
#include "apps/stage_run.hpp"
#include "apps/triaxial.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"
#include "tests/apps/fcc_lattice.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

namespace fabrica {
namespace {

struct Row {
  std::int64_t step;
  Vec3 eps;
  Mat3 s = Mat3::Zero();
  real_t p, q;
};

std::vector<Row> parse_rows(const std::string& csv, const std::string& stage) {
  std::vector<Row> rows;
  std::istringstream in(csv);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    std::string x;
    while (std::getline(ls, x, ',')) f.push_back(x);
    if (f.size() < 16 || f[0] != stage) continue;
    Row r;
    r.step = std::stoll(f[1]);
    r.eps = Vec3(std::stod(f[3]), std::stod(f[4]), std::stod(f[5]));
    for (int k = 0; k < 3; ++k) r.s(k, k) = std::stod(f[7 + k]);
    r.p = std::stod(f[13]);
    r.q = std::stod(f[14]);
    rows.push_back(r);
  }
  return rows;
}

// The lattice through the scene's stages; the second stage's rows, start and end.
struct LatticeRun {
  Fcc f;
  Simulation sim = f.make();
  Scene scene;
  std::ostringstream series;
  StageResult first, second;
  MacroState start;         // at the start of the second stage
  Vec3 l_start, eps_start;  // its cell lengths, and its series strains (from the list's start)
  std::int64_t step_start = 0;
  std::vector<Row> rows;
  explicit LatticeRun(const std::string& stage) : scene(parse_scene(lattice_stage_scene(stage), "lattice.toml")) {
    const Vec3 l_init = sim.cell().lengths();
    StageRun run(scene, sim, 2 * Fcc::R, 2650, &series, nullptr);
    first = run.run(scene.stages[0], 0);
    start = sim.macro();
    l_start = sim.cell().lengths();
    for (int k = 0; k < 3; ++k) eps_start[k] = std::log(l_init[k] / l_start[k]);
    step_start = sim.step_count();
    second = run.run(scene.stages[1], 1);
    rows = parse_rows(series.str(), scene.stages[1].name);
  }
  Vec3 eps() const {  // of the second stage, from its start
    Vec3 e;
    for (int k = 0; k < 3; ++k) e[k] = std::log(l_start[k] / sim.cell().lengths()[k]);
    return e;
  }
};

TEST(Stages, IsotropicConsolidationComesToRest) {
  LatticeRun r("type = \"hold\"\nend = { steps = 10 }");
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.first.state.stress(k, k), 100e3, 0.005 * 100e3) << k;
  EXPECT_LT(r.first.state.unbalanced, 1e-4);
}

// Axis 1 at a strain rate, axes 2 and 3 held (rate 0): Delta s11 = c eps1, Delta s22 = Delta s33
// = 0 to first order (the second-order terms are of relative size eps ~ 1e-5): within 0.2 %.
TEST(Stages, StrainControlGivesTheLatticeStiffness) {
  LatticeRun r(R"(type = "mixed"
control.axis_1 = { strain_rate = -0.01 }
control.axis_2 = { strain_rate = 0.0 }
control.axis_3 = { strain_rate = 0.0 }
end = { steps = 1000 })");
  const Vec3 e = r.eps();
  ASSERT_GT(e[0], 9e-6);
  EXPECT_EQ(e[1], 0.0);
  const real_t ds1 = r.second.state.stress(0, 0) - r.start.stress(0, 0);
  const real_t ds2 = r.second.state.stress(1, 1) - r.start.stress(1, 1);
  const real_t c = r.f.stiffness();
  std::printf("[stages] eps1 %.6e: Delta s11 %.6e Pa, c eps1 %.6e Pa (%.2e relative), Delta s22 %.3e Pa\n", e[0], ds1,
              c * e[0], ds1 / (c * e[0]) - 1, ds2);
  EXPECT_NEAR(ds1, c * e[0], 2e-3 * c * e[0]);
  EXPECT_NEAR(ds2, 0.0, 2e-3 * c * e[0]);
}

// Conventional extension: axis 1 lengthens (eps1 < 0), the lateral stresses held at p by the
// servo; with M diagonal, Delta s11 = c eps1 < 0 (within 2 %: the servo's lateral error).
TEST(Stages, ExtensionGoesTheRightWay) {
  LatticeRun r(R"(type = "triaxial_extension"
pressure = 100e3
axial_strain_rate = 0.005
end = { strain = -4e-6 })");
  const Vec3 e = r.eps();
  EXPECT_LE(e[0], -4e-6);
  const real_t ds1 = r.second.state.stress(0, 0) - r.start.stress(0, 0);
  EXPECT_LT(ds1, 0);
  EXPECT_NEAR(ds1, r.f.stiffness() * e[0], 0.02 * r.f.stiffness() * std::abs(e[0]));
  for (int k = 1; k < 3; ++k) EXPECT_NEAR(r.second.state.stress(k, k), 100e3, 0.01 * 100e3) << k;
  EXPECT_LT(r.second.state.stress(0, 0), r.second.state.stress(1, 1));
}

// Constant mean stress: p within 1 % of 100 kPa at every row while q grows.
TEST(Stages, ConstantPKeepsP) {
  LatticeRun r(R"(type = "constant_p"
pressure = 100e3
axial_strain_rate = 0.005
end = { strain = 5e-6 })");
  ASSERT_GT(r.rows.size(), 10u);
  real_t worst = 0;
  for (const Row& row : r.rows) worst = std::max(worst, std::abs(row.p - 100e3) / 100e3);
  std::printf("[stages] constant p: %zu rows, |p - 100 kPa| <= %.3f %%, end q/p %.4f\n", r.rows.size(), 100 * worst,
              r.second.state.q / r.second.state.p);
  EXPECT_LT(worst, 0.01);
  EXPECT_GT(r.second.state.q / r.second.state.p, 0.5);
}

// Constant volume: the volume to rounding (1e-12) at every step of the stage's end; with M = c I
// and the strain (-e, e/2, e/2) in the cell's sign, Delta p = 0 and Delta q = 1.5 c eps1
// (undrained response of the elastic lattice), within 1 %.
TEST(Stages, ConstantVolumeKeepsTheVolume) {
  LatticeRun r(R"(type = "constant_volume"
axial_strain_rate = 0.005
end = { strain = 5e-6 })");
  const real_t v0 = r.l_start.prod(), v = r.sim.cell().lengths().prod();
  std::printf("[stages] constant volume: V / V0 - 1 = %.3e, Delta p %.3e Pa, Delta q %.6e Pa (1.5 c eps1 %.6e)\n",
              v / v0 - 1, r.second.state.p - r.start.p, r.second.state.q - r.start.q,
              1.5 * r.f.stiffness() * r.eps()[0]);
  EXPECT_NEAR(v / v0, 1.0, 1e-12);
  const real_t dq = 1.5 * r.f.stiffness() * r.eps()[0];
  EXPECT_NEAR(r.second.state.q - r.start.q, dq, 0.01 * dq);
  EXPECT_NEAR(r.second.state.p - r.start.p, 0.0, 0.01 * dq);
}

// True triaxial at b = 0.3: s33 held at p, s22 = s33 + b (s11 - s33) within 0.02 in b.
TEST(Stages, TrueTriaxialHoldsB) {
  LatticeRun r(R"(type = "true_triaxial"
pressure = 100e3
b = 0.3
axial_strain_rate = 0.005
end = { strain = 6e-6 })");
  const Mat3& s = r.second.state.stress;
  const real_t b = (s(1, 1) - s(2, 2)) / (s(0, 0) - s(2, 2));
  std::printf("[stages] true triaxial: s11 %.4e, s22 %.4e, s33 %.4e Pa, b = %.4f\n", s(0, 0), s(1, 1), s(2, 2), b);
  EXPECT_NEAR(b, 0.3, 0.02);
  EXPECT_NEAR(s(2, 2), 100e3, 0.01 * 100e3);
  EXPECT_GT(s(0, 0) - s(2, 2), 50e3);
}

// Cyclic strain, amplitude 3e-6, 2 cycles at 0.005 1/s: eps1 reaches +-amplitude (to one servo
// interval's strain, rate x 2 dt, and the 10 steps between rows) and no further; the stage takes
// 4 N amplitude / (rate dt) steps (to 1 %); it ends back at eps1 = 0 (to one interval).
TEST(Stages, CyclicStrainCompletesItsCycles) {
  LatticeRun r(R"(type = "cyclic_strain"
pressure = 100e3
axial_strain_rate = 0.005
amplitude = 3e-6
cycles = 2)");
  const real_t step = 0.005 * r.sim.params().dt, A = 3e-6;
  real_t hi = -1, lo = 1;
  int reversals = 0;
  real_t prev = 0, dir = 1;
  for (const Row& row : r.rows) {
    const real_t e = row.eps[0] - r.eps_start[0];  // the stage's strain (log strains add)
    hi = std::max(hi, e), lo = std::min(lo, e);
    if ((e - prev) * dir < 0) dir = -dir, ++reversals;
    prev = e;
  }
  const Vec3 e = r.eps();
  const double expected = 4 * 2 * A / step;
  std::printf(
      "[stages] cyclic strain: %lld steps (4 N A / (rate dt) = %.1f), eps1 in [%.4e, %.4e], "
      "%d reversals in the rows, end eps1 %.3e\n",
      (long long)r.second.steps, expected, lo, hi, reversals, e[0]);
  EXPECT_EQ(reversals, 4);
  EXPECT_NEAR(double(r.second.steps), expected, 0.01 * expected);
  EXPECT_LE(hi, A + 2.02 * step);
  EXPECT_GE(hi, A - 10.1 * step);
  EXPECT_GE(lo, -A - 2.02 * step);
  EXPECT_LE(lo, -A + 10.1 * step);
  EXPECT_GE(e[0], 0.0);
  EXPECT_LT(e[0], 2.02 * step);
}

// Cyclic stress, amplitude 20 kPa of q_s = s11 - (s22 + s33) / 2, one cycle: q_s reaches +-20 kPa
// (to one servo interval's change, c x 2 rate dt, and the rows' 10 steps) and ends back at 0.
TEST(Stages, CyclicStressCompletesItsCycle) {
  LatticeRun r(R"(type = "cyclic_stress"
pressure = 100e3
axial_strain_rate = 0.005
amplitude = 20e3
cycles = 1)");
  const real_t dq = r.f.stiffness() * 0.005 * r.sim.params().dt;  // q_s per step
  real_t hi = -1e9, lo = 1e9;
  for (const Row& row : r.rows) {
    const real_t qs = row.s(0, 0) - 0.5 * (row.s(1, 1) + row.s(2, 2));
    hi = std::max(hi, qs), lo = std::min(lo, qs);
  }
  const Mat3& s = r.second.state.stress;
  const real_t qs_end = s(0, 0) - 0.5 * (s(1, 1) + s(2, 2));
  std::printf("[stages] cyclic stress: q_s in [%.4e, %.4e] Pa (amplitude 2e4, %.1f Pa per step), end %.3e Pa\n", lo, hi,
              dq, qs_end);
  EXPECT_LE(hi, 20e3 + 3 * dq + 200);
  EXPECT_GE(hi, 20e3 - 11 * dq - 200);
  EXPECT_GE(lo, -20e3 - 3 * dq - 200);
  EXPECT_LE(lo, -20e3 + 11 * dq + 200);
  EXPECT_GE(qs_end, 0.0);
  EXPECT_LT(qs_end, 3 * dq + 200);
}

// End conditions: 'steps' stops at that step exactly (the driver measures there, between two
// servo steps); 'strain' at the first servo step past it; 'q_p' at the first past it.
TEST(Stages, EndAfterSteps) {
  LatticeRun r("type = \"hold\"\nend = { steps = 137 }");
  EXPECT_EQ(r.second.steps, 137);
  EXPECT_EQ(r.sim.step_count() - r.step_start, 137);
}

TEST(Stages, EndAtStrain) {
  LatticeRun r(R"(type = "triaxial_compression"
pressure = 100e3
axial_strain_rate = 0.005
end = { strain = 3e-6 })");
  const real_t step = 0.005 * r.sim.params().dt;
  EXPECT_GE(r.eps()[0], 3e-6);
  EXPECT_LT(r.eps()[0], 3e-6 + 2.02 * step);
}

TEST(Stages, EndAtStressRatio) {
  LatticeRun r(R"(type = "triaxial_compression"
pressure = 100e3
axial_strain_rate = 0.005
end = { q_p = 0.2 })");
  const real_t qp = r.second.state.q / r.second.state.p;
  // q/p per servo interval: about c x 2 rate dt / p
  const real_t dqp = r.f.stiffness() * 2 * 0.005 * r.sim.params().dt / 100e3;
  std::printf("[stages] q/p at the end %.5f (target 0.2, %.5f per interval)\n", qp, dqp);
  EXPECT_GE(qp, 0.2);
  EXPECT_LT(qp, 0.2 + 1.5 * dqp);
}

// The plain run's compression (apps/plain_run.hpp): the three axes at the [compress] strain rate
// until p reaches the target, seen at a measurement (here every servo interval: p rises by
// c |rate| dt a step), in the compression's law (its friction, no rolling resistance).
TEST(Stages, CompressionEndsAtItsPressure) {
  const Scene scene = parse_scene(R"([contact]
rolling_friction = 0.1

[compress]
target_pressure = 50e3
strain_rate = -0.01
friction = 0.2
)",
                                  "lattice.toml");
  Fcc f;
  Simulation sim = f.make();
  const real_t p0 = sim.macro().p;
  StageRun run(scene, sim, 2 * Fcc::R, 2650, nullptr, nullptr);
  const StageSpec st = compress_stage(scene);
  const StageResult r = run.run(st, 0);
  const real_t dp = f.stiffness() * 0.01 * sim.params().dt;  // a step's rise of p
  std::printf("[stages] compression from p %.1f Pa: %lld steps to p %.1f Pa (target 50000, %.1f Pa a step)\n", p0,
              static_cast<long long>(r.steps), r.state.p, dp);
  EXPECT_GE(r.state.p, 50e3);
  EXPECT_LT(r.state.p, 50e3 + 1.5 * st.servo.interval * dp);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(sim.cell().strain_rate()[k], -0.01) << k;
  EXPECT_EQ(sim.params().law.friction, 0.2);
  EXPECT_EQ(sim.params().law.rolling_friction, 0.0);
  // The end condition alone: p reaching the value from below.
  MacroState m;
  StageSpec end;
  end.end.pressure = 100.0;
  m.p = 99.9;
  EXPECT_FALSE(stage_done(end, EndProbe{1, &m}));
  m.p = 100.0;
  EXPECT_TRUE(stage_done(end, EndProbe{1, &m}));
}

// A contact parameter set by a stage is the simulation's from then on.
TEST(Stages, StageSetsContactParameters) {
  LatticeRun r(
      "type = \"hold\"\nfriction = 0.25\nrolling_friction = 0.05\ntwisting_friction = 0.02\n"
      "local_damping = 0.3\ndamping_ratio_normal = 0.2\ndamping_ratio_shear = 0.1\nend = { steps = 4 }");
  EXPECT_EQ(r.sim.params().law.friction, 0.25);
  EXPECT_EQ(r.sim.params().law.rolling_friction, 0.05);
  EXPECT_EQ(r.sim.params().law.twisting_friction, 0.02);
  EXPECT_TRUE(r.sim.pairs().twisting);  // its springs kept from then on
  EXPECT_EQ(r.sim.params().local_damping, 0.3);
  EXPECT_EQ(r.sim.params().law.damping_ratio_n, 0.2);
  EXPECT_EQ(r.sim.params().law.damping_ratio_s, 0.1);
}

// With several materials: the triaxial consolidation sets every pair's friction; the switch after
// it puts back each pair's own (the mixing rule's, a [[material_pair]]'s) with the case's mu_r
// for every pair; a [[stage]]'s friction is every pair's.
TEST(Stages, TriaxialSwitchPutsBackEachMaterialsLaw) {
  const Scene scene = parse_scene(R"([contact]
friction = 0.3
[triaxial]
consolidation_friction = 1000.0
[[material]]
name = "a"
fraction = 0.5
friction = 0.2
[[material]]
name = "b"
fraction = 0.25
friction = 0.6
[[material]]
name = "c"
fraction = 0.25
[[material_pair]]
materials = ["b", "c"]
friction = 0.45
)",
                                  "materials.toml");
  Fcc f;
  Simulation sim = f.make();
  sim.set_laws(sim.params().law, scene_materials(scene));
  std::ostringstream series;
  StageRun run(scene, sim, 2 * Fcc::R, 2650, &series, nullptr);
  auto one_step = [](StageSpec st) {
    st.end = StageEnd{};
    st.end.steps = 1;
    return st;
  };
  run.run(one_step(consolidation_stage(scene)), 0);
  const Materials& m = sim.params().materials;
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b) EXPECT_EQ(m.pair(a, b).friction, 1000.0);
  run.run(one_step(equilibration_stage(scene, 0.1)), 1);
  const real_t own[3][3] = {{0.2, 0.2, 0.2}, {0.2, 0.6, 0.45}, {0.2, 0.45, 0.3}};
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b) {
      EXPECT_EQ(m.pair(a, b).friction, own[a][b]) << a << ", " << b;
      EXPECT_EQ(m.pair(a, b).rolling_friction, 0.1);
    }
  EXPECT_EQ(sim.params().law.friction, 0.3);
  EXPECT_TRUE(sim.params().rolling());
}

// A stage's damping ratio replaces that direction's dashpot, rate form included; later stages
// keep it until one changes it.
TEST(Stages, StageLawReplacesTheDashpot) {
  ContactLawParams law;
  law.damping_rate_n = 50;
  law.damping_rate_s = 20;
  StageSpec st;
  st.law.set(&ContactLawParams::damping_ratio_n, 0.3);
  const ContactLawParams a = stage_law(law, st);
  EXPECT_EQ(a.damping_ratio_n, 0.3);
  EXPECT_EQ(a.damping_rate_n, 0.0);
  EXPECT_EQ(a.damping_rate_s, 20.0);  // untouched
  StageSpec later;
  const ContactLawParams bound = most_damped_law(law, {st, later});
  EXPECT_EQ(bound.damping_ratio_n, 0.3);
  EXPECT_EQ(bound.damping_rate_n, 50.0);  // the scene's own law is among those bounded
  EXPECT_EQ(bound.damping_rate_s, 20.0);
}

// Damping shortens the critical time step by sqrt(1 + beta^2) - beta (the damped oscillator):
// the set-up of a stage list takes the strongest dashpots any stage sets, so a stage with
// beta = 0.5 in both directions makes the estimate 0.618... of the undamped one, and the time
// step (the same fraction of it) is stable in that stage too.
TEST(Stages, StageDampingSizesTheTimeStep) {
  const std::string base =
      "[particles]\ncount = 60\nd_min = 0.02\nd_max = 0.03\nseed = 3\nsolid_fraction = 0.3\n"
      "[contact]\nyoungs_modulus = 100e6\nfriction = 0.3\n";
  const std::string hold = "[[stage]]\ntype = \"hold\"\nend = { steps = 1 }\n";
  const std::string damped_hold =
      "[[stage]]\ntype = \"hold\"\ndamping_ratio_normal = 0.5\ndamping_ratio_shear = 0.5\nend = { steps = 1 }\n";
  const fabrica::Setup a = make_setup(triaxial_setup_scene(parse_scene(base + hold + hold, "a.toml")));
  const fabrica::Setup b = make_setup(triaxial_setup_scene(parse_scene(base + hold + damped_hold + hold, "b.toml")));
  std::printf("[stages] critical time step %.6e s undamped, %.6e s with a stage at beta = 0.5\n", a.critical_dt,
              b.critical_dt);
  EXPECT_NEAR(b.critical_dt / a.critical_dt, std::sqrt(1.25) - 0.5, 1e-12);
  EXPECT_NEAR(b.params.dt / a.params.dt, std::sqrt(1.25) - 0.5, 1e-12);
}

}  // namespace
}  // namespace fabrica
