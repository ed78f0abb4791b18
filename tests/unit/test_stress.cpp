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
Simulation lattice(const std::array<int, 3>& n, const Vec3& a, real_t R,
                   const ContactLawParams& law, bool use_generator) {
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

void check_lattice(Simulation& sim, const std::array<int, 3>& n, const Vec3& a, real_t R,
                   real_t kn) {
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
    std::printf("[stress] n = %d %d %d, a = %.4g %.4g %.4g: max |sigma - exact| / sigma = %.2e, "
                "p rel err %.2e, q = %.3e (exact %.3e)\n",
                n[0], n[1], n[2], a[0], a[1], a[2], err, m.p / p_exact - 1, m.q, q_exact);
    EXPECT_LT(err, 1e-10);
    EXPECT_NEAR(m.p / p_exact, 1.0, 1e-10);
    if (q_exact < 1e-8 * p_exact)  // isotropic: q = 0 up to rounding
      EXPECT_LT(m.q, 1e-10 * m.p);
    else
      EXPECT_NEAR(m.q / q_exact, 1.0, 1e-10);
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

}  // namespace
}  // namespace fabrica
