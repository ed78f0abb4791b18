// Coarse-grained fields on a sheared periodic cell (core/coarse_grain.hpp, docs/fields.md "A
// sheared cell": the grid in fractional coordinates of the cell matrix H):
//  - the grid: node (i, j, k) at H ((i + 1/2) / n), node volume |det H| / N, positions wrapped
//    into the parallelepiped; a diagonal matrix makes an orthorhombic grid (the same bits);
//  - the volume integral of the contact stress and of the stress equals the Love-Weber sum
//    (relative 1e-12), of the solid fraction the solid volume, of the density the mass, of each
//    network's contact density its count, with contacts across the slanted faces, both kernels;
//  - a homogeneous simple shear u = G x (G_xz != 0) between two sheared cells gives G at every
//    node to 1e-12, also across a flip of the cell's edges between the instants (H1 = F H0 M)
//    and from an orthorhombic cell to a sheared one; a deformation too large to tell a flip from
//    is refused;
//  - the grid check names the longest diagonal of a slanted grid cell.
// The rank-count independence on a sheared cell: tests/mpi/test_fields_ranks.cpp.
#include "core/cell.hpp"
#include "core/coarse_grain.hpp"
#include "core/serial_domain.hpp"
#include "tests/unit/cg_sample.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

namespace fabrica {
namespace {

// A cell tilted in xz (0.45 of Lz along x), xy and yz.
Mat3 tilted() {
  Mat3 H;
  H << 0.05, 0.008, 0.027, 0, 0.04, -0.006, 0, 0, 0.06;
  return H;
}

// The sample in the cell H (tests/unit/cg_sample.hpp), body 1 of each contact at any image.
CgSample sample(const Mat3& H, std::size_t n, std::uint64_t seed, double reach = 0.0066) {
  return cg_sample(H, n, seed, reach, true);
}

FieldGrid grid_of(const Mat3& H, std::array<int, 3> n) {
  FieldGrid g;
  g.n = n;
  g.set_matrix(H);
  return g;
}

TEST(CoarseGrainSheared, GridInFractionalCoordinates) {
  const Mat3 H = tilted();
  const FieldGrid g = grid_of(H, {10, 8, 12});
  ASSERT_TRUE(g.sheared);
  EXPECT_LT((g.node(3, 2, 7) - H * Vec3(3.5 / 10, 2.5 / 8, 7.5 / 12)).norm(), 1e-17);
  EXPECT_DOUBLE_EQ(g.cell_volume() * double(g.nodes()), H.determinant());
  // A matrix with terms below the diagonal too (the product of its diagonal is not its volume).
  Mat3 Hg = H;
  Hg(2, 0) = 0.012, Hg(1, 0) = -0.007;
  const FieldGrid gg = grid_of(Hg, {10, 8, 12});
  EXPECT_GT(std::abs(Hg.diagonal().prod() - Hg.determinant()), 1e-3 * Hg.determinant());
  EXPECT_NEAR(gg.cell_volume() * double(gg.nodes()), std::abs(Hg.determinant()), 1e-15 * Hg.determinant());
  const Vec3 x = H * Vec3(1.25, -0.5, 2.75);
  EXPECT_LT((g.wrap(x) - H * Vec3(0.25, 0.5, 0.75)).norm(), 1e-16);
  EXPECT_NEAR(g.layer_coordinate(x), 0.75, 1e-14);
  // A diagonal matrix: the orthorhombic grid.
  const FieldGrid d = grid_of(Mat3(Vec3(0.05, 0.04, 0.06).asDiagonal()), {10, 8, 12});
  EXPECT_FALSE(d.sheared);
  EXPECT_EQ(d.lengths, Vec3(0.05, 0.04, 0.06));
}

TEST(CoarseGrainSheared, VolumeIntegralsAreLoveWeberAndSolidVolume) {
  const Mat3 H = tilted();
  const CgSample s = sample(H, 600, 5);
  Mat3 lw = Mat3::Zero();
  double solid = 0, mass = 0;
  for (const CgContact& c : s.c) lw += c.rec.force() * c.rec.branch.transpose();
  for (const CgParticle& p : s.p) solid += 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius, 3), mass += p.mass;
  for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
    const FieldGrid grid = grid_of(H, {10, 8, 13});
    const FieldKernel k{type, type == KernelType::Gaussian ? 0.004 : 0.009, 3};
    ASSERT_EQ(check_field_grid(grid, k, 0.001), "");
    SerialDomain d;
    const FieldsResult r = coarse_grain(grid, k, s.p, s.c, {}, d);
    double worst = 0;
    for (const char* name : {"contact_stress", "stress"}) {
      Mat3 kin = Mat3::Zero();
      if (std::string(name) == "stress")
        for (int q = 0; q < 9; ++q) kin(q / 3, q % 3) = volume_integral(r, "kinetic_stress", q);
      for (int q = 0; q < 9; ++q) {
        const double e = std::abs(volume_integral(r, name, q) - lw(q / 3, q % 3) - kin(q / 3, q % 3)) / lw.norm();
        worst = std::max(worst, e);
        EXPECT_LT(e, 1e-12) << name << " " << q;
      }
    }
    const double es = std::abs(volume_integral(r, "solid_fraction", 0) - solid) / solid;
    const double en = std::abs(volume_integral(r, "contact_density_all", 0) - double(s.c.size())) / double(s.c.size());
    EXPECT_LT(es, 1e-12);
    EXPECT_LT(en, 1e-12);
    EXPECT_LT(std::abs(volume_integral(r, "density", 0) - mass) / mass, 1e-12);
    std::printf(
        "sheared cell, %zu spheres, %zu contacts, %s: stress integral %.2e, solid volume %.2e, contact count "
        "%.2e (relative errors)\n",
        s.p.size(), s.c.size(), type == KernelType::Gaussian ? "gaussian" : "lucy", worst, es, en);
  }
}

// Particles at x0 = H0 s in the cell H0, moved by the homogeneous F to F x0, then written at a
// random image of the cell H1 (a lattice vector H1 m added).
std::vector<CgMotion> homogeneous(const Mat3& H0, const Mat3& F, const Mat3& H1, std::size_t n) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<CgMotion> m(n);
  for (CgMotion& q : m) {
    q.x0 = H0 * Vec3(u(rng), u(rng), u(rng));
    q.radius = 0.001;
    const Vec3 img(std::floor(3 * u(rng)) - 1, std::floor(3 * u(rng)) - 1, std::floor(3 * u(rng)) - 1);
    q.x1 = F * q.x0 + H1 * img;
  }
  return m;
}

double gradient_error(const FieldsResult& r, const Mat3& G) {
  const Field &grad = r.field("displacement_gradient"), &E = r.field("strain_increment");
  const Mat3 S = 0.5 * (G + G.transpose());
  double worst = 0;
  for (std::size_t g = 0; g < r.grid.nodes(); ++g)
    for (int q = 0; q < 9; ++q) {
      worst = std::max(worst, std::abs(grad.values[9 * g + std::size_t(q)] - G(q / 3, q % 3)));
      worst = std::max(worst, std::abs(E.values[9 * g + std::size_t(q)] - S(q / 3, q % 3)));
    }
  return worst;
}

TEST(CoarseGrainSheared, SimpleShearGivesItsGradientAcrossAFlip) {
  Mat3 G = Mat3::Zero();
  G(0, 2) = 0.08;  // simple shear du_x/dz, with a small stretch along y
  G(1, 1) = 0.003;
  const Mat3 F = Mat3::Identity() + G;
  Mat3 H0 = tilted();
  H0(0, 2) = 0.034;  // 0.57 of Lz: F H0 leans past the flip ratio 0.6
  Mat3 M = Mat3::Identity();
  M(0, 2) = -1;  // the flip: edge 3 minus edge 1
  const Mat3 L0 = Mat3(Vec3(0.05, 0.04, 0.06).asDiagonal());
  struct Case {
    const char* what;
    Mat3 H0, H1;
  };
  const Case cases[] = {{"sheared, no flip", H0, F * H0},
                        {"sheared, a flip between the instants", H0, F * H0 * M},
                        {"orthorhombic to sheared", L0, F * L0}};
  for (const Case& c : cases)
    for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
      const FieldGrid grid = grid_of(c.H0, {9, 7, 11});
      const FieldKernel k{type, type == KernelType::Gaussian ? 0.005 : 0.012, 3};
      ASSERT_EQ(check_field_grid(grid, k, 0.001), "");
      SerialDomain d;
      const FieldsResult r = displacement_fields(grid, k, c.H1, homogeneous(c.H0, F, c.H1, 1500), d);
      const double worst = gradient_error(r, G);
      std::printf("%s, %s: displacement gradient of a simple shear, largest error %.2e\n", c.what,
                  type == KernelType::Gaussian ? "gaussian" : "lucy", worst);
      EXPECT_LT(worst, 1e-12) << c.what;
    }
  // The edges recovered: F H0 from F H0 M.
  EXPECT_LT((deformed_reference_edges(H0, F * H0 * M) - F * H0).norm(), 1e-15);
}

TEST(CoarseGrainSheared, DeformationTooLargeForAFlipIsRefused) {
  const Mat3 H0 = tilted();
  Mat3 F = Mat3::Identity();
  F(0, 2) = 0.4;  // 0.4 Lz / Lx = 0.48 of an edge in fractional terms
  try {
    deformed_reference_edges(H0, F * H0);
    ADD_FAILURE() << "not refused";
  } catch (const std::domain_error& e) {
    EXPECT_NE(std::string(e.what()).find("the cell deformed too much between the two instants"), std::string::npos)
        << e.what();
  }
}

TEST(CoarseGrainSheared, GridCheckNamesTheLongestDiagonal) {
  const FieldGrid grid = grid_of(tilted(), {5, 4, 6});
  const std::string why = check_field_grid(grid, {KernelType::Lucy, 0.009, 3}, 0.001);
  EXPECT_NE(why.find("half the longest diagonal of a grid cell, a parallelepiped, is"), std::string::npos) << why;
  EXPECT_GT(grid.half_diagonal(), 0.5 * Vec3(0.01, 0.01, 0.01).norm());
}

}  // namespace
}  // namespace fabrica
