// Particles (core/particles.hpp): the buffers of a reordering and of the force accumulators,
// which the peak memory of large runs depends on (docs/large.md, "Not yet"), and the derived
// moments of inertia and inverse masses.
#include "core/integrator.hpp"
#include "core/particles.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <numeric>
#include <random>
#include <vector>

namespace fabrica {
namespace {

Particles line_of(int n) {
  Particles p;
  for (int k = 0; k < n; ++k)
    p.add({GlobalId(100 + k), 1e-3 * (1 + k % 3), 2500.0, Vec3(0.01 * k, 0, 0), Vec3(k, 0, 0)});
  return p;
}

std::size_t largest_capacity(const Particles& p) {
  std::size_t c = p.id.capacity();
  for (const auto* a : {&p.x, &p.v, &p.w, &p.f, &p.t}) c = std::max(c, a->capacity());
  for (const auto* a : {&p.radius, &p.mass}) c = std::max(c, a->capacity());
  return c;
}

TEST(Particles, ShortOrderFreesTheLongBuffers) {
  // A rank keeping a tenth of what it read (a set-up's hand-over): no array keeps the room of
  // the thousand, and the kept ones are the ones named, in that order.
  Particles p = line_of(1000);
  const Particles read = line_of(1000);
  std::vector<Index> keep;
  for (Index k = 990; k >= 0; k -= 10) keep.push_back(k);
  p.permute_owned(keep);
  ASSERT_EQ(p.n_owned(), keep.size());
  EXPECT_LE(largest_capacity(p), 3 * keep.size());
  for (std::size_t k = 0; k < keep.size(); ++k) {
    EXPECT_EQ(p.id[k], 100 + keep[k]);
    EXPECT_EQ(p.v[k][0], double(keep[k]));
    EXPECT_EQ(p.radius[k], read.radius[keep[k]]);
    EXPECT_EQ(p.mass[k], read.mass[keep[k]]);
  }
}

TEST(Particles, KeptInOrderIsCompactedInPlace) {
  // A migration keeps nearly all its particles, in their order: compacted in place (no second
  // array at the rebuild's peak), the room for ghosts kept; a set-up's short hand-over in order
  // still frees the long room.
  Particles p = line_of(1000);
  const Particles read = line_of(1000);
  p.reserve(1200);
  for (std::size_t a = 0; a < p.size(); ++a) p.f[a] = Vec3(double(a), 0, 0);
  std::vector<Index> keep;
  for (Index k = 0; k < 1000; ++k)
    if (k % 10 != 3) keep.push_back(k);
  const Vec3* x0 = p.x.data();
  const real_t* m0 = p.mass.data();
  const GlobalId* id0 = p.id.data();
  p.permute_owned(keep);
  ASSERT_EQ(p.n_owned(), keep.size());
  EXPECT_EQ(p.x.data(), x0);
  EXPECT_EQ(p.mass.data(), m0);
  EXPECT_EQ(p.id.data(), id0);
  for (const auto* a : {&p.x, &p.v, &p.w, &p.f, &p.t}) EXPECT_GE(a->capacity(), 1200u);
  for (std::size_t k = 0; k < keep.size(); ++k) {
    EXPECT_EQ(p.id[k], 100 + keep[k]);
    EXPECT_EQ(p.x[k], read.x[keep[k]]);
    EXPECT_EQ(p.v[k][0], double(keep[k]));
    EXPECT_EQ(p.f[k][0], double(keep[k]));
    EXPECT_EQ(p.radius[k], read.radius[keep[k]]);
    EXPECT_EQ(p.mass[k], read.mass[keep[k]]);
  }
  std::vector<Index> tenth;
  for (Index k = 5; k < Index(keep.size()); k += 10) tenth.push_back(k);
  const std::vector<GlobalId> ids = p.id;
  p.permute_owned(tenth);
  ASSERT_EQ(p.n_owned(), tenth.size());
  EXPECT_LE(largest_capacity(p), 3 * tenth.size());
  for (std::size_t k = 0; k < tenth.size(); ++k) EXPECT_EQ(p.id[k], ids[tenth[k]]);
}

TEST(Particles, FullOrderKeepsTheRoom) {
  // A rebuild's spatial sort (every owned particle) keeps the room made for ghosts.
  Particles p = line_of(1000);
  p.reserve(1500);
  std::vector<Index> order(1000);
  std::iota(order.rbegin(), order.rend(), 0);
  p.permute_owned(order);
  EXPECT_EQ(p.id.front(), 1099);
  for (const auto* a : {&p.x, &p.v, &p.w, &p.f, &p.t}) EXPECT_GE(a->capacity(), 1500u);
}

TEST(Particles, ForcesReleasedComeBackZeroWithTheRoom) {
  Particles p = line_of(200);
  p.reserve(260);
  for (std::size_t a = 0; a < p.size(); ++a) p.f[a] = Vec3(1, 2, 3), p.t[a] = Vec3(4, 5, 6);
  p.release_forces();
  EXPECT_EQ(p.f.capacity(), 0u);
  EXPECT_EQ(p.t.capacity(), 0u);
  p.zero_forces();
  ASSERT_EQ(p.f.size(), p.size());
  ASSERT_EQ(p.t.size(), p.size());
  EXPECT_GE(p.f.capacity(), p.capacity());  // appending ghosts does not double them
  for (std::size_t a = 0; a < p.size(); ++a) {
    EXPECT_EQ(p.f[a], Vec3::Zero());
    EXPECT_EQ(p.t[a], Vec3::Zero());
  }
}

TEST(Particles, ReleasedForcesStayOutOfTheSortAndTheGhosts) {
  // A rebuild frees f and t before its spatial sort: the sort and the ghosts leave them out
  // (no array of them is made again) and order the rest; zero_forces() then sizes them.
  Particles p = line_of(300);
  for (std::size_t a = 0; a < p.size(); ++a) p.f[a] = Vec3(1, 2, 3);
  p.release_forces();
  std::vector<Index> order(250);
  std::iota(order.rbegin(), order.rend(), 50);  // 299 down to 50: 50 particles leave
  p.permute_owned(order);
  p.reserve_more(20);  // the ghost build's room
  const std::size_t first = p.append_ghosts(20);
  EXPECT_EQ(p.f.capacity(), 0u);
  EXPECT_EQ(p.t.capacity(), 0u);
  ASSERT_EQ(p.n_owned(), 250u);
  ASSERT_EQ(p.size(), 270u);
  EXPECT_EQ(first, 250u);
  EXPECT_EQ(p.id[0], 100 + 299);
  EXPECT_EQ(p.v[0][0], 299.0);
  EXPECT_EQ(p.id[249], 100 + 50);
  p.zero_forces();
  ASSERT_EQ(p.f.size(), 270u);
  ASSERT_EQ(p.t.size(), 270u);
  for (std::size_t a = 0; a < p.size(); ++a) EXPECT_EQ(p.f[a], Vec3::Zero());
  p.clear_ghosts();  // with the forces back, the ghosts' go with the rest
  EXPECT_EQ(p.f.size(), 250u);
}

TEST(Particles, DerivedInertiaAndInversesAreOneArithmetic) {
  // A solid sphere's I = 2/5 m R^2 (to a rounding), and the half kicks' inverses, taken a block
  // at a time by inverse_masses, the same bits as Particles::inv_mass and inv_inertia for every
  // particle, the last short block included (a difference would make a run's bits depend on
  // where a particle falls in the blocks, hence on the rank count).
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<real_t> r(1e-4, 3e-2), rho(500.0, 8000.0);
  Particles p;
  const std::size_t n = 3 * kKickBlock + 5;
  std::vector<real_t> density(n);
  for (std::size_t k = 0; k < n; ++k) p.add({GlobalId(k), r(rng), density[k] = rho(rng), Vec3::Zero()});
  p.scale_density(10.0);  // masses no longer those of add()'s expression
  std::vector<real_t> im(kKickBlock), iI(kKickBlock);
  for (std::size_t a0 = 0; a0 < n; a0 += kKickBlock) {
    const std::size_t nb = std::min(kKickBlock, n - a0);
    inverse_masses(p, a0, nb, im.data(), iI.data());
    for (std::size_t k = 0; k < nb; ++k) {
      const std::size_t a = a0 + k;
      const real_t I = 10.0 * 8.0 / 15.0 * std::numbers::pi * density[a] * std::pow(p.radius[a], 5);
      EXPECT_NEAR(p.inertia(a), I, 1e-14 * I) << a;
      EXPECT_EQ(im[k], p.inv_mass(a)) << a;
      EXPECT_EQ(iI[k], p.inv_inertia(a)) << a;
      EXPECT_EQ(iI[k], 1.0 / p.inertia(a)) << a;
    }
  }
}

}  // namespace
}  // namespace fabrica
