// Neighbour search against brute force (docs/verification.md section 10):
//  - NeighborSearch::build == brute_force_pairs on polydisperse periodic packings (diameter
//    ratio 6), including cells where the grid of the largest class has fewer than 3 cells per
//    axis, with the stored periodic image giving the minimum-image branch vector, and pairs
//    placed at the cutoff to within far less than single precision resolves;
//  - the list order (by space-filling-curve place, core/space_order.hpp) depends on the
//    particles alone, not on their storage order (the basis of rank-count independence);
//  - during a run with a deforming cell, the Verlet rebuild criterion keeps every touching pair
//    in the list (checked against brute force at every step).
#include "core/generate.hpp"
#include "core/neighbor.hpp"
#include "core/space_order.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <utility>
#include <map>
#include <set>
#include <tuple>

namespace fabrica {
namespace {

using Pair = std::pair<GlobalId, GlobalId>;

// n fractal diameters in [10, 60] mm with the extremes forced in (ratio exactly 6).
std::vector<real_t> diameters(std::size_t n, Random& rng) {
  std::vector<real_t> d = fractal_diameters(n, 1.9, 0.01, 0.06, rng);
  d[0] = 0.06;
  d[1] = 0.01;
  return d;
}

real_t solid_volume(const std::vector<real_t>& d) {
  real_t v = 0;
  for (real_t x : d) v += std::numbers::pi / 6 * x * x * x;
  return v;
}

// Pairs of a list as sorted (lower id, higher id), checking that the stored image gives the
// minimum-image branch vector and that i holds the lower id.
std::vector<Pair> list_pairs(const Particles& p, const PeriodicCell& cell, const PairList& pl) {
  std::vector<Pair> out;
  for (std::size_t q = 0; q < pl.size(); ++q) {
    const Index i = pl.i[q], j = pl.j[q];
    EXPECT_LT(p.id[i], p.id[j]);
    const Vec3 d = p.x[j] + image_offset(pl.image[q], cell) - p.x[i];
    const Vec3 dmin = cell.minimum_image(p.x[j] - p.x[i]);
    EXPECT_LT((d - dmin).norm(), 1e-12 * cell.lengths().maxCoeff()) << "wrong image";
    out.emplace_back(p.id[i], p.id[j]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The pairs the neighbour search lists, as list_pairs gives them.
std::vector<Pair> search_pairs(const Particles& p, const PeriodicCell& cell, real_t skin) {
  NeighborSearch ns;
  PairList pl;
  ns.build(p, cell, skin, pl);
  return list_pairs(p, cell, pl);
}

// A direction drawn from the cube [-1, 1]^3, normalised.
Vec3 random_direction(Random& rng) {
  Vec3 dir(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1);
  return dir.normalized();
}

// n / 2 pairs of spheres (ids 2k, 2k + 1) at random places in 'cell': the first of radius r1,
// the second of the radius and at the distance from the first's centre (in a random
// direction, across a periodic face too) that second(id, rng) draws, in that order.
template <class Second>
Particles random_pairs(const PeriodicCell& cell, Random& rng, GlobalId n, real_t r1, Second second) {
  const Vec3 L = cell.lengths();
  Particles p;
  for (GlobalId id = 0; id < n; id += 2) {
    const Vec3 x(L[0] * rng.uniform(), L[1] * rng.uniform(), L[2] * rng.uniform());
    const Vec3 dir = random_direction(rng);
    p.add({id, r1, test::kRho, x});
    const std::pair<real_t, real_t> rd = second(id, rng);
    p.add({id + 1, rd.first, test::kRho, cell.wrap(x + rd.second * dir)});
  }
  return p;
}

void compare_with_brute_force(const Particles& p, const PeriodicCell& cell, real_t skin, const char* label) {
  NeighborSearch ns;
  PairList pl;
  ns.build(p, cell, skin, pl);
  const std::vector<Pair> got = list_pairs(p, cell, pl);
  const std::vector<Pair> ref = brute_force_pairs(p, cell, skin);
  EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << "duplicate pair";
  EXPECT_EQ(got, ref) << label;
  // Sorted along the space-filling curve: by (Morton key, id) of body i, then of body j,
  // computed here from the positions and ids alone (independently of neighbor.cpp).
  using Place = std::tuple<std::uint64_t, GlobalId, std::uint64_t, GlobalId>;
  std::vector<Place> places;
  for (std::size_t q = 0; q < pl.size(); ++q)
    places.emplace_back(morton_key(p.x[pl.i[q]], cell.lengths()), p.id[pl.i[q]],
                        morton_key(p.x[pl.j[q]], cell.lengths()), p.id[pl.j[q]]);
  EXPECT_TRUE(std::is_sorted(places.begin(), places.end())) << label;
  std::printf("[neighbor] %s: N = %zu, cell %.3f x %.3f x %.3f m, %zu pairs (brute force %zu)\n", label, p.size(),
              cell.lengths()[0], cell.lengths()[1], cell.lengths()[2], got.size(), ref.size());
  EXPECT_GT(ref.size(), p.size() / 4);  // a meaningful number of pairs
}

// A random packing generated in a cell 1/s times larger, then shrunk by s per axis (the
// spheres overlap), so that every sphere has several neighbours.
Particles compressed_packing(const std::vector<real_t>& d, const Vec3& L, real_t s, Random& rng) {
  const PeriodicCell big(L / s), cell(L);
  Particles p = random_packing(d, test::kRho, big, rng);
  for (auto& x : p.x) x = cell.wrap(x * s);
  return p;
}

TEST(Neighbor, BuildMatchesBruteForcePolydisperse) {
  Random rng(42);
  const std::vector<real_t> d = diameters(600, rng);
  const real_t L = std::cbrt(solid_volume(d) / 0.3);
  {
    const PeriodicCell cell(Vec3(L, 1.1 * L, 0.9 * L));
    Particles p = random_packing(d, test::kRho, cell, rng);
    compare_with_brute_force(p, cell, 0.02, "random packing phi = 0.3, skin 0.02 m");
  }
  // Shrunk to phi = 0.3 / 0.75^3 = 0.71 (overlapping spheres).
  const PeriodicCell cell(0.75 * Vec3(L, 1.1 * L, 0.9 * L));
  const Particles p = compressed_packing(d, cell.lengths(), 0.75, rng);
  for (real_t skin : {0.0, 0.002, 0.02}) compare_with_brute_force(p, cell, skin, "phi = 0.71");
}

// Cells barely larger than 2 (2 Rmax + skin): the grid of the (largest, largest) class pair has
// fewer than 3 cells along an axis, so the 27-cell stencil wraps onto itself and must not visit
// a cell twice.
TEST(Neighbor, BuildMatchesBruteForceSmallCell) {
  Random rng(7);
  const real_t skin = 0.003, Rmax = 0.03;
  const real_t Lmin = 2 * (2 * Rmax + skin) * 1.01;
  for (const Vec3& Lv :
       {Vec3(Lmin, Lmin, Lmin), Vec3(Lmin, 1.6 * Lmin, 2.5 * Lmin), Vec3(3.1 * Lmin, Lmin, 1.3 * Lmin)}) {
    const PeriodicCell cell(Lv);
    EXPECT_LT(int(std::floor(Lv.minCoeff() / (2 * Rmax + skin))), 3);
    // About phi = 0.3 before shrinking by 0.8 per axis (phi = 0.59).
    std::vector<real_t> d = diameters(400, rng);
    real_t vs = solid_volume(d);
    while (vs > 0.3 * cell.volume() / 0.512) vs -= std::numbers::pi / 6 * std::pow(d.back(), 3), d.pop_back();
    const Particles p = compressed_packing(d, Lv, 0.8, rng);
    for (real_t s : {0.0, skin}) compare_with_brute_force(p, cell, s, "small cell");
  }
}

// Pairs at the cutoff to within far less than the single-precision copies resolve (their
// rounding is about 5e-7 m in a 4 m cell): the copies only pick candidates, and the pairs
// just inside the cutoff are in the list, those just outside and exactly at it are not,
// through periodic images too (fails if the copies decide alone, with or without a margin).
TEST(Neighbor, PairsAtTheCutoffDecidedExactly) {
  const real_t L = 4.0, R = 0.01, skin = 0.001, cut = 2 * R + skin;
  const PeriodicCell cell(Vec3(L, 0.75 * L, 0.5 * L));
  const real_t offsets[] = {-1e-9, 1e-9, -1e-12, 1e-12, 0.0, -3e-6, 3e-6, -2e-7, 2e-7};
  Random rng(11);
  Particles p;
  GlobalId id = 0;
  int k = 0;
  for (real_t a : {0.004, 0.59, 1.33, 1.99, 2.51, 2.98})
    for (real_t b : {0.004, 0.48, 1.24, 1.96, 2.61})
      for (real_t c : {0.004, 0.32, 0.85, 1.39, 1.63}) {
        // Near the faces at 0 the partner lies across the face: a periodic image.
        const Vec3 base(a, b, c);
        const Vec3 dir = random_direction(rng);
        const real_t dist = cut + offsets[k++ % std::size(offsets)];
        p.add({id++, R, test::kRho, cell.wrap(base)});
        p.add({id++, R, test::kRho, cell.wrap(base + dist * dir)});
      }
  const std::vector<Pair> got = search_pairs(p, cell, skin);
  const std::vector<Pair> ref = brute_force_pairs(p, cell, skin);
  EXPECT_EQ(got, ref);
  // Both sides of the cutoff are represented: about half the partners are within it.
  EXPECT_GT(ref.size(), p.size() / 6);
  EXPECT_LT(ref.size(), p.size() / 3);
}

// Spheres so small against the cell that the single-precision margin exceeds the cutoff
// (1-um spheres, no skin, a 4 m cell: margin 1.5e-5 m, cutoff 2e-6 m): spheres 5e-6 m apart
// are not a pair, those 1.5e-6 m apart are (the "surely in" bound must not go below zero).
TEST(Neighbor, MarginBeyondTheCutoffKeepsTheExactList) {
  const PeriodicCell cell(Vec3(4.0, 3.0, 2.0));
  Random rng(9);
  const Particles p = random_pairs(cell, rng, 600, 1e-6, [](GlobalId id, Random&) {
    return std::pair<real_t, real_t>{1e-6, id % 4 == 0 ? 5e-6 : 1.5e-6};
  });
  const std::vector<Pair> got = search_pairs(p, cell, 0.0);
  const std::vector<Pair> ref = brute_force_pairs(p, cell, 0.0);
  EXPECT_EQ(got, ref);
  EXPECT_EQ(ref.size(), 150u);
}

// A dilute specimen: spheres of 1 cm in a 64 m cell would ask for a grid of 2.8e10 cells of
// the cutoff's size (it crashed); the grid is capped at 16 cells a sphere (65,536 at least),
// and the pairs are the brute-force ones.
TEST(Neighbor, DiluteSpecimenCapsTheGrid) {
  const PeriodicCell cell(Vec3(64.0, 48.0, 40.0));
  Random rng(5);
  const Particles p = random_pairs(cell, rng, 400, 0.01, [](GlobalId, Random& r) {
    return std::pair<real_t, real_t>{0.005 + 0.01 * r.uniform(), 0.028 * r.uniform()};
  });
  const std::vector<Pair> got = search_pairs(p, cell, 0.002);
  const std::vector<Pair> ref = brute_force_pairs(p, cell, 0.002);
  EXPECT_EQ(got, ref);
  EXPECT_GT(ref.size(), 100u);
}

// The places in the (Morton key, id) order: owned particles in that order already (a rebuild's
// neighbour search, after the spatial sort) have only the ghosts sorted and merged in; the
// places equal those of one sort of everything, ties of keys included, and so do those of
// owned particles out of order.
TEST(Neighbor, SpaceRanksMergeGhostsIntoSortedOwned) {
  Random rng(3);
  const PeriodicCell cell(Vec3(1.0, 0.8, 0.6));
  const Vec3& L = cell.lengths();
  Particles p;
  for (GlobalId id = 0; id < 3000; ++id) {
    Vec3 x(rng.uniform(), 0.8 * rng.uniform(), 0.6 * rng.uniform());
    if (id % 10 == 0 && id > 0) x = p.x[std::size_t(id - 1)];  // the same key, told apart by id
    p.add({1000 - id, 0.001, test::kRho, x});
  }
  NeighborSearch ns;
  p.permute_owned(ns.spatial_order(p, cell));
  const std::size_t first = p.append_ghosts(700);
  for (std::size_t a = first; a < p.size(); ++a) {
    p.x[a] = Vec3(rng.uniform(), 0.8 * rng.uniform(), 0.6 * rng.uniform());
    if (a % 7 == 0) p.x[a] = p.x[a % first];  // ties with owned particles
    p.id[a] = GlobalId(5000 + a);
  }
  auto reference = [&] {
    std::vector<std::tuple<std::uint64_t, GlobalId, std::size_t>> all;
    for (std::size_t a = 0; a < p.size(); ++a) all.emplace_back(morton_key(p.x[a], L), p.id[a], a);
    std::sort(all.begin(), all.end());
    std::vector<std::uint32_t> r(p.size());
    for (std::size_t k = 0; k < all.size(); ++k) r[std::get<2>(all[k])] = std::uint32_t(k);
    return r;
  };
  std::vector<std::uint32_t> rank;
  space_ranks(p, p.size(), L, rank);
  EXPECT_EQ(rank, reference()) << "sorted owned, ghosts merged";
  std::swap(p.x[10], p.x[2000]);  // owned out of order: one sort of everything
  space_ranks(p, p.size(), L, rank);
  EXPECT_EQ(rank, reference()) << "owned out of order";
}

// The Morton key interleaves the cell coordinates (bit k of axis a at bit 3k + a) and clamps
// positions on the upper face into the last cell.
TEST(Neighbor, MortonKeyInterleavesAndClamps) {
  const Vec3 L(2.0, 4.0, 8.0);
  const real_t cell = std::ldexp(1.0, -kMortonBits);  // one grid cell in reduced coordinates
  EXPECT_EQ(morton_key(Vec3(0, 0, 0), L), 0u);
  EXPECT_EQ(morton_key(Vec3(1.5 * cell * L[0], 0, 0), L), 1u);
  EXPECT_EQ(morton_key(Vec3(0, 1.5 * cell * L[1], 0), L), 2u);
  EXPECT_EQ(morton_key(Vec3(0, 0, 1.5 * cell * L[2]), L), 4u);
  EXPECT_EQ(morton_key(Vec3(2.5 * cell * L[0], 0, 0), L), 8u);  // cell 2 along x: bit 3
  EXPECT_EQ(morton_key(L, L), (std::uint64_t(1) << (3 * kMortonBits)) - 1);
  EXPECT_EQ(morton_key(Vec3(-1e-300, 0, 0), L), 0u);
}

// The pair list, as a sequence of (id_i, id_j), is the same whatever the storage order of the
// particles: what makes force sums bitwise the same on any number of ranks.
TEST(Neighbor, PairOrderIndependentOfStorageOrder) {
  Random rng(11);
  std::vector<real_t> d = diameters(600, rng);
  const Vec3 L = Vec3(1, 1, 2) * std::cbrt(solid_volume(d) / 0.3 / 2.0) * 0.85;
  const Particles p = compressed_packing(d, L, 0.85, rng);
  const PeriodicCell cell(L);
  auto id_sequence = [&](const Particles& q) {
    NeighborSearch ns;
    PairList pl;
    ns.build(q, cell, 0.002, pl);
    std::vector<Pair> seq;
    for (std::size_t k = 0; k < pl.size(); ++k) seq.emplace_back(q.id[pl.i[k]], q.id[pl.j[k]]);
    return seq;
  };
  Particles shuffled = p;
  std::vector<Index> order(p.n_owned());
  for (std::size_t a = 0; a < order.size(); ++a) order[a] = Index(order.size() - 1 - a);
  for (std::size_t a = order.size() - 1; a > 0; --a)
    std::swap(order[a], order[std::size_t(rng.uniform() * double(a + 1))]);
  shuffled.permute_owned(order);
  const std::vector<Pair> ref = id_sequence(p);
  EXPECT_GT(ref.size(), p.size());
  EXPECT_EQ(id_sequence(shuffled), ref);
}

// The Verlet criterion under a deforming cell: at every step, every pair that touches now
// (brute force, skin 0) is in the simulation's list with the right image.
TEST(Neighbor, VerletListKeepsEveryTouchingPairUnderDeformation) {
  Random rng(3);
  const std::vector<real_t> d = diameters(250, rng);
  const real_t L = std::cbrt(solid_volume(d) / 0.3);
  const PeriodicCell cell(0.85 * Vec3(L, L, 1.2 * L));  // phi = 0.49, some overlaps
  Particles p = compressed_packing(d, cell.lengths(), 0.85, rng);
  for (auto& v : p.v) v = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 4.0;
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  law.friction = 0.5;
  law.rolling_friction = 0.1;
  SimulationParams sp;
  sp.law = law;
  sp.skin = 0.002;
  sp.dt = 0.3 * critical_time_step(p, law, false);
  Simulation sim(std::move(p), cell, sp);
  // Compress axis 1 by about 10 % over the run, extend axes 2 and 3 less (denser at the end).
  const int steps = 1500;
  const real_t edot = 0.1 / (steps * sp.dt);
  sim.cell().set_strain_rate(Vec3(-edot, 0.3 * edot, 0.2 * edot));
  const std::int64_t rebuilds0 = sim.rebuild_count();
  std::size_t touching_checked = 0, missing = 0;
  real_t min_gap_unlisted = sp.skin;
  for (int s = 0; s < steps; ++s) {
    sim.step();
    const Particles& q = sim.particles();
    const std::vector<Pair> touching = brute_force_pairs(q, sim.cell(), 0.0);
    const std::vector<Pair> near = brute_force_pairs(q, sim.cell(), sp.skin);
    std::set<Pair> listed;
    for (std::size_t k = 0; k < sim.pairs().size(); ++k) {
      const Index i = sim.pairs().i[k], j = sim.pairs().j[k];
      listed.emplace(q.id[i], q.id[j]);
      const Vec3 dd = q.x[j] + image_offset(sim.pairs().image[k], sim.cell()) - q.x[i];
      if (dd.norm() < q.radius[i] + q.radius[j]) {
        // A listed pair that touches must use the minimum image.
        EXPECT_LT((dd - sim.cell().minimum_image(q.x[j] - q.x[i])).norm(), 1e-12);
      }
    }
    for (const Pair& t : touching) missing += listed.count(t) == 0;
    // Smallest surface gap of a pair outside the list (how close the criterion came to a miss).
    for (const Pair& t : near) {
      if (listed.count(t)) continue;
      const std::size_t a = test::index_of(q, t.first), b = test::index_of(q, t.second);
      const real_t gap = sim.cell().minimum_image(q.x[b] - q.x[a]).norm() - q.radius[a] - q.radius[b];
      min_gap_unlisted = std::min(min_gap_unlisted, gap);
    }
    touching_checked += touching.size();
  }
  const real_t strain = sim.cell().lengths()[0] / cell.lengths()[0] - 1;
  std::printf(
      "[neighbor] Verlet run: %d steps, strain_1 = %.3f, %lld rebuilds, %zu touching "
      "pairs checked, %zu missing; smallest gap of an unlisted pair %.3f skin\n",
      steps, strain, (long long)(sim.rebuild_count() - rebuilds0), touching_checked, missing,
      min_gap_unlisted / sp.skin);
  EXPECT_EQ(missing, 0u);
  EXPECT_GT(min_gap_unlisted, 0.0);
  EXPECT_GT(touching_checked, std::size_t(steps) * 20);
  EXPECT_GT(sim.rebuild_count() - rebuilds0, 5);          // the criterion was exercised
  EXPECT_LT(sim.rebuild_count() - rebuilds0, steps / 3);  // and is not trivially "always"
  EXPECT_NEAR(strain, std::exp(-0.1) - 1, 1e-9);          // exact exponential cell update
}

// A rebuild (re-sorting particles in space, new list) carries every touching contact's shear
// and rolling springs, keyed by the two ids, bit for bit.
TEST(Neighbor, RebuildCarriesContactHistory) {
  Random rng(17);
  const std::vector<real_t> d = diameters(200, rng);
  const real_t L = std::cbrt(solid_volume(d) / 0.3);
  const PeriodicCell cell(0.85 * Vec3(L, L, L));
  Particles p = compressed_packing(d, cell.lengths(), 0.85, rng);
  for (auto& v : p.v) v = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
  SimulationParams sp;
  sp.law.friction = 0.5;
  sp.law.rolling_friction = 0.1;
  sp.skin = 0.002;
  sp.dt = 0.3 * critical_time_step(p, sp.law, false);
  Simulation sim(std::move(p), cell, sp);
  for (int s = 0; s < 300; ++s) sim.step();
  auto history = [&] {
    std::map<Pair, std::pair<Vec3, Vec3>> h;
    const Particles& q = sim.particles();
    for (std::size_t k = 0; k < sim.pairs().size(); ++k)
      if (sim.pairs().touching[k])
        h[{q.id[sim.pairs().i[k]], q.id[sim.pairs().j[k]]}] = {sim.pairs().shear_spring(k),
                                                               sim.pairs().rolling_spring(k)};
    return h;
  };
  const auto h0 = history();
  std::size_t loaded = 0;
  for (const auto& [k, v] : h0) loaded += v.first.norm() > 0 && v.second.norm() > 0;
  sim.rebuild();
  const auto h1 = history();
  EXPECT_EQ(h0.size(), h1.size());
  bool same = h0.size() == h1.size();
  for (const auto& [k, v] : h0) {
    auto it = h1.find(k);
    same = same && it != h1.end() && it->second.first == v.first && it->second.second == v.second;
  }
  std::printf(
      "[neighbor] rebuild: %zu touching contacts (%zu with loaded shear and rolling "
      "springs) carried, identical: %s\n",
      h0.size(), loaded, same ? "yes" : "no");
  EXPECT_TRUE(same);
  EXPECT_GT(loaded, 50u);
}

}  // namespace
}  // namespace fabrica

namespace fabrica {
namespace {

// A cell that shrinks past 2 (2 Rmax + skin) (a consolidation): the list holds one image per
// pair, so once a cell length is below twice the cutoff two spheres could touch through two
// images and the second contact would be missed. Two spheres of R = 10 mm, 20.5 mm apart along
// an axis of 50 mm, are compressed along it until L1 = 36 mm < 4 R, where they must touch
// through both images. The guard must fire at the first rebuild with L1 <= 2 (2 R + skin) =
// 0.042 m; before it, every touching image (all 27, brute force) is in the list at every step;
// stepping on past it (the guard ignored) a touching image goes unlisted, later.
TEST(Neighbor, ShrinkingCellStopsBeforeAPairTouchesThroughTwoImages) {
  const real_t R = 0.01, skin = 0.001, need = 2 * (2 * R + skin);
  const Vec3 L0(0.05, 0.1, 0.1);
  Particles p =
      test::make_particles({{1, R, test::kRho, Vec3(0.0125, 0.05, 0.05)}, {2, R, test::kRho, Vec3(0.033, 0.05, 0.05)}});
  SimulationParams sp;
  sp.law = test::direct_law(1e5, 0.5);
  sp.skin = skin;
  sp.dt = 0.1 * critical_time_step(p, sp.law, false);
  Simulation sim(std::move(p), PeriodicCell(L0), sp);
  sim.cell().set_strain_rate(Vec3(-0.5, 0, 0));
  real_t L_at_last_rebuild = L0[0], L_at_guard = 0;
  std::int64_t steps = 0, guard_step = -1, first_miss = -1, touching_seen = 0;
  std::string message;
  while (sim.cell().lengths()[0] > 0.036) {
    sim.step();
    ++steps;
    if (guard_step < 0 && !sim.step_guard().empty()) {
      guard_step = steps, L_at_guard = sim.cell().lengths()[0], message = sim.step_guard();
    }
    if (guard_step < 0 && sim.rebuilt_last_step()) L_at_last_rebuild = sim.cell().lengths()[0];
    const Particles& q = sim.particles();
    const Vec3& L = sim.cell().lengths();
    for (int c = 0; c < 27 && first_miss < 0; ++c) {
      const Vec3 d = q.x[1] + image_offset(c, L) - q.x[0];
      if (d.norm() >= q.radius[0] + q.radius[1]) continue;
      touching_seen += guard_step < 0;
      bool listed = false;
      for (std::size_t k = 0; k < sim.pairs().size(); ++k)
        listed = listed || (sim.pairs().i[k] == 0 ? sim.pairs().image[k] : 26 - sim.pairs().image[k]) == c;
      if (!listed) first_miss = steps;
    }
  }
  std::printf(
      "[neighbor] shrinking cell: guard at step %lld with L1 = %.6f m (limit %.6f m, "
      "last rebuild before it at L1 = %.6f m); first unlisted touching image at step "
      "%lld; %lld touching images checked before the guard\n",
      (long long)guard_step, L_at_guard, need, L_at_last_rebuild, (long long)first_miss, (long long)touching_seen);
  ASSERT_GT(guard_step, 0) << "the guard never fired";
  EXPECT_LE(L_at_guard, need);
  EXPECT_GT(L_at_last_rebuild, need);  // the rebuild before was still above the limit
  EXPECT_GT(touching_seen, 10);        // the pair touched (through one image) before it
  EXPECT_GT(first_miss, guard_step);   // no miss before the guard; and one does come after it
  for (const char* part :
       {"cannot go on at step", "L1 = ", "2 (2 Rmax + skin) = 0.042 m", "two periodic images", "larger specimen"})
    EXPECT_NE(message.find(part), std::string::npos) << part << " missing in: " << message;
}

}  // namespace
}  // namespace fabrica
