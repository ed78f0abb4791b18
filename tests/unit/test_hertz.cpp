// Hertz-Mindlin (core/contact/hertz_mindlin.hpp) against closed forms (docs/verification.md,
// "Hertz-Mindlin"):
//  - elastic normal impact, sphere-sphere (unequal radii) and sphere-wall: contact time
//    2.868 (m*^2 / (R* E*^2 v))^{1/5}, largest overlap (15 m* v^2 / (16 E* sqrt R*))^{2/5},
//    rebound speed = impact speed;
//  - restitution of the damped impact against the input (the exact clamped mapping);
//  - oblique impact on a wall in gross sliding (Chung & Ooi 2011 test 6: independent of the
//    normal model);
//  - the tangential spring: Mindlin's k_t = 8 G* sqrt(R* u_n), scaled as the contact unloads;
//  - the elastic energy of a frictionless Hertz lattice conserved.
#include "core/contact_law.hpp"
#include "core/restitution.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace fabrica {
namespace {

using test::index_of;
using test::kRho;
using test::make_particles;
using test::make_sim;
using test::sphere_mass;

ContactLawParams hertz_law(real_t E, real_t nu, real_t mu) {
  ContactLawParams law;
  law.model = ContactModel::HertzMindlin;
  law.youngs_modulus = E;
  law.poisson_ratio = nu;
  law.friction = mu;
  return law;
}

struct Impact {
  real_t contact_time, max_overlap, v_in, v_out;
  real_t ke_lost, e_viscous;  // kinetic energy lost, energy booked as dashpot work [J]
};

// Sphere 0 (radius R1) moves at speed v along +x towards sphere 1 (radius R2) at rest, or
// towards a wall (R2 = 0) with its normal along -x. The overlap is interpolated linearly
// between steps for the first touch and the separation.
Impact normal_impact(const ContactLawParams& law, real_t R1, real_t R2, real_t v, real_t dt) {
  const Vec3 c(0.5, 0.5, 0.5);
  const real_t gap0 = 10 * v * dt;
  const bool wall = R2 == 0;
  std::vector<SphereInit> s{{0, R1, kRho, c - Vec3(R1 + gap0, 0, 0), Vec3(v, 0, 0)}};
  if (!wall) s.push_back({1, R2, kRho, c + Vec3(R2, 0, 0), Vec3::Zero()});
  std::vector<Wall> walls;
  if (wall) walls.push_back(Wall{c, -Vec3::UnitX(), Vec3::Zero(), false, {}});
  Simulation sim = make_sim(make_particles(s), law, dt, 0.2 * R1, walls);
  auto overlap_and_v = [&](real_t& un, real_t& vn) {
    const Particles& q = sim.particles();
    const std::size_t a = index_of(q, 0);
    if (wall) {
      un = q.x[a].x() + R1 - c.x();
      vn = q.v[a].x();
    } else {
      const std::size_t b = index_of(q, 1);
      un = R1 + R2 - (q.x[b] - q.x[a]).norm();
      vn = q.v[a].x() - q.v[b].x();
    }
  };
  real_t un, vn, un_prev, t0 = -1, t1 = -1, umax = 0;
  overlap_and_v(un, vn);
  const real_t ke_in = kinetic_energy(sim.particles());
  const real_t v_in = vn;
  for (int k = 0; k < 10000000 && t1 < 0; ++k) {
    un_prev = un;
    sim.step();
    overlap_and_v(un, vn);
    umax = std::max(umax, un);
    const real_t t = sim.time();
    if (t0 < 0 && un_prev <= 0 && un > 0) t0 = t - dt * un / (un - un_prev);
    if (t0 >= 0 && un_prev > 0 && un <= 0) t1 = t - dt * un / (un - un_prev);
  }
  EXPECT_GT(t1, 0.0) << "no separation";
  for (int k = 0; k < 3; ++k) sim.step();
  overlap_and_v(un, vn);
  return {t1 - t0, umax, v_in, -vn, ke_in - kinetic_energy(sim.particles()), sim.dissipation().viscous};
}

// Test 1. Elastic normal impact (no damping, mu = 0.5 irrelevant along the normal).
// E = 70 GPa, nu = 0.3 (glass), v = 0.5 m/s, dt = t_c / 2000. Tolerances: the contact time
// 1e-3 (the constant 2.868 is rounded at 1.5e-4; the crossings interpolated), the largest overlap
// 1e-3 (sampled at steps: (pi dt / t_c)^2 / 8 ~ 3e-7), rebound speed 1e-6.
void check_elastic_impact(real_t R1, real_t R2, const char* label) {
  const ContactLawParams law = hertz_law(70e9, 0.3, 0.5);
  const real_t v = 0.5;
  const real_t m1 = sphere_mass(R1), m2 = R2 > 0 ? sphere_mass(R2) : 0;
  const real_t mstar = R2 > 0 ? m1 * m2 / (m1 + m2) : m1;
  const real_t rstar = R2 > 0 ? R1 * R2 / (R1 + R2) : R1;
  const real_t Estar = law.youngs_modulus / (2 * (1 - law.poisson_ratio * law.poisson_ratio));
  const real_t tc = 2.868 * std::pow(mstar * mstar / (rstar * Estar * Estar * v), 0.2);
  const real_t umax = std::pow(15 * mstar * v * v / (16 * Estar * std::sqrt(rstar)), 0.4);
  const Impact r = normal_impact(law, R1, R2, v, tc / 2000);
  std::printf(
      "[hertz impact] %s: t_c %.6e s (closed form %.6e, rel err %.2e), u_max %.6e m (%.6e, "
      "%.2e), v_out/v_in - 1 = %.2e\n",
      label, r.contact_time, tc, r.contact_time / tc - 1, r.max_overlap, umax, r.max_overlap / umax - 1,
      r.v_out / r.v_in - 1);
  EXPECT_NEAR(r.v_in, v, 1e-12);
  EXPECT_NEAR(r.contact_time / tc, 1.0, 1e-3);
  EXPECT_NEAR(r.max_overlap / umax, 1.0, 1e-3);
  EXPECT_NEAR(r.v_out / r.v_in, 1.0, 1e-6);
}

TEST(Hertz, ElasticNormalImpactSphereSphere) { check_elastic_impact(0.002, 0.003, "sphere-sphere"); }
TEST(Hertz, ElasticNormalImpactSphereWall) { check_elastic_impact(0.002, 0.0, "sphere-wall"); }

// Test 2. The exact clamped restitution mapping, and the damped impact against its input e.
// dt = t_c / 4000; tolerance 0.5 % on e (first order in dt, as for the linear dashpot), and on
// the energy booked as the dashpots' work against the kinetic energy lost.
TEST(Hertz, DampedRestitutionMatchesInput) {
  EXPECT_EQ(hertz_clamped_restitution(0.0), 1.0);
  for (real_t e : {0.3, 0.5, 0.8, 0.95}) {
    const real_t beta = hertz_damping_for_restitution(e);
    EXPECT_NEAR(hertz_clamped_restitution(beta), e, 1e-8);
    ContactLawParams law = hertz_law(70e9, 0.3, 0.5);
    law.damping_ratio_n = beta;
    const real_t R = 0.002, v = 0.5, m = sphere_mass(R);
    const real_t Estar = law.youngs_modulus / (2 * (1 - 0.09));
    const real_t tc = 2.868 * std::pow(0.25 * m * m / (0.5 * R * Estar * Estar * v), 0.2);
    for (real_t R2 : {R, 0.0}) {
      const Impact r = normal_impact(law, R, R2, v, tc / 4000);
      const real_t got = r.v_out / r.v_in;
      // LIGGGHTS' mapping beta = -ln e / sqrt(ln^2 e + pi^2) gives, with the clamp:
      const real_t l = std::log(e);
      const real_t e_liggghts = hertz_clamped_restitution(-l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi));
      std::printf(
          "[hertz restitution] e = %.2f (%s): beta %.6f, measured %.6f (rel err %.2e); "
          "LIGGGHTS' beta %.6f would give %.4f\n",
          e, R2 > 0 ? "sphere-sphere" : "sphere-wall", beta, got, got / e - 1,
          -l / std::sqrt(l * l + std::numbers::pi * std::numbers::pi), e_liggghts);
      EXPECT_NEAR(got / e, 1.0, 5e-3) << "e = " << e;
      // The books: the kinetic energy lost is the dashpots' work booked (0.5 %).
      std::printf("[hertz restitution]   KE lost %.6e J, booked %.6e J, rel err %.2e\n", r.ke_lost, r.e_viscous,
                  r.e_viscous / r.ke_lost - 1);
      EXPECT_NEAR(r.e_viscous / r.ke_lost, 1.0, 5e-3) << "e = " << e;
    }
  }
}

// Test 3. Oblique impact on a wall in gross sliding (Chung & Ooi 2011, test 6: v_t / v_n large):
// whatever the normal model, the impulse ratio is mu: dv_t = -mu (1 + e) v_n and the spin
// w = 5 mu (1 + e) v_n / (2 R), e = 1 here. Tolerances as the linear law's (test_impact.cpp):
// 1e-6 on v_n' / v_n, 1 % on dv_t and w; the kinetic energy lost booked as slip (1 %).
TEST(Hertz, ObliqueWallGrossSliding) {
  const real_t R = 0.002, mu = 0.1, vn = 0.2, vt = 2.0;
  const ContactLawParams law = hertz_law(70e9, 0.3, mu);
  const real_t m = sphere_mass(R), Estar = law.youngs_modulus / (2 * (1 - 0.09));
  const real_t tc = 2.868 * std::pow(m * m / (R * Estar * Estar * vn), 0.2);
  const real_t dt = tc / 2000;
  const Vec3 wall_pt(0.5, 0.5, 0.5);
  Particles p = make_particles({{7, R, kRho, Vec3(0.3, 0.5, wall_pt.z() + R + 10 * vn * dt), Vec3(vt, 0, -vn)}});
  Simulation sim = make_sim(std::move(p), law, dt, 0.2 * R, {Wall{wall_pt, Vec3::UnitZ(), Vec3::Zero(), false, {}}});
  const real_t ke_in = kinetic_energy(sim.particles());
  bool touched = false, slid_always = true;
  for (int s = 0; s < 1000000; ++s) {
    sim.step();
    const auto& wl = sim.wall_contacts();
    const bool touching = wl.size() == 1 && wl.touching[0];
    if (touching) {
      touched = true;
      const real_t un = R - (sim.particles().x[0].z() - wall_pt.z());
      const auto c = HertzMindlin::constants<false, false>(law, R, INFINITY, m, INFINITY);
      const real_t ft = HertzMindlin::shear_force(c, un, wl.fs[0]).norm();
      const real_t cap = mu * HertzMindlin::normal_force(c, un);
      if (un > 0 && std::abs(ft - cap) > 1e-9 * cap) slid_always = false;
    }
    if (touched && !touching) break;
  }
  for (int s = 0; s < 3; ++s) sim.step();
  const Particles& q = sim.particles();
  const real_t dvt = q.v[0].x() - vt, wy = q.w[0].y();
  const real_t dvt_exact = -mu * 2 * vn, wy_exact = 5 * mu * 2 * vn / (2 * R);
  const real_t lost = ke_in - kinetic_energy(q);
  std::printf(
      "[hertz oblique] vn'/vn - 1 = %.2e, dvt rel err %.2e, w rel err %.2e, friction "
      "booked / KE lost - 1 = %.2e\n",
      q.v[0].z() / vn - 1, dvt / dvt_exact - 1, wy / wy_exact - 1, sim.dissipation().friction / lost - 1);
  EXPECT_TRUE(touched);
  EXPECT_TRUE(slid_always);
  EXPECT_NEAR(q.v[0].z() / vn, 1.0, 1e-6);
  EXPECT_NEAR(dvt / dvt_exact, 1.0, 1e-2);
  EXPECT_NEAR(wy / wy_exact, 1.0, 1e-2);
  EXPECT_NEAR(sim.dissipation().friction / lost, 1.0, 1e-2);
}

// Test 4. The law itself, one contact: f_n = 4/3 E* sqrt(R*) u^{3/2}; a small tangential step at
// constant overlap loads the spring at Mindlin's k_t = 8 G* sqrt(R* u_n) (to rounding), one
// while the overlap grows at the step's mean stiffness (the midpoint rule); the energies are
// 8/15 E* sqrt(R*) u^{5/2} and |f_t|^2 / (2 k_t). Loading at rest keeps the stored force, and the
// energy |f_t|^2 / 2 (1 / k_t,prev - 1 / k_t) it loses is booked as slip; unloading to a quarter
// of the overlap halves it (s = sqrt(u_n / u_n,prev)), the
// spring's energy falling from |f|^2 / 2k_prev to (|f| / 2)^2 / (2 k_prev / 2), half of it booked.
TEST(Hertz, ContactLawClosedForms) {
  const ContactLawParams law = hertz_law(1e9, 0.25, 0.5);
  const real_t R1 = 0.01, R2 = 0.02, rstar = R1 * R2 / (R1 + R2), un = 1e-5, dt = 1e-6;
  const real_t Estar = 1e9 / (2 * (1 - 0.0625)), Gstar = 1e9 / (4 * 1.75 * 1.25);
  const auto c = HertzMindlin::constants<true, false>(law, R1, R2, 1, 2);
  using simd::from_vec, simd::to_vec;
  const Vec3 n = Vec3::UnitZ(), vt(1e-3, 0, 0);
  ContactKinematicsL<real_t> k{from_vec(n), un, from_vec(vt), from_vec(Vec3::Zero()), from_vec(Vec3::Zero()), un};
  ContactHistoryL<real_t> h{from_vec(Vec3::Zero()), from_vec(Vec3::Zero())};
  const auto r = HertzMindlin::evaluate<true, false, real_t>(law, c, k, h, dt);
  const real_t fn = 4.0 / 3.0 * Estar * std::sqrt(rstar) * std::pow(un, 1.5);
  const real_t kt = 8 * Gstar * std::sqrt(rstar * un);
  EXPECT_NEAR(r.fn / fn, 1.0, 1e-14);
  EXPECT_NEAR(to_vec(r.fs).x() / (-kt * vt.x() * dt), 1.0, 1e-14);
  EXPECT_FALSE(r.sliding);
  EXPECT_EQ(r.e_friction, 0.0);
  const real_t f = to_vec(r.fs).norm();
  EXPECT_NEAR(HertzMindlin::energy_normal(c, un) / (8.0 / 15.0 * Estar * std::sqrt(rstar) * std::pow(un, 2.5)), 1.0,
              1e-14);
  EXPECT_NEAR(HertzMindlin::energy_shear(c, un, to_vec(h.fs)) / (0.5 * f * f / kt), 1.0, 1e-14);
  // Loading to 4 u_n at rest (v_n = -3 u_n / dt): the force kept, k_t doubled.
  k.un = 4 * un;
  k.un_prev = un;
  k.vrel = from_vec(Vec3(0, 0, -3 * un / dt));
  const auto r2 = HertzMindlin::evaluate<true, false, real_t>(law, c, k, h, dt);
  EXPECT_NEAR(to_vec(r2.fs).norm() / f, 1.0, 1e-12);
  EXPECT_NEAR(r2.e_friction / (0.5 * f * f * (1 / kt - 1 / (2 * kt))), 1.0, 1e-9);
  // Unloading back to u_n (v_n = +3 u_n / dt): the force halved, half the energy booked.
  k.un = un;
  k.un_prev = 4 * un;
  k.vrel = from_vec(Vec3(0, 0, 3 * un / dt));
  const auto r3 = HertzMindlin::evaluate<true, false, real_t>(law, c, k, h, dt);
  EXPECT_NEAR(to_vec(r3.fs).norm() / (0.5 * f), 1.0, 1e-12);
  EXPECT_NEAR(r3.e_friction / (0.5 * f * f / (2 * kt) * 0.5), 1.0, 1e-9);
  // A tangential step while the overlap grows from u_n to 4 u_n: the increment at
  // (k_t(u_n) + k_t(4 u_n)) / 2 = 1.5 k_t.
  ContactHistoryL<real_t> h4{from_vec(Vec3::Zero()), from_vec(Vec3::Zero())};
  k.un = 4 * un;
  k.un_prev = un;
  k.vrel = from_vec(Vec3(vt.x(), 0, -3 * un / dt));
  const auto r4 = HertzMindlin::evaluate<true, false, real_t>(law, c, k, h4, dt);
  EXPECT_NEAR(to_vec(r4.fs).x() / (-1.5 * kt * vt.x() * dt), 1.0, 1e-12);
  // The stiffnesses the servo reads.
  EXPECT_NEAR(HertzMindlin::normal_stiffness(c, un) / (2 * Estar * std::sqrt(rstar * un)), 1.0, 1e-14);
  EXPECT_NEAR(HertzMindlin::shear_stiffness(c, un) / kt, 1.0, 1e-14);
}

// Test 5. The Rayleigh time step: pi R sqrt(rho / G) / (0.1631 nu + 0.8766), of the smallest sphere.
TEST(Hertz, RayleighTimeStep) {
  const ContactLawParams law = hertz_law(70e9, 0.3, 0.5);
  Particles p = make_particles(
      {{0, 0.002, kRho, Vec3(0.2, 0.2, 0.2), Vec3::Zero()}, {1, 0.001, kRho, Vec3(0.6, 0.6, 0.6), Vec3::Zero()}});
  const real_t G = 70e9 / 2.6;
  const real_t tr = std::numbers::pi * 0.001 * std::sqrt(kRho / G) / (0.1631 * 0.3 + 0.8766);
  EXPECT_NEAR(critical_time_step(p, law, false) / tr, 1.0, 1e-12);
}

}  // namespace
}  // namespace fabrica
