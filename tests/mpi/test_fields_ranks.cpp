// The coarse-grained fields (core/coarse_grain.hpp) do not depend on the number of ranks: 3,000
// spheres and about 9,000 contacts (many across the periodic faces) are dealt out over the ranks
// irregularly (item i to rank (i * 7919) mod P, each rank's items in reverse order) and
// coarse-grained through MpiDomain, with both kernels; every value of every field, and of the
// displacement fields of a deformation with random fluctuations, must equal the serial result
// (SerialDomain, all items in order) bit for bit. Registered at 1, 2 and 4 ranks.
#include "core/coarse_grain.hpp"
#include "core/serial_domain.hpp"
#include "parallel/mpi_domain.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

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

}  // namespace

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
    const FieldsResult dpar = displacement_fields(grid, k, kL.cwiseProduct(Vec3(0.99, 1.003, 1.004)), m, domain);
    const FieldsResult dser = displacement_fields(grid, k, kL.cwiseProduct(Vec3(0.99, 1.003, 1.004)), all.m, serial);
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
