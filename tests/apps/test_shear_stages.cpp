// The shear stages (issue 42: control.shear_ij, simple_shear, cyclic_simple_shear,
// principal_rotation; apps/stage_control.hpp) on the affine elastic FCC lattice
// (tests/apps/fcc_lattice.hpp) against closed forms. With linear springs k_n = k_s between
// nearest neighbours its shear modulus is G = (k_n + k_s) / a (a the cube edge), for a
// rotation-free or a simple shear; its cubic symmetry couples a shear of one pair of axes to no
// other component. Stresses are compression positive, so a positive engineering shear strain
// gamma_12 (the cell's kinematic sign) is resisted by s12 = -G gamma_12. Friction is raised to
// 1e3 by the consolidation stage: no contact slides, the response is elastic.
#include "apps/servo.hpp"
#include "apps/stage_run.hpp"
#include "io/serial/scene.hpp"
#include "tests/apps/fcc_lattice.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace fabrica {
namespace {

// The rows of one stage of a series, by column name.
using Rows = std::vector<std::map<std::string, double>>;
Rows parse_rows(const std::string& csv, const std::string& stage) {
  std::istringstream in(csv);
  std::string line;
  std::vector<std::string> names;
  Rows rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    std::string x;
    while (std::getline(ls, x, ',')) f.push_back(x);
    if (names.empty()) {
      names = f;
      continue;
    }
    if (f.size() != names.size() || f[0] != stage) continue;
    std::map<std::string, double> r;
    for (std::size_t k = 1; k < f.size(); ++k) r[names[k]] = std::stod(f[k]);
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
  MacroState start;  // at the start of the second stage
  real_t v_start = 0;
  Rows rows;
  explicit LatticeRun(const std::string& stage) : scene(parse_scene(lattice_stage_scene(stage), "lattice.toml")) {
    write_series_header(series, true);  // the run's shear columns (the driver writes the header)
    StageRun run(scene, sim, 2 * Fcc::R, 2650, &series, nullptr);
    first = run.run(scene.stages[0], 0);
    start = sim.macro();
    v_start = sim.cell().volume();
    second = run.run(scene.stages[1], 1);
    rows = parse_rows(series.str(), scene.stages[1].name);
  }
  real_t G() const { return 2 * Fcc::kn / f.a; }  // (k_n + k_s) / a
};

// The specimen's shear response (add_shear_response) of the lattice is its shear modulus on each
// of the three pairs of axes (rounding only: every contact is alike).
TEST(ShearStages, ShearResponseOfTheLatticeIsItsModulus) {
  Fcc f;
  Simulation sim = f.make();
  sim.step(true);
  const SpecimenResponse R = specimen_response(sim, true);
  const real_t G = 2 * Fcc::kn / f.a;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(R.shear_stiffness[c], G, 1e-9 * G) << c;
    EXPECT_EQ(R.shear_viscosity[c], 0.0) << c;
  }
  const SpecimenResponse normal = specimen_response(sim);  // without 'shear': the 18 numbers only
  EXPECT_EQ(normal.shear_stiffness, Vec3::Zero());
  EXPECT_EQ(normal.stiffness, R.stiffness);
}

// A stress-controlled shear_12 (the normal axes at 100 kPa) comes to rest at its target, and the
// shear strain it took is tau / G: the closed form within 0.5 % (the pre-stress's share of the
// shear stiffness is p / G ~ 1e-5; the rest is the servo's tolerance, 1 Pa of 20 kPa).
TEST(ShearStages, StressControlledShearReachesItsTargetWithTauOverG) {
  LatticeRun r(R"(type = "mixed"
control.axis_1 = { stress = 100e3 }
control.axis_2 = { stress = 100e3 }
control.axis_3 = { stress = 100e3 }
control.shear_12 = { stress = -20e3 }
stress_tolerance = 1e-5
end = { at_rest = true })");
  const Mat3& s = r.second.state.stress;
  const real_t tau = 20e3, ds12 = s(0, 1) - r.start.stress(0, 1);
  const real_t gamma = r.second.gamma[0];
  std::printf("[shear] stress-controlled: s12 %.6e Pa (target -2e4), gamma_12 %.6e, tau / G %.6e (%.2e relative)\n",
              s(0, 1), gamma, tau / r.G(), gamma / (tau / r.G()) - 1);
  EXPECT_NEAR(0.5 * (s(0, 1) + s(1, 0)), -tau, 1e-5 * 100e3 + 1e-9);
  EXPECT_NEAR(gamma, tau / r.G(), 5e-3 * tau / r.G());
  EXPECT_NEAR(gamma, -ds12 / r.G(), 1e-3 * tau / r.G());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(s(k, k), 100e3, 1e-5 * 100e3 + 1e-9) << k;
  EXPECT_NEAR(r.second.gamma[1], 0.0, 1e-3 * gamma);  // no coupling to the other pairs
  EXPECT_NEAR(r.second.gamma[2], 0.0, 1e-3 * gamma);
  ASSERT_FALSE(r.rows.empty());
  EXPECT_NEAR(r.rows.back()["gamma_12"], gamma, 1e-9 * gamma);  // the series' column
}

// A rate-controlled rotation-free shear_12 (the normal axes fixed): Delta s12 = -G gamma_12,
// the series' gamma_12 the rate times the time, the principal axes at 45 degrees from them.
TEST(ShearStages, RateControlledShearGivesTheShearModulus) {
  LatticeRun r(R"(type = "mixed"
control.axis_1 = { strain_rate = 0.0 }
control.axis_2 = { strain_rate = 0.0 }
control.axis_3 = { strain_rate = 0.0 }
control.shear_12 = { strain_rate = 0.01 }
end = { shear_strain = 1e-5 })");
  const real_t gamma = r.second.gamma[0], ds12 = r.second.state.stress(0, 1) - r.start.stress(0, 1);
  std::printf("[shear] rate-controlled: gamma_12 %.6e, Delta s12 %.6e Pa, -G gamma %.6e Pa (%.2e relative)\n", gamma,
              ds12, -r.G() * gamma, ds12 / (-r.G() * gamma) - 1);
  EXPECT_GE(gamma, 1e-5);
  EXPECT_LT(gamma, 1e-5 + 2.02 * 0.01 * r.sim.params().dt);
  EXPECT_NEAR(ds12, -r.G() * gamma, 2e-3 * r.G() * gamma);
  EXPECT_NEAR(r.sim.cell().volume() / r.v_start, 1.0, 1e-12);
  ASSERT_FALSE(r.rows.empty());
  const auto& last = r.rows.back();
  // s12 < 0 with s11 = s22: the major (most compressive) axis is (1, -1, 0) / sqrt 2, at -45.
  EXPECT_NEAR(last.at("theta_12"), -45.0, 0.1);
  EXPECT_NEAR(last.at("sigma_1") - last.at("sigma_3"), 2 * std::abs(last.at("s12")), 1e-3 * std::abs(last.at("s12")));
}

// Constant-volume simple shear (planes normal to axis 1 sliding along axis 2): the volume to
// rounding, gamma_12 reached, the normal strains zero.
TEST(ShearStages, ConstantVolumeSimpleShearKeepsTheVolume) {
  LatticeRun r(R"(type = "simple_shear"
constant_volume = true
shear_strain_rate = 0.01
end = { shear_strain = 1e-5 })");
  const real_t v = r.sim.cell().volume();
  std::printf("[shear] constant-volume simple shear: gamma_12 %.6e, V / V0 - 1 = %.3e, H(1,0) / H(1,1) = %.6e\n",
              r.second.gamma[0], v / r.v_start - 1, r.sim.cell().matrix()(1, 0) / r.sim.cell().matrix()(1, 1));
  EXPECT_NEAR(v / r.v_start, 1.0, 1e-14);
  EXPECT_GE(r.second.gamma[0], 1e-5);
  // simple shear: the edge along axis 1 leans along axis 2 by gamma
  EXPECT_NEAR(r.sim.cell().matrix()(1, 0) / r.sim.cell().matrix()(0, 0), r.second.gamma[0], 1e-12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.second.strain[k] - r.first.strain[k], 0.0, 1e-15) << k;
}

// Drained simple shear: the normal stress on the shear plane held at its pressure by the servo,
// the shear stress of the elastic lattice -G gamma (within 2 %: the spheres spin up with the
// material's rotation in the first instants).
TEST(ShearStages, DrainedSimpleShearHoldsTheNormalStress) {
  LatticeRun r(R"(type = "simple_shear"
pressure = 100e3
shear_strain_rate = 0.01
end = { shear_strain = 1e-5 })");
  const Mat3& s = r.second.state.stress;
  const real_t gamma = r.second.gamma[0];
  std::printf("[shear] drained simple shear: s11 %.6e Pa, s12 %.6e Pa, -G gamma %.6e Pa\n", s(0, 0), s(0, 1),
              -r.G() * gamma);
  EXPECT_NEAR(s(0, 0), 100e3, 0.005 * 100e3);
  EXPECT_NEAR(s(0, 1) - r.start.stress(0, 1), -r.G() * gamma, 0.02 * r.G() * gamma);
  EXPECT_NEAR(r.second.strain[1], r.first.strain[1], 1e-15);  // the lateral axes fixed
  EXPECT_NEAR(r.second.strain[2], r.first.strain[2], 1e-15);
}

// Cyclic simple shear in strain, amplitude 3e-6, 2 cycles: gamma_12 reaches +-amplitude (to one
// servo interval and the rows' 10 steps), reverses 4 times and ends back at gamma >= 0.
TEST(ShearStages, CyclicSimpleShearCompletesItsCycles) {
  LatticeRun r(R"(type = "cyclic_simple_shear"
constant_volume = true
shear_strain_rate = 0.01
amplitude = 3e-6
cycles = 2)");
  const real_t step = 0.01 * r.sim.params().dt, A = 3e-6;
  real_t hi = -1, lo = 1, prev = 0, dir = 1;
  int reversals = 0;
  for (auto& row : r.rows) {
    const real_t g = row["gamma_12"];
    hi = std::max(hi, g), lo = std::min(lo, g);
    if ((g - prev) * dir < 0) dir = -dir, ++reversals;
    prev = g;
  }
  std::printf("[shear] cyclic simple shear: gamma_12 in [%.4e, %.4e], %d reversals, end %.3e\n", lo, hi, reversals,
              r.second.gamma[0]);
  EXPECT_EQ(reversals, 4);
  EXPECT_LE(hi, A + 2.02 * step);
  EXPECT_GE(hi, A - 10.1 * step);
  EXPECT_GE(lo, -A - 2.02 * step);
  EXPECT_LE(lo, -A + 10.1 * step);
  EXPECT_GE(r.second.gamma[0], 0.0);
  EXPECT_LT(r.second.gamma[0], 2.02 * step);
  EXPECT_NEAR(r.sim.cell().volume() / r.v_start, 1.0, 1e-14);
}

// Cyclic simple shear in stress: tau = -s12 reaches +-10 kPa (to one servo interval's change and
// the rows' 10 steps) and the stage ends back at tau >= 0.
TEST(ShearStages, CyclicSimpleShearInStress) {
  LatticeRun r(R"(type = "cyclic_simple_shear"
pressure = 100e3
shear_strain_rate = 0.01
amplitude_stress = 10e3
cycles = 1)");
  const real_t dtau = r.G() * 0.01 * r.sim.params().dt;  // per step
  real_t hi = -1e9, lo = 1e9;
  for (auto& row : r.rows) hi = std::max(hi, -row["s12"]), lo = std::min(lo, -row["s12"]);
  const Mat3& s = r.second.state.stress;
  const real_t end = -0.5 * (s(0, 1) + s(1, 0));  // the symmetric part, as the control reads it
  std::printf("[shear] cyclic simple shear in stress: tau in [%.4e, %.4e] Pa (%.1f Pa per step), end %.3e Pa\n", lo, hi,
              dtau, end);
  EXPECT_GE(hi, 10e3 - 11 * dtau - 200);
  EXPECT_LE(hi, 10e3 + 3 * dtau + 200);
  EXPECT_LE(lo, -10e3 + 11 * dtau + 200);
  EXPECT_GE(lo, -10e3 - 3 * dtau - 200);
  EXPECT_GE(end, 0.0);
}

// Principal rotation: p, q, b held within 1 % of their targets at every row after the first 20
// while the major axis turns through 90 degrees at 30000 degrees/s (3 ms, some 2900 steps); the
// series' theta_12 follows the turn (to 2 degrees) and ends at the start angle + 90.
TEST(ShearStages, PrincipalRotationTurnsTheMajorAxis) {
  LatticeRun r(R"(type = "principal_rotation"
pressure = 100e3
q = 30e3
b = 0.5
rotation_rate = 30000
angle = 90
start_angle = -30)");
  ASSERT_GT(r.rows.size(), 100u);
  const real_t dt = r.sim.params().dt;
  real_t worst_p = 0, worst_q = 0, worst_b = 0, worst_angle = 0;
  for (std::size_t i = 20; i < r.rows.size(); ++i) {
    auto& row = r.rows[i];
    const real_t s1 = row["sigma_1"], s2 = row["sigma_2"], s3 = row["sigma_3"];
    worst_p = std::max(worst_p, std::abs(row["p"] - 100e3) / 100e3);
    worst_q = std::max(worst_q, std::abs(row["q"] - 30e3) / 30e3);
    worst_b = std::max(worst_b, std::abs((s2 - s3) / (s1 - s3) - 0.5));
    const real_t k = row["step"] - (r.rows.front()["step"] - 10);  // the stage's step
    real_t want = -30 + 30000 * k * dt, d = row["theta_12"] - std::min(want, 60.0);
    d -= 180 * std::round(d / 180);
    worst_angle = std::max(worst_angle, std::abs(d));
  }
  std::printf(
      "[shear] principal rotation: %zu rows, |p - p0| <= %.3f %%, |q - q0| <= %.3f %%, |b - b0| <= %.2e, "
      "the angle within %.3f degrees, ending at %.3f\n",
      r.rows.size(), 100 * worst_p, 100 * worst_q, worst_b, worst_angle, r.rows.back()["theta_12"]);
  EXPECT_LT(worst_p, 0.01);
  EXPECT_LT(worst_q, 0.01);
  EXPECT_LT(worst_b, 0.02);
  EXPECT_LT(worst_angle, 2.0);
  EXPECT_NEAR(r.rows.back()["theta_12"], 60.0, 2.0);
}

}  // namespace
}  // namespace fabrica
