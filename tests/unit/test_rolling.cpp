// A sphere on a horizontal wall under gravity (docs/verification.md sections 4-6):
//  - rolling resistance: deceleration 5 mu_r g / 7, stopping distance 7 v0^2 / (10 mu_r g),
//    then rest without creep;
//  - sliding-to-rolling transition with mu_r = 0: t = 2 v0 / (7 mu g), v = 5 v0 / 7;
//  - incline (tilted gravity): rest for tan(theta) < mu_r, a = 5/7 g (sin - mu_r cos) above.
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

namespace fabrica {
namespace {

using test::kRho;
using test::make_particles;
using test::make_sim;
using test::sphere_mass;

constexpr real_t kG = 9.81;
const Vec3 kWallPoint(0.5, 0.5, 0.3);

// One sphere resting on the wall z = 0.3 (normal +z) at its equilibrium overlap m g_z / k_n,
// with velocity v and spin w. dt = 0.2 of the critical step.
Simulation sphere_on_wall(const ContactLawParams& law, real_t R, const Vec3& v, const Vec3& w, const Vec3& gravity,
                          real_t& kn_out) {
  const real_t m = sphere_mass(R);
  const real_t kn = law.stiffness_mode == NormalStiffnessMode::Direct
      ? law.normal_stiffness
      : std::numbers::pi * R * law.youngs_modulus;  // wall: r = L = R
  kn_out = kn;
  const real_t un = m * -gravity.z() / kn;
  Particles p = make_particles({{0, R, kRho, Vec3(0.2, 0.5, kWallPoint.z() + R - un), v, w}});
  const real_t dt = 0.2 * critical_time_step(p, law, true);
  return make_sim(std::move(p), law, dt, 0.2 * R, {Wall{kWallPoint, Vec3::UnitZ(), Vec3::Zero(), false, {}}}, gravity);
}

// Least-squares slope of y(t).
real_t slope(const std::vector<real_t>& t, const std::vector<real_t>& y) {
  const real_t n = real_t(t.size());
  real_t st = 0, sy = 0, stt = 0, sty = 0;
  for (std::size_t k = 0; k < t.size(); ++k) { st += t[k], sy += y[k], stt += t[k] * t[k], sty += t[k] * y[k]; }
  return (n * sty - st * sy) / (n * stt - st * st);
}

// Test 4. Rolling resistance on a horizontal wall, started in pure rolling v0 = w R.
// Closed forms: a = -5 mu_r g / 7, stopping distance s = 7 v0^2 / (10 mu_r g).
// Tolerances: 2 % on a and s. After the stop the centre stays within 5 theta_c R of the stopping
// point for 20 stopping times (bound derived below), theta_c = mu_r Rbar f_n / k_r the rolling
// spring's elastic range, and its mean position does not drift by more than theta_c R / 2.
void rolling_resistance_case(const ContactLawParams& law) {
  const real_t R = 0.01, m = sphere_mass(R), v0 = 0.1, mu_r = law.rolling_friction;
  real_t kn;
  Simulation sim = sphere_on_wall(law, R, Vec3(v0, 0, 0), Vec3(0, v0 / R, 0), Vec3(0, 0, -kG), kn);
  const real_t a_exact = 5 * mu_r * kG / 7, s_exact = 7 * v0 * v0 / (10 * mu_r * kG);
  const real_t t_stop = v0 / a_exact, dt = sim.params().dt;
  const real_t x0 = sim.particles().x[0].x();
  std::vector<real_t> ts, vs;
  real_t x_stop = 0, v_prev = v0, x_prev = x0;
  bool stopped = false;
  while (!stopped && sim.time() < 2 * t_stop) {
    sim.step();
    const real_t t = sim.time(), v = sim.particles().v[0].x(), x = sim.particles().x[0].x();
    if (t > 0.1 * t_stop && t < 0.9 * t_stop) ts.push_back(t), vs.push_back(v);
    if (v <= 0) {
      x_stop = x_prev + (x - x_prev) * v_prev / (v_prev - v);
      stopped = true;
    }
    v_prev = v, x_prev = x;
  }
  ASSERT_TRUE(stopped);
  const real_t a = -slope(ts, vs), s = x_stop - x0;
  // Hold for 20 stopping times. At the stop the rolling spring holds its cap M_c = k_r theta_c
  // and the shear spring the force F = 5/7 mu_r m g that decelerated the sphere; afterwards the
  // undamped system rocks on these springs with at most the energy
  // E = k_s (theta_c R)^2 (1 + 25/49) / 2 (k_r = k_s R^2 on a wall), so each spring's extension
  // changes by at most 2 sqrt(2E/k_s) = 2.46 theta_c R and the centre stays within
  // 4.92 theta_c R of the stopping point; its speed stays below sqrt(2E/m).
  const real_t ks = kn / law.stiffness_ratio, kr = ks * R * R;  // wall: Rbar = R
  const real_t theta_c = mu_r * R * m * kG / kr;
  const real_t E = 0.5 * ks * theta_c * R * theta_c * R * (1 + 25.0 / 49);
  real_t creep = 0, vmax = 0, x_first = 0, x_last = 0;
  const int n_hold = int(20 * t_stop / dt), n_avg = int(t_stop / dt);
  for (int k = 0; k < n_hold; ++k) {
    sim.step();
    const real_t x = sim.particles().x[0].x();
    creep = std::max(creep, std::abs(x - x_stop));
    vmax = std::max(vmax, sim.particles().v[0].norm());
    if (k < n_avg) x_first += x / n_avg;
    if (k >= n_hold - n_avg) x_last += x / n_avg;
  }
  std::printf(
      "[rolling] kn %.3e: a rel err %.2e, s rel err %.2e; after stop (%d steps): max "
      "|x - x_stop| = %.2f theta_c R, drift of the mean %.2e theta_c R, max |v| = %.2f "
      "sqrt(2E/m)\n",
      kn, a / a_exact - 1, s / s_exact - 1, n_hold, creep / (theta_c * R), (x_last - x_first) / (theta_c * R),
      vmax / std::sqrt(2 * E / m));
  EXPECT_NEAR(a / a_exact, 1.0, 2e-2);
  EXPECT_NEAR(s / s_exact, 1.0, 2e-2);
  EXPECT_LT(creep, 5 * theta_c * R);
  EXPECT_LT(std::abs(x_last - x_first), 0.5 * theta_c * R);  // no ratcheting
  EXPECT_LT(vmax, 1.05 * std::sqrt(2 * E / m));
}

TEST(Rolling, ResistanceDirectStiffness) { rolling_resistance_case(test::direct_law(1e5, 0.5, 0.1)); }

TEST(Rolling, ResistanceDeformabilityStiffness) {
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  law.friction = 0.5;
  law.rolling_friction = 0.05;
  law.stiffness_ratio = 1.5;
  rolling_resistance_case(law);
}

// Test 5. Sliding to rolling, mu_r = 0: launched with v0 and no spin, the slip velocity
// v - w R decays at 7 mu g / 2, so rolling starts at t = 2 v0 / (7 mu g) with v = 5 v0 / 7.
// Tolerance 1 % on both.
TEST(Rolling, SlidingToRollingTransition) {
  const real_t R = 0.01, v0 = 0.5, mu = 0.2;
  real_t kn;
  Simulation sim = sphere_on_wall(test::direct_law(1e5, mu), R, Vec3(v0, 0, 0), Vec3::Zero(), Vec3(0, 0, -kG), kn);
  const real_t t_exact = 2 * v0 / (7 * mu * kG), v_exact = 5 * v0 / 7;
  const real_t dt = sim.params().dt;
  auto slip = [&] {
    const Particles& p = sim.particles();
    const real_t un = R - (p.x[0].z() - kWallPoint.z());
    return p.v[0].x() - (R - 0.5 * un) * p.w[0].y();
  };
  real_t s_prev = slip(), t_roll = -1, v_roll = 0, v_prev = v0;
  while (t_roll < 0 && sim.time() < 2 * t_exact) {
    sim.step();
    const real_t s = slip(), v = sim.particles().v[0].x();
    if (s <= 0) {
      const real_t f = s_prev / (s_prev - s);
      t_roll = sim.time() - dt + f * dt;
      v_roll = v_prev + f * (v - v_prev);
    }
    s_prev = s, v_prev = v;
  }
  ASSERT_GT(t_roll, 0);
  // Then it rolls on at constant mean speed (no rolling resistance); average over 0.1 s.
  real_t v_mean = 0;
  const int n = int(0.1 / dt);
  for (int k = 0; k < n; ++k) sim.step(), v_mean += sim.particles().v[0].x() / n;
  std::printf("[slide->roll] t rel err %.2e, v rel err %.2e, later mean v rel err %.2e\n", t_roll / t_exact - 1,
              v_roll / v_exact - 1, v_mean / v_exact - 1);
  EXPECT_NEAR(t_roll / t_exact, 1.0, 1e-2);
  EXPECT_NEAR(v_roll / v_exact, 1.0, 1e-2);
  EXPECT_NEAR(v_mean / v_exact, 1.0, 1e-2);
  EXPECT_EQ(sim.macro().sliding, 0);
}

// Test 6. Incline: gravity g (sin th, 0, -cos th) over the horizontal wall, sphere released at
// rest. Rolling without slip: a = 5/7 g (sin th - mu_r cos th) when tan th > mu_r (2 %);
// at rest when tan th < mu_r (see the elastic bound below).
real_t incline_acceleration(real_t theta, real_t mu_r, real_t duration) {
  const real_t R = 0.01;
  const Vec3 g(kG * std::sin(theta), 0, -kG * std::cos(theta));
  real_t kn;
  Simulation sim = sphere_on_wall(test::direct_law(1e5, 0.6, mu_r), R, Vec3::Zero(), Vec3::Zero(), g, kn);
  std::vector<real_t> ts, vs;
  while (sim.time() < duration) {
    sim.step();
    if (sim.time() > 0.2 * duration) ts.push_back(sim.time()), vs.push_back(sim.particles().v[0].x());
  }
  EXPECT_LT(sim.dissipation().friction, 1e-12) << "the contact slipped";
  return slope(ts, vs);
}

TEST(Rolling, InclineRollingWithResistance) {
  const real_t theta = 20 * std::numbers::pi / 180, mu_r = 0.1;
  const real_t a_exact = 5.0 / 7 * kG * (std::sin(theta) - mu_r * std::cos(theta));
  const real_t a = incline_acceleration(theta, mu_r, 0.2);
  std::printf("[incline] mu_r = %.2f, theta = 20 deg: a rel err %.2e\n", mu_r, a / a_exact - 1);
  EXPECT_NEAR(a / a_exact, 1.0, 2e-2);
}

TEST(Rolling, InclineRollingFree) {
  const real_t theta = 20 * std::numbers::pi / 180;
  const real_t a_exact = 5.0 / 7 * kG * std::sin(theta);
  const real_t a = incline_acceleration(theta, 0.0, 0.2);
  std::printf("[incline] mu_r = 0, theta = 20 deg: a rel err %.2e\n", a / a_exact - 1);
  EXPECT_NEAR(a / a_exact, 1.0, 2e-2);
}

// tan th = 0.4 mu_r: released with unloaded springs, the undamped sphere oscillates about its
// static offset x_s = F/k_s + R M/k_r = 2 m g sin th / k_s (F = m g sin th, M = R F, k_r = k_s R^2)
// so |x - x0| <= 2 x_s and the rolling moment peaks at 2 M = 0.8 of its cap: no slip ever, the
// centre stays within 2 x_s (tolerance 5 %) for 2 s, while free rolling would cover metres.
TEST(Rolling, InclineAtRestBelowRollingLimit) {
  const real_t R = 0.01, m = sphere_mass(R), mu_r = 0.2, theta = std::atan(0.4 * mu_r);
  const Vec3 g(kG * std::sin(theta), 0, -kG * std::cos(theta));
  real_t kn;
  Simulation sim = sphere_on_wall(test::direct_law(1e5, 0.6, mu_r), R, Vec3::Zero(), Vec3::Zero(), g, kn);
  const real_t x0 = sim.particles().x[0].x();
  const real_t x_s = 2 * m * g.x() / kn;
  real_t dmax = 0;
  while (sim.time() < 2.0) {
    sim.step();
    dmax = std::max(dmax, std::abs(sim.particles().x[0].x() - x0));
  }
  std::printf("[incline] tan th = 0.4 mu_r: max displacement %.3e m, bound 2 x_s = %.3e m\n", dmax, 2 * x_s);
  EXPECT_LT(dmax, 1.05 * 2 * x_s);
  EXPECT_GT(dmax, 0.5 * x_s);  // the springs did take the load
  EXPECT_EQ(sim.dissipation().rolling, 0.0);
  EXPECT_EQ(sim.dissipation().friction, 0.0);
}

}  // namespace
}  // namespace fabrica
