// Coarse-grained fields (core/coarse_grain.hpp, docs/fields.md, docs/verification.md
// "Coarse-grained fields"):
//  - the volume integral (sum over nodes x cell volume) of the contact stress equals the
//    Love-Weber sum f (x) b (relative 1e-12), of the solid fraction the solid volume (1e-12), of
//    each network's contact density its number of contacts (1e-12), with contacts across the
//    periodic faces, for both kernels;
//  - a simple cubic lattice (spacing a, radius a/2) gives the solid fraction pi/6 at every node
//    (1e-6 with a Gaussian of width a cut at 6 widths), its uniform contact stress f a / a^3 per
//    axis (1e-6) and the lattice's fabric (1/3 I, 1e-6); at 3 widths the errors are printed;
//  - a uniform translation velocity gives that velocity (1e-12) and no kinetic stress;
//  - a homogeneous (diagonal) deformation of the periodic cell, particles wrapped across the
//    faces, gives the applied displacement gradient at every node (1e-10 absolute);
//  - the fields do not depend on the order of the particles and contacts, to the bit, nor on
//    reusing a previous result's storage; each network's contact density (summed from the
//    classes of contacts) integrates to its count and the two halves of a partition add up to
//    `all` (1e-12);
//  - unusable grids and kernels are refused with their numbers.
// The rank-count independence is tested in tests/mpi/test_fields_ranks.cpp.
#include "core/coarse_grain.hpp"
#include "core/serial_domain.hpp"
#include "tests/unit/cg_sample.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <utility>

namespace fabrica {
namespace {

using Sample = CgSample;

// The sample in the cell of lengths (0.05, 0.04, 0.06) m (tests/unit/cg_sample.hpp).
Sample sample(std::size_t n, std::uint64_t seed, double reach = 0.0066) {
  return cg_sample(Mat3(Vec3(0.05, 0.04, 0.06).asDiagonal()), n, seed, reach, false);
}

TEST(CoarseGrain, VolumeIntegralsAreLoveWeberAndSolidVolume) {
  const Sample s = sample(600, 5);
  Mat3 lw = Mat3::Zero();
  double solid = 0;
  for (const CgContact& c : s.c) lw += c.rec.force() * c.rec.branch.transpose();
  for (const CgParticle& p : s.p) solid += 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius, 3);
  for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
    FieldGrid grid{{10, 8, 13}, s.L};
    FieldKernel k{type, type == KernelType::Gaussian ? 0.004 : 0.009, 3};
    ASSERT_EQ(check_field_grid(grid, k, 0.001), "");
    SerialDomain d;
    const FieldsResult r = coarse_grain(grid, k, s.p, s.c, {}, d);
    double worst = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const double e = std::abs(volume_integral(r, "contact_stress", 3 * i + j) - lw(i, j)) / lw.norm();
        worst = std::max(worst, e);
        EXPECT_LT(e, 1e-12) << i << j;
      }
    const double es = std::abs(volume_integral(r, "solid_fraction", 0) - solid) / solid;
    EXPECT_LT(es, 1e-12);
    const double en = std::abs(volume_integral(r, "contact_density_all", 0) - double(s.c.size())) / double(s.c.size());
    EXPECT_LT(en, 1e-12);
    double mass = 0;
    for (const CgParticle& p : s.p) mass += p.mass;
    EXPECT_LT(std::abs(volume_integral(r, "density", 0) - mass) / mass, 1e-12);
    std::printf("%zu spheres, %zu contacts, ", s.p.size(), s.c.size());
    std::printf("%s: contact stress integral %.2e, solid volume %.2e, contact count %.2e (relative errors)\n",
                type == KernelType::Gaussian ? "gaussian" : "lucy", worst, es, en);
  }
}

// The simple cubic lattice of m^3 spheres of radius a/2, touching along the axes, with normal
// forces f_a along axis a.
struct Lattice {
  std::vector<CgParticle> p;
  std::vector<CgContact> c;
  Vec3 L;
};
Lattice lattice(int m, double a, const Vec3& f, const Vec3& v0) {
  Lattice l;
  l.L = Vec3::Constant(m * a);
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) {
        CgParticle q;
        q.x = Vec3((i + 0.3) * a, (j + 0.3) * a, (k + 0.3) * a);  // off the grid's nodes
        q.radius = 0.5 * a;
        q.mass = 1.5;
        q.v = v0;
        l.p.push_back(q);
        for (int ax = 0; ax < 3; ++ax) {
          CgContact c;
          c.rec.id1 = GlobalId(l.p.size() - 1), c.rec.id2 = c.rec.id1 + 1;
          c.rec.normal = Vec3::Unit(ax);
          c.rec.branch = a * Vec3::Unit(ax);
          c.rec.fn = f[ax];
          c.x1 = q.x, c.r1 = q.radius;
          l.c.push_back(c);
        }
      }
  return l;
}

TEST(CoarseGrain, SimpleCubicLattice) {
  const double a = 0.002;
  const Vec3 f(3, 2, 1), v0(0.1, -0.2, 0.05);
  const Lattice l = lattice(6, a, f, v0);
  for (double cutoff : {3.0, 6.0}) {
    FieldGrid grid{{13, 13, 13}, l.L};  // h = 0.92 a: incommensurate with the lattice
    FieldKernel k{KernelType::Gaussian, a, cutoff};
    ASSERT_EQ(check_field_grid(grid, k, 0.5 * a), "");
    SerialDomain d;
    const FieldsResult r = coarse_grain(grid, k, l.p, l.c, {}, d);
    double ephi = 0, esig = 0, efab = 0, evel = 0, ekin = 0;
    const Field &phi = r.field("solid_fraction"), &sig = r.field("contact_stress"), &fab = r.field("fabric_all"),
                &vel = r.field("velocity"), &kin = r.field("kinetic_stress");
    for (std::size_t g = 0; g < grid.nodes(); ++g) {
      ephi = std::max(ephi, std::abs(phi.values[g] / (std::numbers::pi / 6) - 1));
      for (int i = 0; i < 3; ++i) {
        esig = std::max(esig, std::abs(sig.values[9 * g + 4 * i] / (f[i] / (a * a)) - 1));
        efab = std::max(efab, std::abs(fab.values[9 * g + 4 * i] - 1.0 / 3));
        evel = std::max(evel, std::abs(vel.values[3 * g + i] - v0[i]) / v0.norm());
      }
      for (int k2 = 0; k2 < 9; ++k2) ekin = std::max(ekin, std::abs(kin.values[9 * g + k2]));
    }
    std::printf(
        "cut-off %.0f widths: solid fraction %.2e, contact stress %.2e, fabric %.2e, velocity %.2e "
        "(relative), kinetic stress %.2e Pa\n",
        cutoff, ephi, esig, efab, evel, ekin);
    if (cutoff == 6.0) {
      EXPECT_LT(ephi, 1e-6);
      EXPECT_LT(esig, 1e-6);
      EXPECT_LT(efab, 1e-6);
    }
    EXPECT_LT(evel, 1e-12);
    EXPECT_LT(ekin, 1e-10 * 1.5 * v0.squaredNorm() / (a * a * a));
  }
}

TEST(CoarseGrain, AffineDeformationGivesItsDisplacementGradient) {
  const Vec3 L0(0.05, 0.04, 0.06), eps(-0.01, 0.004, 0.006);
  const Vec3 L1 = L0.cwiseProduct(Vec3::Ones() + eps);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<CgMotion> m(1500);
  for (CgMotion& q : m) {
    q.x0 = Vec3(u(rng) * L0[0], u(rng) * L0[1], u(rng) * L0[2]);
    q.radius = 0.001;
    const Vec3 s = q.x0.cwiseQuotient(L0);
    // The same scaled position in the deformed cell, at a random image, then wrapped back.
    Vec3 x1 = s.cwiseProduct(L1);
    for (int a = 0; a < 3; ++a) {
      x1[a] += std::floor(3 * u(rng) - 1) * L1[a];
      x1[a] -= L1[a] * std::floor(x1[a] / L1[a]);
    }
    q.x1 = x1;
  }
  for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
    FieldGrid grid{{9, 7, 11}, L0};
    FieldKernel k{type, type == KernelType::Gaussian ? 0.005 : 0.012, 3};
    ASSERT_EQ(check_field_grid(grid, k, 0.001), "");
    SerialDomain d;
    const FieldsResult r = displacement_fields(grid, k, L1, m, d);
    const Field& G = r.field("displacement_gradient");
    const Field& E = r.field("strain_increment");
    double worst = 0;
    for (std::size_t g = 0; g < grid.nodes(); ++g)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const double want = i == j ? eps[i] : 0.0;
          worst = std::max(worst, std::abs(G.values[9 * g + 3 * i + j] - want));
          worst = std::max(worst, std::abs(E.values[9 * g + 3 * i + j] - want));
        }
    std::printf("%s: displacement gradient of a homogeneous deformation, largest error %.2e\n",
                type == KernelType::Gaussian ? "gaussian" : "lucy", worst);
    EXPECT_LT(worst, 1e-10);
  }
}

TEST(CoarseGrain, IndependentOfTheOrderToTheBit) {
  Sample s = sample(400, 9);
  FieldGrid grid{{7, 6, 9}, s.L};
  FieldKernel k{KernelType::Gaussian, 0.004, 3};
  SerialDomain d;
  const FieldsResult r1 = coarse_grain(grid, k, s.p, s.c, {}, d);
  std::mt19937_64 rng(1);
  std::shuffle(s.p.begin(), s.p.end(), rng);
  std::shuffle(s.c.begin(), s.c.end(), rng);
  const FieldsResult r2 = coarse_grain(grid, k, s.p, s.c, {}, d);
  ASSERT_EQ(r1.fields.size(), r2.fields.size());
  for (std::size_t f = 0; f < r1.fields.size(); ++f)
    for (std::size_t i = 0; i < r1.fields[f].values.size(); ++i) {
      const double a = r1.fields[f].values[i], b = r2.fields[f].values[i];
      ASSERT_TRUE(std::memcmp(&a, &b, sizeof a) == 0) << r1.fields[f].name << " " << i << ": " << a << " " << b;
    }
}

// The storage of a previous result (another grid) reused: the same bits, the previous fields
// emptied. Each network's sums come from its classes of contacts (sliding, rolling, strong):
// every network's contact density integrates to its number of contacts, and the two networks
// of each two-way partition add up to `all`.
TEST(CoarseGrain, RecycledStorageAndNetworksFromClasses) {
  const Sample s = sample(400, 11);
  FieldGrid grid{{7, 6, 9}, s.L};
  FieldKernel k{KernelType::Gaussian, 0.004, 3};
  SerialDomain d;
  const FieldsResult r1 = coarse_grain(grid, k, s.p, s.c, {}, d);
  FieldsResult spare = coarse_grain({{9, 9, 9}, s.L}, k, s.p, s.c, {}, d);
  const FieldsResult r2 = coarse_grain(grid, k, s.p, s.c, {}, d, &spare);
  ASSERT_EQ(r1.fields.size(), r2.fields.size());
  for (std::size_t f = 0; f < r1.fields.size(); ++f) {
    EXPECT_TRUE(spare.fields[f].values.empty()) << spare.fields[f].name;
    ASSERT_EQ(r1.fields[f].values.size(), r2.fields[f].values.size());
    for (std::size_t i = 0; i < r1.fields[f].values.size(); ++i) {
      const double a = r1.fields[f].values[i], b = r2.fields[f].values[i];
      ASSERT_TRUE(std::memcmp(&a, &b, sizeof a) == 0) << r1.fields[f].name << " " << i << ": " << a << " " << b;
    }
  }
  std::array<double, kNetworks> count{};
  for (const CgContact& c : s.c)
    for (int net : contact_networks(c.rec, r1.strong_threshold)) count[std::size_t(net)] += 1;
  double worst = 0;
  for (int net = 0; net < kNetworks; ++net) {
    const std::string name = "contact_density_" + std::string(kNetworkNames[std::size_t(net)]);
    worst = std::max(worst, std::abs(volume_integral(r1, name, 0) - count[std::size_t(net)]) / double(s.c.size()));
  }
  const Field& all = r1.field("contact_density_all");
  for (const auto& [a, b] : {std::pair{"ns", "s"}, {"nr", "r"}, {"sf", "wf"}}) {
    const Field &fa = r1.field(std::string("contact_density_") + a),
                &fb = r1.field(std::string("contact_density_") + b);
    for (std::size_t g = 0; g < all.values.size(); ++g)
      if (all.values[g] > 0)
        worst = std::max(worst, std::abs(fa.values[g] + fb.values[g] - all.values[g]) / all.values[g]);
  }
  std::printf("%zu contacts: networks' counts and partitions, largest relative error %.2e\n", s.c.size(), worst);
  EXPECT_LT(worst, 1e-12);
  EXPECT_GT(count[kS], 0.0);
  EXPECT_GT(count[kSR], 0.0);
}

TEST(CoarseGrain, UnusableGridsAreRefused) {
  const Vec3 L(0.05, 0.04, 0.06);
  EXPECT_NE(check_field_grid({{0, 4, 4}, L}, {KernelType::Gaussian, 0.01, 3}, 0.001).find("at least 1 node"),
            std::string::npos);
  EXPECT_NE(check_field_grid({{8, 8, 8}, L}, {KernelType::Gaussian, 0.0005, 3}, 0.001)
                .find("kernel width 0.0005 m is below the smallest sphere radius 0.001 m"),
            std::string::npos);
  EXPECT_NE(check_field_grid({{2, 2, 2}, L}, {KernelType::Lucy, 0.002, 3}, 0.001).find("support radius 0.002 m"),
            std::string::npos);
  EXPECT_NE(check_field_grid({{8, 8, 8}, L}, {KernelType::Gaussian, 0.01, 0.5}, 0.001).find("cut-off 0.5"),
            std::string::npos);
  EXPECT_EQ(check_field_grid({{8, 8, 8}, L}, {KernelType::Gaussian, 0.005, 3}, 0.001), "");
}

}  // namespace
}  // namespace fabrica
