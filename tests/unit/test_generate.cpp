// Specimen generation (docs/verification.md section 13): the fractal gradation against its
// closed-form mass curve and mean diameter; random packings without overlap; the simple cubic
// lattice.
#include "core/generate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>

namespace fabrica {
namespace {

// Mass curve of the truncated, renormalised gradation on [dmin, dmax]:
//   F(d) = (d^(3-D) - dmin^(3-D)) / (dmax^(3-D) - dmin^(3-D)).
// Number density n(d) ~ d^-(D+1): mean diameter
//   <d> = D/(D-1) (dmin^(1-D) - dmax^(1-D)) / (dmin^-D - dmax^-D)  (17.48 mm for 10-60 mm, D 1.9).
// Tolerances with 1e6 draws: |<d> - exact| < 0.5 % (about 10 standard errors), max
// |F_sample - F| < 0.01 (the sample mass curve is dominated by the largest spheres; over six
// seeds at 2e5 draws it reached 0.003-0.008, so about half that here).
TEST(Generate, FractalGradationMassCurve) {
  const real_t D = 1.9, dmin = 0.01, dmax = 0.06;
  Random rng(123);
  const std::size_t n = 1000000;
  std::vector<real_t> d = fractal_diameters(n, D, dmin, dmax, rng);
  EXPECT_GE(*std::min_element(d.begin(), d.end()), dmin);
  EXPECT_LE(*std::max_element(d.begin(), d.end()), dmax);
  const real_t mean = std::accumulate(d.begin(), d.end(), 0.0) / n;
  const real_t mean_exact =
      D / (D - 1) * (std::pow(dmin, 1 - D) - std::pow(dmax, 1 - D)) / (std::pow(dmin, -D) - std::pow(dmax, -D));
  std::sort(d.begin(), d.end());
  real_t mtot = 0;
  for (real_t x : d) mtot += x * x * x;
  auto F = [&](real_t x) {
    return (std::pow(x, 3 - D) - std::pow(dmin, 3 - D)) / (std::pow(dmax, 3 - D) - std::pow(dmin, 3 - D));
  };
  real_t m = 0, ks = 0;
  for (real_t x : d) {
    m += x * x * x;
    ks = std::max(ks, std::abs(m / mtot - F(x)));
  }
  std::printf(
      "[generate] mean diameter %.4f mm (exact %.4f mm, rel err %.2e); max mass-curve "
      "deviation %.4f\n",
      1e3 * mean, 1e3 * mean_exact, mean / mean_exact - 1, ks);
  EXPECT_NEAR(mean / mean_exact, 1.0, 5e-3);
  EXPECT_NEAR(1e3 * mean_exact, 17.48, 0.01);
  EXPECT_LT(ks, 0.01);
}

// Random packing: every sphere inside the cell, no two overlap (minimum image), ids 0..n-1 in
// the order of the diameters given.
TEST(Generate, RandomPackingHasNoOverlap) {
  Random rng(9);
  std::vector<real_t> d = fractal_diameters(500, 1.9, 0.01, 0.06, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  const real_t L = std::cbrt(vs / 0.3);
  const PeriodicCell cell(Vec3(L, 0.8 * L, 1.25 * L));
  const Particles p = random_packing(d, 2650.0, cell, rng);
  ASSERT_EQ(p.size(), d.size());
  real_t worst = 1;
  for (std::size_t a = 0; a < p.size(); ++a) {
    EXPECT_EQ(p.id[a], GlobalId(a));
    EXPECT_DOUBLE_EQ(2 * p.radius[a], d[a]);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p.x[a][k], 0.0);
      EXPECT_LT(p.x[a][k], cell.lengths()[k]);
    }
    for (std::size_t b = a + 1; b < p.size(); ++b)
      worst = std::min(worst, cell.minimum_image(p.x[b] - p.x[a]).norm() / (p.radius[a] + p.radius[b]));
  }
  std::printf("[generate] random packing phi = 0.3: smallest distance / (R_a + R_b) = %.4f\n", worst);
  EXPECT_GE(worst, 1.0);
  EXPECT_NEAR(p.solid_volume() / vs, 1.0, 1e-12);
}

TEST(Generate, SimpleCubicLattice) {
  const Particles p = simple_cubic(3, 0.01, 0.0195, 2650.0);
  ASSERT_EQ(p.size(), 27u);
  EXPECT_TRUE((p.x[0] - Vec3::Constant(0.5 * 0.0195)).isZero(1e-15));
  EXPECT_TRUE((p.x[26] - Vec3::Constant(2.5 * 0.0195)).isZero(1e-15));
  EXPECT_TRUE((p.x[1] - p.x[0] - Vec3(0.0195, 0, 0)).isZero(1e-15));
  EXPECT_NEAR(p.mass[0], 2650.0 * 4.0 / 3.0 * std::numbers::pi * 1e-6, 1e-15);
  EXPECT_NEAR(p.inertia(0), 0.4 * p.mass[0] * 1e-4, 1e-18);
}

}  // namespace
}  // namespace fabrica
