// The localisation index (core/localisation.hpp, docs/fields.md "Shear bands") on fields whose
// index is known by hand:
//  - gamma = sqrt(2 e':e') of a pure shear e01 = e10 = g/2 plus any isotropic part is |g|
//    (1e-15 relative);
//  - a homogeneous increment gives 0.1 (1e-12) on 60 nodes, and on 25 nodes 3/25 (the tenth is
//    ceil(25/10) = 3 nodes);
//  - one tenth of 60 nodes at 10, the rest at 1: 10/19 (1e-12), in any order of the nodes (the
//    same bits);
//  - gamma = 1, 2, ..., 25 on 25 nodes: (25 + 24 + 23) / 325 (1e-12); with 5 of them NaN (nodes
//    out of reach) the 20 finite ones count: 2 nodes; with 21 finite ones, 3 (rounded up);
//  - no finite node, or no shear at all: NaN.
#include "core/localisation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace fabrica {
namespace {

// A strain increment of pure shear of engineering strain g in the 1-2 plane, plus 'iso' on the
// diagonal (no deviator): gamma = |g|.
void shear(std::vector<double>& e, double g, double iso = 0) {
  const double v[9] = {iso, 0.5 * g, 0, 0.5 * g, iso, 0, 0, 0, iso};
  e.insert(e.end(), v, v + 9);
}

std::vector<double> field(const std::vector<double>& gamma) {
  std::vector<double> e;
  for (double g : gamma) shear(e, g, 1e-3 * g);
  return e;
}

TEST(Localisation, ShearIntensityOfAPureShear) {
  std::vector<double> e;
  shear(e, -0.0123, 0.004);
  const double g = shear_intensity(e.data());
  std::printf("gamma of a pure shear 0.0123 plus an isotropic 0.004: %.17g\n", g);
  EXPECT_NEAR(g, 0.0123, 1e-15 * 0.0123);
  // A uniaxial increment diag(a, 0, 0): e' = a diag(2, -1, -1)/3, gamma = sqrt(2 * 6 a^2 / 9).
  const double a = 0.003, u[9] = {a, 0, 0, 0, 0, 0, 0, 0, 0};
  EXPECT_NEAR(shear_intensity(u), std::sqrt(12.0 / 9.0) * a, 1e-15 * a);
}

TEST(Localisation, HomogeneousIsOneTenth) {
  const double i60 = localisation_index(field(std::vector<double>(60, 0.002)));
  const double i25 = localisation_index(field(std::vector<double>(25, 0.002)));
  std::printf("homogeneous: index %.17g on 60 nodes, %.17g on 25 nodes (3 of them the tenth)\n", i60, i25);
  EXPECT_NEAR(i60, 0.1, 1e-12);
  EXPECT_NEAR(i25, 3.0 / 25.0, 1e-12);
}

TEST(Localisation, PlantedTenth) {
  std::vector<double> g(60, 1.0);
  for (int k = 0; k < 6; ++k) g[std::size_t(10 * k + 3)] = 10.0;
  const double index = localisation_index(field(g));
  std::printf("one tenth at 10, the rest at 1: index %.17g, 10/19 = %.17g\n", index, 10.0 / 19.0);
  EXPECT_NEAR(index, 10.0 / 19.0, 1e-12);
  std::mt19937 rng(7);
  std::shuffle(g.begin(), g.end(), rng);
  const double shuffled = localisation_index(field(g));
  EXPECT_EQ(std::memcmp(&index, &shuffled, sizeof index), 0) << "the order of the nodes changed the bits";
}

TEST(Localisation, TheTenthIsCountedUp) {
  std::vector<double> g;
  for (int k = 1; k <= 25; ++k) g.push_back(0.001 * k);
  const double index = localisation_index(field(g));
  std::printf("gamma 1..25 (x 1e-3): index %.17g, (25 + 24 + 23) / 325 = %.17g\n", index, 72.0 / 325.0);
  EXPECT_NEAR(index, 72.0 / 325.0, 1e-12);
  // Five nodes out of reach (NaN, the largest five among them): 20 finite nodes, a tenth of 2.
  std::vector<double> e = field(g);
  for (int k = 20; k < 25; ++k) e[std::size_t(9 * k + 1)] = std::numeric_limits<double>::quiet_NaN();
  const double finite = localisation_index(e);
  EXPECT_NEAR(finite, (20.0 + 19.0) / 210.0, 1e-12) << finite;
  // 21 finite nodes: the tenth is rounded up to 3 nodes, not down to 2.
  e = field(g);
  for (int k = 21; k < 25; ++k) e[std::size_t(9 * k + 1)] = std::numeric_limits<double>::quiet_NaN();
  const double up = localisation_index(e);
  EXPECT_NEAR(up, (21.0 + 20.0 + 19.0) / 231.0, 1e-12) << up;
}

TEST(Localisation, NothingToMeasureIsNaN) {
  EXPECT_TRUE(std::isnan(localisation_index({})));
  std::vector<double> e(27, std::numeric_limits<double>::quiet_NaN());
  EXPECT_TRUE(std::isnan(localisation_index(e)));
  std::vector<double> iso;
  for (int k = 0; k < 10; ++k) shear(iso, 0.0, 0.002);  // an isotropic increment: no shear
  EXPECT_TRUE(std::isnan(localisation_index(iso)));
}

}  // namespace
}  // namespace fabrica
