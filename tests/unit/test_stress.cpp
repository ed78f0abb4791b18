// Love-Weber stress, invariants, coordination and void ratio of compressed simple cubic
// lattices (docs/verification.md section 9). Every sphere touches its 6 lattice neighbours
// (across the periodic boundary too) with overlap 2R - a_k along axis k, so
//   sigma_kk = k_n (2R - a_k) a_k / (a_1 a_2 a_3),  sigma_ij = 0 (i != j),  Z = 6.
// Tolerance: relative 1e-10 (rounding only).
#include "core/generate.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

namespace fabrica {
namespace {

constexpr real_t kPi = std::numbers::pi;

// n[k] spheres of radius R along axis k at spacing a[k]; the cell is n[k] a[k] long.
Simulation lattice(const std::array<int, 3>& n, const Vec3& a, real_t R, const ContactLawParams& law,
                   bool use_generator) {
  Particles p;
  if (use_generator) {
    p = simple_cubic(n[0], R, a[0], test::kRho);
  } else {
    GlobalId id = 0;
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i)
          p.add({id++, R, test::kRho, Vec3((i + 0.5) * a[0], (j + 0.5) * a[1], (k + 0.5) * a[2])});
  }
  SimulationParams sp;
  sp.law = law;
  sp.skin = 0.1 * R;
  const Vec3 L(n[0] * a[0], n[1] * a[1], n[2] * a[2]);
  sp.dt = 1e-7;
  return Simulation(std::move(p), PeriodicCell(L), sp);
}

void check_lattice(Simulation& sim, const std::array<int, 3>& n, const Vec3& a, real_t R, real_t kn) {
  const real_t N = real_t(n[0]) * n[1] * n[2];
  const real_t V = n[0] * a[0] * n[1] * a[1] * n[2] * a[2];
  Mat3 exact = Mat3::Zero();
  for (int k = 0; k < 3; ++k) exact(k, k) = kn * (2 * R - a[k]) * a[k] / (a[0] * a[1] * a[2]);
  real_t p_exact, q_exact;
  {
    p_exact = exact.trace() / 3;
    const Vec3 s = exact.diagonal() - Vec3::Constant(p_exact);
    q_exact = std::sqrt(1.5 * s.squaredNorm());
  }
  // At construction and after a (static) measuring step.
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) sim.step(true);
    const MacroState m = sim.macro();
    const real_t scale = exact.diagonal().maxCoeff();
    const real_t err = (m.stress - exact).cwiseAbs().maxCoeff() / scale;
    std::printf(
        "[stress] n = %d %d %d, a = %.4g %.4g %.4g: max |sigma - exact| / sigma = %.2e, "
        "p rel err %.2e, q = %.3e (exact %.3e)\n",
        n[0], n[1], n[2], a[0], a[1], a[2], err, m.p / p_exact - 1, m.q, q_exact);
    EXPECT_LT(err, 1e-10);
    EXPECT_NEAR(m.p / p_exact, 1.0, 1e-10);
    if (q_exact < 1e-8 * p_exact)  // isotropic: q = 0 up to rounding
      EXPECT_LT(m.q, 1e-10 * m.p);
    else EXPECT_NEAR(m.q / q_exact, 1.0, 1e-10);
    EXPECT_EQ(m.contacts, std::int64_t(3 * N));
    EXPECT_DOUBLE_EQ(m.coordination, 6.0);
    EXPECT_DOUBLE_EQ(m.mech_coordination, 6.0);
    EXPECT_EQ(m.sliding, 0);
    EXPECT_NEAR(m.volume / V, 1.0, 1e-14);
    EXPECT_NEAR(m.void_ratio, V / (N * 4.0 / 3.0 * kPi * R * R * R) - 1, 1e-12);
    // Equilibrium: every sphere's resultant vanishes.
    EXPECT_LT(m.unbalanced, 1e-10);
    // Normal spring energy: 1/2 k_n (2R - a_k)^2 per contact.
    real_t en = 0;
    for (int k = 0; k < 3; ++k) en += N * 0.5 * kn * (2 * R - a[k]) * (2 * R - a[k]);
    EXPECT_NEAR(m.e_normal / en, 1.0, 1e-10);
  }
}

TEST(Stress, SimpleCubicIsotropic) {
  const real_t R = 0.01, a = 0.0199;  // overlap 1 % of R
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  const real_t kn = kPi * R * R * law.youngs_modulus / (2 * R);
  Simulation sim = lattice({4, 4, 4}, Vec3::Constant(a), R, law, true);
  check_lattice(sim, {4, 4, 4}, Vec3::Constant(a), R, kn);
}

TEST(Stress, SimpleCubicAnisotropic) {
  const real_t R = 0.01, kn = 3e5;
  const Vec3 a(0.0199, 0.0195, 0.01985);
  Simulation sim = lattice({4, 3, 5}, a, R, test::direct_law(kn, 0.3), false);
  check_lattice(sim, {4, 3, 5}, a, R, kn);
}

// With friction and motion the contact forces have shear parts; the stress is recomputed
// independently from the raw contact data (f = k_n u_n n + f_s on the body the branch vector
// points to, b the minimum-image branch vector): relative 1e-12 of max |sigma_ij|.
TEST(Stress, LoveWeberWithShearForcesFromRawContacts) {
  const real_t R = 0.01, a = 0.0198;
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  law.friction = 0.4;
  law.rolling_friction = 0.1;
  const real_t kn = kPi * R * R * law.youngs_modulus / (2 * R);
  Particles p = simple_cubic(4, R, a, test::kRho);
  Random rng(1);
  for (std::size_t k = 0; k < p.size(); ++k) {
    p.v[k] = 0.5 * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
    p.w[k] = 50.0 * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
  }
  SimulationParams sp;
  sp.law = law;
  sp.skin = 0.1 * R;
  sp.dt = 1e-6;
  Simulation sim(std::move(p), PeriodicCell(Vec3::Constant(4 * a)), sp);
  for (int s = 0; s < 200; ++s) sim.step();
  sim.step(true);
  const Particles& q = sim.particles();
  const PairList& pl = sim.pairs();
  Mat3 fb = Mat3::Zero();
  real_t shear = 0;
  for (std::size_t k = 0; k < pl.size(); ++k) {
    const Index i = pl.i[k], j = pl.j[k];
    const Vec3 d = sim.cell().minimum_image(q.x[j] - q.x[i]);
    const real_t un = q.radius[i] + q.radius[j] - d.norm();
    if (un <= 0) continue;
    const Vec3 f = kn * un * d.normalized() + pl.shear_spring(k);
    fb += f * d.transpose();
    shear = std::max(shear, pl.shear_spring(k).norm() / (kn * un));
  }
  const Mat3 sigma = fb / sim.cell().volume();
  const MacroState m = sim.macro();
  const real_t err = (m.stress - sigma).cwiseAbs().maxCoeff() / sigma.cwiseAbs().maxCoeff();
  const real_t asym = (sigma - sigma.transpose()).cwiseAbs().maxCoeff() / sigma.cwiseAbs().maxCoeff();
  std::printf(
      "[stress] with shear forces (max |f_s| / f_n = %.2f): rel err %.2e, asymmetric part "
      "%.2e of max |sigma|\n",
      shear, err, asym);
  EXPECT_LT(err, 1e-12);
  EXPECT_GT(shear, 0.05);      // shear forces are a real part of the stress
  EXPECT_GT(m.contacts, 150);  // of the 192 lattice contacts
}

// Unbalanced-force ratio mean |F_particle| / mean |F_contact| with a wall contact: a sphere under
// gravity pressed into a wall to twice its equilibrium overlap carries a contact force 2 m g and
// a resultant m g, so the ratio is 1/2 (relative 1e-9: the overlap is recovered from positions
// near 0.5 m, so it carries a rounding error of about 1e-11). A first version counted wall
// contacts in the mean but not their forces and reported 0.
TEST(Stress, UnbalancedRatioCountsWallContacts) {
  const real_t R = 0.01, m = test::sphere_mass(R), kn = 1e5, g = 9.81;
  const real_t un = 2 * m * g / kn;
  Particles p = test::make_particles({{0, R, test::kRho, Vec3(0.5, 0.5, 0.5 + R - un)}});
  Simulation sim = test::make_sim(std::move(p), test::direct_law(kn, 0.3), 1e-6, 0.1 * R,
                                  {Wall{Vec3(0, 0, 0.5), Vec3::UnitZ(), Vec3::Zero(), false, {}}}, Vec3(0, 0, -g));
  const MacroState ms = sim.macro();
  std::printf("[measures] unbalanced ratio with one wall contact: %.6f (exact 0.5)\n", ms.unbalanced);
  EXPECT_NEAR(ms.unbalanced / 0.5, 1.0, 1e-9);
  EXPECT_EQ(ms.contacts, 0);  // particle-particle contacts only
  EXPECT_NEAR(ms.e_normal / (0.5 * kn * un * un), 1.0, 1e-9);
}

// Affine kinematics of the deforming cell: two touching spheres at rest relative to the affine
// field, branch d along (1,1,0)/sqrt 2, strain rates (e, -e, 0). The affine relative velocity
// edot (.) d = e (d_x, -d_y, 0) is tangential, so after one step the shear spring holds
// -k_s (edot (.) d) dt (relative 1e-6; the normal force only moves the spheres along n).
TEST(Stress, AffineRelativeVelocityLoadsTheShearSpring) {
  const real_t R = 0.01, un = 1e-6, kn = 1e5, e = 2.0, dt = 1e-6;
  const Vec3 n = Vec3(1, 1, 0).normalized();
  const Vec3 c(0.05, 0.05, 0.05);
  Particles p =
      test::make_particles({{0, R, test::kRho, c - (R - 0.5 * un) * n}, {1, R, test::kRho, c + (R - 0.5 * un) * n}});
  SimulationParams sp;
  sp.law = test::direct_law(kn, 10.0);
  sp.skin = 0.1 * R;
  sp.dt = dt;
  Simulation sim(std::move(p), PeriodicCell(Vec3::Constant(0.1)), sp);
  sim.cell().set_strain_rate(Vec3(e, -e, 0));
  sim.step();
  const Particles& q = sim.particles();
  const std::size_t a = test::index_of(q, 0), b = test::index_of(q, 1);
  const Vec3 d = q.x[b] - q.x[a];
  const Vec3 va = Vec3(e, -e, 0).cwiseProduct(d);
  const Vec3 expected = -kn * (va - va.dot(d.normalized()) * d.normalized()) * dt;
  const Vec3 fs = sim.pairs().shear_spring(0);
  std::printf("[kinematics] affine shear increment: |f_s| = %.6e N, expected %.6e N, rel err %.2e\n", fs.norm(),
              expected.norm(), (fs - expected).norm() / expected.norm());
  EXPECT_LT((fs - expected).norm(), 1e-6 * expected.norm());
  EXPECT_GT(expected.norm(), 0.0);
}

}  // namespace
}  // namespace fabrica
