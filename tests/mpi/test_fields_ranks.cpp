// The coarse-grained fields (core/coarse_grain.hpp) do not depend on the number of ranks: 3,000
// spheres and about 9,000 contacts (many across the periodic faces) are dealt out over the ranks
// irregularly (item i to rank (i * 7919) mod P, each rank's items in reverse order) and
// coarse-grained through MpiDomain, with both kernels; every value of every field, and of the
// displacement fields of a deformation with random fluctuations, must equal the serial result
// (SerialDomain, all items in order) bit for bit. Then the grid shared over the ranks
// (core/grid_exchange.hpp, MpiGridExchange): each rank's layers of every field equal the serial
// fields' layers bit for bit, and with the items dealt by the layer they lie in each rank's sums
// cover fewer nodes than the grid. The same on a sheared cell (a grid in fractional coordinates,
// z-layers of s3; displacements across a flip of the cell's edges), shared or not. Registered at
// 1, 2, 4, 8 and 16 ranks.
#include "core/coarse_grain.hpp"
#include "core/serial_domain.hpp"
#include "parallel/mpi_domain.hpp"
#include "parallel/mpi_grid_exchange.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

using namespace fabrica;

namespace {

const Vec3 kL(0.05, 0.04, 0.06);

struct Sample {
  std::vector<CgParticle> p;
  std::vector<CgContact> c;
  std::vector<CgMotion> m;
};

Sample sample(std::size_t n) {
  Sample s;
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g;
  for (std::size_t i = 0; i < n; ++i) {
    CgParticle q;
    q.x = Vec3(u(rng) * kL[0], u(rng) * kL[1], u(rng) * kL[2]);
    q.radius = 0.001 + 0.001 * u(rng);
    q.mass = 2650 * 4.0 / 3.0 * std::numbers::pi * std::pow(q.radius, 3);
    q.v = Vec3(g(rng), g(rng), g(rng)) * 0.01;
    q.w = Vec3(g(rng), g(rng), g(rng));
    s.p.push_back(q);
    CgMotion m;
    m.x0 = q.x, m.radius = q.radius;
    m.x1 = q.x.cwiseProduct(Vec3(0.99, 1.003, 1.004)) + 1e-4 * Vec3(g(rng), g(rng), g(rng));
    s.m.push_back(m);
  }
  PeriodicCell cell(kL);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      CgContact c;
      c.rec.id1 = GlobalId(i), c.rec.id2 = GlobalId(j);
      const CgParticle& a = s.p[i];
      c.rec.branch = cell.minimum_image(s.p[j].x - a.x);
      if (c.rec.branch.norm() > 0.00385) continue;  // about 3 contacts a sphere
      c.rec.normal = c.rec.branch.normalized();
      c.rec.fn = 10 * u(rng) * u(rng);
      Vec3 tt(g(rng), g(rng), g(rng));
      tt -= tt.dot(c.rec.normal) * c.rec.normal;
      c.rec.ft = 0.4 * c.rec.fn * u(rng) * tt.normalized();
      c.rec.sliding = u(rng) < 0.3, c.rec.rolling = u(rng) < 0.5;
      c.x1 = a.x, c.r1 = a.radius;
      s.c.push_back(c);
    }
  return s;
}

template <class T>
std::vector<T> deal(const std::vector<T>& all, int rank, int size) {
  std::vector<T> mine;
  for (std::size_t i = all.size(); i-- > 0;)
    if (int((i * 7919) % std::size_t(size)) == rank) mine.push_back(all[i]);
  return mine;
}

std::size_t differing(const FieldsResult& a, const FieldsResult& b, std::size_t& values) {
  std::size_t differ = 0;
  EXPECT_EQ(a.fields.size(), b.fields.size());
  for (std::size_t f = 0; f < a.fields.size() && f < b.fields.size(); ++f) {
    EXPECT_EQ(a.fields[f].values.size(), b.fields[f].values.size());
    for (std::size_t i = 0; i < a.fields[f].values.size(); ++i, ++values)
      differ += std::memcmp(&a.fields[f].values[i], &b.fields[f].values[i], sizeof(double)) != 0;
  }
  return differ;
}

// Values differing between a's layers (a shared result) and the same layers of b (the whole grid).
std::size_t differing_layers(const FieldsResult& a, const FieldsResult& b, std::size_t& values) {
  std::size_t differ = 0;
  EXPECT_EQ(a.fields.size(), b.fields.size());
  const std::size_t layer = std::size_t(a.grid.n[0]) * std::size_t(a.grid.n[1]);
  for (std::size_t f = 0; f < a.fields.size() && f < b.fields.size(); ++f) {
    const std::size_t c = std::size_t(a.fields[f].components), first = std::size_t(a.layers.first) * layer * c;
    EXPECT_EQ(a.fields[f].values.size(), std::size_t(a.layers.end - a.layers.first) * layer * c);
    for (std::size_t i = 0; i < a.fields[f].values.size(); ++i, ++values)
      differ += std::memcmp(&a.fields[f].values[i], &b.fields[f].values[first + i], sizeof(double)) != 0;
  }
  return differ;
}

// The items whose point (a particle's centre, body 1's centre, a motion's first position) lies in
// this rank's layers of a grid of nz layers.
template <class T, class Point>
std::vector<T> deal_by_layer(const std::vector<T>& all, int rank, int size, int nz, Point point) {
  std::vector<T> mine;
  for (const T& x : all) {
    const double z = point(x)[2] / kL[2];
    const int k = std::clamp(int((z - std::floor(z)) * nz), 0, nz - 1);
    const Layers L = slab_of(nz, rank, size);
    if (k >= L.first && k < L.end) mine.push_back(x);
  }
  return mine;
}

// The sample in a sheared cell H (fractional coordinates of kL mapped through H), contacts to
// the nearest image, motions a simple shear F with fluctuations written in the flipped edges
// F H M.
Sample sheared_sample(const Mat3& H, const Mat3& F, const Mat3& M) {
  Sample s = sample(3000);
  const PeriodicCell cell = PeriodicCell::from_matrix(H);
  const Mat3 S = H * Mat3(kL.cwiseInverse().asDiagonal());
  std::mt19937_64 rng(29);
  std::normal_distribution<double> g;
  for (std::size_t i = 0; i < s.p.size(); ++i) {
    s.p[i].x = S * s.p[i].x;
    s.m[i].x0 = s.p[i].x;
    s.m[i].x1 = F * s.p[i].x + 1e-4 * Vec3(g(rng), g(rng), g(rng)) + F * H * M * Vec3(double(i % 3) - 1, 0, 1);
  }
  for (CgContact& c : s.c) {
    c.x1 = S * c.x1;
    c.rec.branch = cell.minimum_image(s.p[std::size_t(c.rec.id2)].x - c.x1);
    c.rec.normal = c.rec.branch.normalized();
  }
  return s;
}

std::vector<CgParticle> layer_deal(const std::vector<CgParticle>& all, const FieldGrid& g, int rank, int size) {
  std::vector<CgParticle> mine;
  const Layers L = slab_of(g.n[2], rank, size);
  for (const CgParticle& q : all) {
    const int k = std::clamp(int(g.layer_coordinate(q.x) * g.n[2]), 0, g.n[2] - 1);
    if (k >= L.first && k < L.end) mine.push_back(q);
  }
  return mine;
}

}  // namespace

TEST(FieldsRanks, ShearedCellSameBitsSharedOrNot) {
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  Mat3 H = Mat3(kL.asDiagonal()), F = Mat3::Identity(), M = Mat3::Identity();
  H(0, 2) = 0.028, H(0, 1) = -0.006;  // tilts of 0.56 and 0.15 of the edges
  F(0, 2) = 0.02, M(0, 2) = -1;
  const Sample all = sheared_sample(H, F, M);
  FieldGrid grid;
  grid.n = {10, 8, 24};
  grid.set_matrix(H);
  const std::vector<CgParticle> p = layer_deal(all.p, grid, rank, size);
  const std::vector<CgContact> c = deal(all.c, rank, size);
  const std::vector<CgMotion> m = deal(all.m, rank, size);
  for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
    const FieldKernel k{type, type == KernelType::Gaussian ? 0.003 : 0.008, 3};
    ASSERT_EQ(check_field_grid(grid, k, 0.001), "");
    MpiDomain domain(MPI_COMM_WORLD);
    MpiGridExchange exchange(MPI_COMM_WORLD);
    SerialDomain serial;
    const Mat3 H1 = F * H * M;
    const FieldsResult ser = coarse_grain(grid, k, all.p, all.c, {}, serial);
    const FieldsResult dser = displacement_fields(grid, k, H1, all.m, serial);
    const FieldsResult par = coarse_grain(grid, k, p, c, {}, domain);
    const FieldsResult dpar = displacement_fields(grid, k, H1, m, domain);
    const FieldsResult spar = coarse_grain(grid, k, p, c, {}, domain, nullptr, &exchange);
    const FieldsResult sdpar = displacement_fields(grid, k, H1, m, domain, nullptr, &exchange);
    std::size_t values = 0, svalues = 0;
    const std::size_t differ = differing(par, ser, values) + differing(dpar, dser, values);
    const std::size_t sdiffer = differing_layers(spar, ser, svalues) + differing_layers(sdpar, dser, svalues);
    EXPECT_EQ(differ, 0u) << "of " << values;
    EXPECT_EQ(sdiffer, 0u) << "of " << svalues;
    // The simple shear is recovered away from the fluctuations: G_xz near F_xz - 1 = 0.02.
    const Field& G = dser.field("displacement_gradient");
    double mean = 0;
    for (std::size_t n = 0; n < grid.nodes(); ++n) mean += G.values[9 * n + 2] / double(grid.nodes());
    EXPECT_NEAR(mean, 0.02, 2e-3);
    if (rank == 0)
      std::printf(
          "[fields sheared] %s, %d rank(s): %zu values (whole grid) and %zu (rank 0's layers), %zu and %zu differ "
          "from the serial fields (bitwise); mean G_xz %.5f (simple shear 0.02)\n",
          type == KernelType::Gaussian ? "gaussian" : "lucy", size, values, svalues, differ, sdiffer, mean);
  }
}

TEST(FieldsRanks, SharedGridHoldsAShareWithTheSameBits) {
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const Sample all = sample(3000);
  const FieldGrid grid{{10, 8, 24}, kL};  // 24 layers, much more than the kernels' reach of 4
  for (bool by_layer : {true, false})
    for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
      const std::vector<CgParticle> p = by_layer
          ? deal_by_layer(all.p, rank, size, 24, [](const CgParticle& q) { return q.x; })
          : deal(all.p, rank, size);
      const std::vector<CgContact> c = by_layer
          ? deal_by_layer(all.c, rank, size, 24, [](const CgContact& q) { return q.x1; })
          : deal(all.c, rank, size);
      const std::vector<CgMotion> m = by_layer
          ? deal_by_layer(all.m, rank, size, 24, [](const CgMotion& q) { return q.x0; })
          : deal(all.m, rank, size);
      const FieldKernel k{type, type == KernelType::Gaussian ? 0.003 : 0.008, 3};
      MpiDomain domain(MPI_COMM_WORLD);
      MpiGridExchange exchange(MPI_COMM_WORLD);
      SerialDomain serial;
      const Vec3 L1 = kL.cwiseProduct(Vec3(0.99, 1.003, 1.004));
      const FieldsResult par = coarse_grain(grid, k, p, c, {}, domain, nullptr, &exchange);
      const FieldsResult ser = coarse_grain(grid, k, all.p, all.c, {}, serial);
      const FieldsResult dpar = displacement_fields(grid, k, L1, m, domain, nullptr, &exchange);
      const FieldsResult dser = displacement_fields(grid, k, L1, all.m, serial);
      const Layers L = size == 1 ? Layers{0, 24} : slab_of(24, rank, size);
      EXPECT_EQ(par.layers.first, L.first);
      EXPECT_EQ(par.layers.end, L.end);
      std::size_t values = 0;
      const std::size_t differ = differing_layers(par, ser, values) + differing_layers(dpar, dser, values);
      EXPECT_EQ(differ, 0u) << "of " << values;
      // Dealt by layers, a rank's sums cover its layers and the kernel's reach: on 4 ranks or more
      // (slabs of 6 layers or fewer, the reach about 6 on either side), a share.
      if (by_layer && size >= 4) {
        EXPECT_LT(par.sum_nodes, grid.nodes());
        EXPECT_LT(dpar.sum_nodes, grid.nodes());
      }
      std::size_t most = par.sum_nodes;
      MPI_Allreduce(MPI_IN_PLACE, &most, 1, MPI_UNSIGNED_LONG, MPI_MAX, MPI_COMM_WORLD);
      if (rank == 0)
        std::printf(
            "[fields shared] %s, items dealt %s, %d rank(s): at most %zu of the %zu nodes summed on a rank, "
            "%zu values of rank 0's layers, %zu differ from the serial fields (bitwise)\n",
            type == KernelType::Gaussian ? "gaussian" : "lucy", by_layer ? "by layer" : "irregularly", size, most,
            grid.nodes(), values, differ);
    }
}

TEST(FieldsRanks, SameFieldsBitForBitOnAnyRankCount) {
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const Sample all = sample(3000);
  const std::vector<CgParticle> p = deal(all.p, rank, size);
  const std::vector<CgContact> c = deal(all.c, rank, size);
  const std::vector<CgMotion> m = deal(all.m, rank, size);
  for (KernelType type : {KernelType::Gaussian, KernelType::Lucy}) {
    const FieldGrid grid{{10, 8, 12}, kL};
    const FieldKernel k{type, type == KernelType::Gaussian ? 0.003 : 0.008, 3};
    MpiDomain domain(MPI_COMM_WORLD);
    SerialDomain serial;
    const FieldsResult par = coarse_grain(grid, k, p, c, {}, domain);
    const FieldsResult ser = coarse_grain(grid, k, all.p, all.c, {}, serial);
    std::size_t values = 0;
    const std::size_t differ = differing(par, ser, values);
    EXPECT_EQ(differ, 0u) << "of " << values;
    EXPECT_EQ(par.contacts, std::int64_t(all.c.size()));
    const FieldsResult dpar = displacement_fields(grid, k, Vec3(kL.cwiseProduct(Vec3(0.99, 1.003, 1.004))), m, domain);
    const FieldsResult dser =
        displacement_fields(grid, k, Vec3(kL.cwiseProduct(Vec3(0.99, 1.003, 1.004))), all.m, serial);
    std::size_t dvalues = 0;
    const std::size_t ddiffer = differing(dpar, dser, dvalues);
    EXPECT_EQ(ddiffer, 0u) << "of " << dvalues;
    if (rank == 0)
      std::printf(
          "[fields ranks] %zu spheres, %zu contacts, %s, %d rank(s): %zu + %zu values, %zu + %zu differ from the "
          "serial fields (bitwise)\n",
          all.p.size(), all.c.size(), type == KernelType::Gaussian ? "gaussian" : "lucy", size, values, dvalues, differ,
          ddiffer);
  }
}
