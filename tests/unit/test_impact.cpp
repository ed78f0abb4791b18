// Binary impacts against closed forms (docs/verification.md sections 1-3):
//  - normal elastic impact of two equal spheres: contact time pi sqrt(m_eff/k_n), e = 1;
//  - normal impact with a viscous dashpot and no-tension clamp: restitution e(beta);
//  - oblique impact on a wall with gross sliding: impulse ratio mu, spin 5 mu (1+e) v_n / (2R).
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

constexpr real_t kPi = std::numbers::pi;

struct ImpactResult {
  real_t contact_time;   // s, from the interpolated zero crossings of the gap
  real_t v_in, v_out;    // relative normal speed before and after (m/s)
  real_t ke_in, ke_out;  // kinetic energy before and after (J)
  real_t e_viscous;      // energy booked as dissipated by the dashpots (J)
};

// Two equal spheres approaching along the unit direction e with relative speed 2 u, plus a
// common drift velocity (Galilean invariance). The gap is interpolated linearly between steps
// to locate the first touch and the separation.
ImpactResult two_sphere_impact(const ContactLawParams& law, real_t R, real_t u, real_t dt, const Vec3& e,
                               const Vec3& drift) {
  const Vec3 c(0.5, 0.5, 0.5);
  const real_t gap0 = 20 * u * dt;  // about 10 steps before contact
  Particles p = make_particles(
      {{0, R, kRho, c - (R + 0.5 * gap0) * e, drift + u * e}, {1, R, kRho, c + (R + 0.5 * gap0) * e, drift - u * e}});
  Simulation sim = make_sim(std::move(p), law, dt, 0.2 * R);
  auto gap_and_vn = [&](real_t& gap, real_t& vn) {
    const Particles& q = sim.particles();
    const std::size_t a = index_of(q, 0), b = index_of(q, 1);
    const Vec3 d = sim.cell().minimum_image(q.x[b] - q.x[a]);
    gap = d.norm() - 2 * R;
    vn = (q.v[b] - q.v[a]).dot(d.normalized());
  };
  real_t gap, vn, gap_prev;
  gap_and_vn(gap, vn);
  const real_t v_in = -vn;
  const real_t ke_in = kinetic_energy(sim.particles());
  real_t t_start = -1, t_end = -1;
  for (int s = 0; s < 1000000 && t_end < 0; ++s) {
    gap_prev = gap;
    sim.step();
    gap_and_vn(gap, vn);
    const real_t t = sim.time();
    if (t_start < 0 && gap_prev >= 0 && gap < 0) t_start = t - dt * gap / (gap - gap_prev);
    if (t_start >= 0 && gap_prev < 0 && gap >= 0) t_end = t - dt * gap / (gap - gap_prev);
  }
  EXPECT_GT(t_end, 0.0) << "no separation";
  for (int s = 0; s < 5; ++s) sim.step();
  gap_and_vn(gap, vn);
  return {t_end - t_start, v_in, vn, ke_in, kinetic_energy(sim.particles()), sim.dissipation().viscous};
}

// Test 1. Elastic normal impact, k_n from the deformability form k_n = pi r^2 E / (R1 + R2).
// Closed form: T = pi sqrt(m_eff / k_n), v_out = v_in.
// Tolerances: T within 0.5 % (dt = T/1000, interpolated crossings); |v_out/v_in - 1| < 1e-6.
TEST(Impact, ElasticNormalTwoEqualSpheres) {
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  law.friction = 0.5;
  const real_t R = 0.01, m = sphere_mass(R), meff = 0.5 * m;
  const real_t kn = kPi * R * R * law.youngs_modulus / (2 * R);
  const real_t T = kPi * std::sqrt(meff / kn);
  const Vec3 e = Vec3(1, 2, 3).normalized();
  const ImpactResult r = two_sphere_impact(law, R, 0.1, T / 1000, e, Vec3(0.03, -0.02, 0.05));
  const real_t err_t = r.contact_time / T - 1, err_v = r.v_out / r.v_in - 1;
  std::printf("[impact] T = %.6e s, measured %.6e s, rel err %.2e; v_out/v_in - 1 = %.2e\n", T, r.contact_time, err_t,
              err_v);
  EXPECT_NEAR(r.v_in, 0.2, 1e-12);
  EXPECT_LT(std::abs(err_t), 5e-3);
  EXPECT_LT(std::abs(err_v), 1e-6);
}

// Closed form of the restitution coefficient of the linear spring-dashpot with the no-tension
// clamp (the contact force ends when k u + c du/dt = 0, before the overlap closes).
real_t restitution_clamped(real_t beta) {
  const real_t w0 = 1.0, z = beta * w0, wd = w0 * std::sqrt(1 - beta * beta);
  const real_t ts = (kPi - std::atan(2 * z * wd / (w0 * w0 - 2 * z * z))) / wd;
  return std::exp(-z * ts) * (-std::cos(wd * ts) + z / wd * std::sin(wd * ts));
}

// Test 2. Viscous normal dashpot, c_n = 2 beta sqrt(m_eff k_n), dt = T/2000. Tolerance 0.5 % on e
// (the error is first order in dt: the dashpot force jumps from 0 to c v_in at first touch).
TEST(Impact, ViscousRestitution) {
  const real_t R = 0.01, m = sphere_mass(R), meff = 0.5 * m, kn = 2e5;
  const real_t T = kPi * std::sqrt(meff / kn);
  for (real_t beta : {0.05, 0.2, 0.5}) {
    ContactLawParams law = test::direct_law(kn, 0.5);
    law.damping_ratio_n = beta;
    const ImpactResult r = two_sphere_impact(law, R, 0.1, T / 2000, Vec3::UnitX(), Vec3::Zero());
    const real_t e_exact = restitution_clamped(beta), e = r.v_out / r.v_in;
    std::printf("[restitution] beta = %.2f: e exact %.6f, measured %.6f, rel err %.2e\n", beta, e_exact, e,
                e / e_exact - 1);
    EXPECT_NEAR(e / e_exact, 1.0, 5e-3) << "beta = " << beta;
    // Energy book-keeping: the kinetic energy lost equals the energy booked as viscous
    // dissipation (dashpot work plus the spring energy dropped by the no-tension clamp), 0.5 %.
    const real_t lost = r.ke_in - r.ke_out;
    std::printf("[restitution]   KE lost %.6e J, booked %.6e J, rel err %.2e\n", lost, r.e_viscous,
                r.e_viscous / lost - 1);
    EXPECT_NEAR(r.e_viscous / lost, 1.0, 5e-3) << "beta = " << beta;
  }
}

// Test 3. Oblique impact on a wall, gross sliding throughout (v_t > 7 mu v_n), no damping.
// Closed form (impulse J = (1+e) m v_n, e = 1): v_n' = v_n, dv_t = -mu (1+e) v_n,
// w_y = 5 mu (1+e) v_n / (2R) (positive: the spin of forward rolling along +x).
// Tolerance: 1e-6 on v_n'/v_n, 1 % on dv_t and w_y.
TEST(Impact, ObliqueWallGrossSliding) {
  const real_t R = 0.01, m = sphere_mass(R), kn = 2e5, mu = 0.1, vn = 0.1, vt = 0.5;
  const real_t T = kPi * std::sqrt(m / kn);
  const real_t dt = T / 1000;
  const Vec3 wall_pt(0.5, 0.5, 0.5);
  const real_t z0 = wall_pt.z() + R + 10 * vn * dt;
  Particles p = make_particles({{7, R, kRho, Vec3(0.3, 0.5, z0), Vec3(vt, 0, -vn)}});
  Simulation sim = make_sim(std::move(p), test::direct_law(kn, mu), dt, 0.2 * R,
                            {Wall{wall_pt, Vec3::UnitZ(), Vec3::Zero(), false, {}}});
  const real_t ke_in = kinetic_energy(sim.particles());
  bool touched = false, slid_always = true;
  for (int s = 0; s < 100000; ++s) {
    sim.step();
    const auto& wl = sim.wall_contacts();
    const bool touching = wl.size() == 1 && wl.touching[0];
    if (touching) {
      touched = true;
      // Shear spring at the Coulomb cap whenever the contact carries load.
      const real_t un = R - (sim.particles().x[0].z() - wall_pt.z());
      if (un > 0 && std::abs(wl.fs[0].norm() - mu * kn * un) > 1e-9 * mu * kn * un) slid_always = false;
    }
    if (touched && !touching) break;
  }
  for (int s = 0; s < 5; ++s) sim.step();
  const Particles& q = sim.particles();
  const real_t vn_out = q.v[0].z(), dvt = q.v[0].x() - vt, wy = q.w[0].y();
  const real_t dvt_exact = -mu * 2 * vn, wy_exact = 5 * mu * 2 * vn / (2 * R);
  std::printf(
      "[oblique] vn'/vn - 1 = %.2e, dvt rel err %.2e, w rel err %.2e, |v_y|,|w_x|,|w_z| = "
      "%.1e %.1e %.1e\n",
      vn_out / vn - 1, dvt / dvt_exact - 1, wy / wy_exact - 1, std::abs(q.v[0].y()), std::abs(q.w[0].x()),
      std::abs(q.w[0].z()));
  EXPECT_TRUE(touched);
  EXPECT_TRUE(slid_always);
  EXPECT_NEAR(vn_out / vn, 1.0, 1e-6);
  EXPECT_NEAR(dvt / dvt_exact, 1.0, 1e-2);
  EXPECT_NEAR(wy / wy_exact, 1.0, 1e-2);
  EXPECT_LT(std::abs(q.v[0].y()) + R * (std::abs(q.w[0].x()) + std::abs(q.w[0].z())), 1e-12);
  // The kinetic energy lost is the energy booked as Coulomb slip dissipation (1 %).
  const real_t lost = ke_in - kinetic_energy(q);
  std::printf("[oblique] KE lost %.6e J, friction booked %.6e J, rel err %.2e\n", lost, sim.dissipation().friction,
              sim.dissipation().friction / lost - 1);
  EXPECT_NEAR(sim.dissipation().friction / lost, 1.0, 1e-2);
}

}  // namespace
}  // namespace fabrica
