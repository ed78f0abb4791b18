// core/region_packing: the loose packing made region by region - no two spheres overlap (every
// pair checked by brute force), the gradation and the count hold, the regions are independent of
// how they are dealt out, and the cut keeps same-colour regions apart.
#include "core/neighbor.hpp"
#include "core/region_packing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <vector>

using namespace fabrica;

namespace {

RegionSpec spec(std::int64_t n) {
  RegionSpec s;
  s.count = n;
  s.D = 1.9;
  s.d_min = 0.010;
  s.d_max = 0.060;
  s.seed = 7;
  s.density = 2650;
  return s;
}

// The cell of aspect 2:1:1 that holds 'volume' of solid at solid fraction 'fraction'.
Vec3 cell_for(real_t volume, real_t fraction) {
  const Vec3 aspect(2, 1, 1);
  return aspect * std::cbrt(volume / fraction / aspect.prod());
}

Particles make(const RegionSpec& s, real_t fraction, RegionGrid* out_grid = nullptr, PeriodicCell* out_cell = nullptr) {
  const Vec3 expected = cell_for(expected_solid_volume(s), fraction);
  RegionGrid cut(s, expected, expected);
  real_t v = 0;
  for (int g = 0; g < cut.regions(); ++g)
    for (real_t d : region_diameters(s, cut, g)) v += std::numbers::pi / 6 * d * d * d;
  const PeriodicCell cell(cell_for(v, fraction));
  RegionGrid grid(s, expected, cell.lengths());
  std::vector<int> all(std::size_t(grid.regions()));
  std::iota(all.begin(), all.end(), 0);
  if (out_grid) *out_grid = grid;
  if (out_cell) *out_cell = cell;
  return region_packing(s, grid, cell, all, [](const Particles&, const std::vector<int>&) { return Particles(); });
}

}  // namespace

TEST(RegionPacking, NoOverlapsAndTheGradation) {
  const RegionSpec s = spec(4000);
  RegionGrid grid(s, Vec3::Ones(), Vec3::Ones());
  PeriodicCell cell(Vec3::Ones());
  const Particles p = make(s, 0.30, &grid, &cell);
  ASSERT_EQ(p.n_owned(), 4000u);
  EXPECT_GE(grid.regions(), 8);
  EXPECT_EQ(size_classes(s), 3);  // 60-30, 30-15, 15-10 mm
  // Every pair (brute force, minimum image): none closer than the sum of the radii.
  EXPECT_TRUE(brute_force_pairs(p, cell, 0.0).empty());
  std::vector<bool> seen(4000, false);
  real_t v = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    ASSERT_GE(p.id[a], 0);
    ASSERT_LT(p.id[a], 4000);
    EXPECT_FALSE(seen[std::size_t(p.id[a])]);
    seen[std::size_t(p.id[a])] = true;
    EXPECT_GE(2 * p.radius[a], s.d_min);
    EXPECT_LE(2 * p.radius[a], s.d_max);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(p.x[a][k] >= 0 && p.x[a][k] < cell.lengths()[k]);
    v += 4.0 / 3 * std::numbers::pi * std::pow(p.radius[a], 3);
  }
  // The solid fraction asked for (the cell is made for the drawn volume).
  EXPECT_NEAR(v / cell.volume(), 0.30, 1e-12);
  // The mass fraction below the median size of the gradation M(<d)/M = ((d^(3-D) - dmin^(3-D)) /
  // (dmax^(3-D) - dmin^(3-D))) at d = 0.035 m, against the sample: within 3 % (4,000 spheres).
  const real_t e = 3 - s.D, dm = 0.035;
  const real_t expect = (std::pow(dm, e) - std::pow(s.d_min, e)) / (std::pow(s.d_max, e) - std::pow(s.d_min, e));
  real_t below = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    if (2 * p.radius[a] < dm) below += std::pow(p.radius[a], 3);
  real_t total = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a) total += std::pow(p.radius[a], 3);
  EXPECT_NEAR(below / total, expect, 0.03);
  // The expected volume (closed form) within 2 % of the drawn one.
  EXPECT_NEAR(expected_solid_volume(s) / v, 1.0, 0.02);
}

TEST(RegionPacking, RegionsDoNotDependOnHowTheyAreDealtOut) {
  // Regions dealt to 3 "ranks" in turn, the exchange carrying each round's spheres to the
  // others: the same spheres, bit for bit, as all regions in one list.
  const RegionSpec s = spec(3000);
  RegionGrid grid(s, Vec3::Ones(), Vec3::Ones());
  PeriodicCell cell(Vec3::Ones());
  const Particles whole = make(s, 0.30, &grid, &cell);
  // Round by round, simulated: each part places its colour's regions given what all parts placed
  // before (the serial driver does this for one part; here, three calls per round).
  std::map<GlobalId, std::pair<Vec3, real_t>> ref;
  for (std::size_t a = 0; a < whole.n_owned(); ++a) ref[whole.id[a]] = {whole.x[a], whole.radius[a]};
  std::map<int, Particles> known;
  long long same = 0, total = 0;
  for (int c = 0; c < size_classes(s); ++c)
    for (int colour = 0; colour < 8; ++colour)
      for (int part = 0; part < 3; ++part)
        for (int g = part; g < grid.regions(); g += 3) {
          if (grid.colour(g) != colour) continue;
          Particles near;
          std::vector<int> around = grid.neighbours(g);
          around.push_back(g);
          for (int h : around)
            for (std::size_t a = 0; a < known[h].n_owned(); ++a)
              near.add({known[h].id[a], known[h].radius[a], s.density, known[h].x[a]});
          const Particles p = place_region(s, grid, cell, g, near, c);
          for (std::size_t a = 0; a < p.n_owned(); ++a) {
            known[g].add({p.id[a], p.radius[a], s.density, p.x[a]});
            const auto& r = ref.at(p.id[a]);
            same += r.first == p.x[a] && r.second == p.radius[a];
            ++total;
          }
        }
  EXPECT_EQ(total, 3000);
  EXPECT_EQ(same, total);
}

TEST(RegionPacking, SameColourRegionsAreNeverAdjacent) {
  const RegionSpec s = spec(20000);
  const Vec3 L(1.2, 0.6, 0.6);
  RegionGrid grid(s, L, L);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(grid.dims()[k] % 2, 0);
  for (int k = 0; k < 3; ++k) EXPECT_GE(grid.side()[k], s.d_max);
  for (int g = 0; g < grid.regions(); ++g)
    for (int h : grid.neighbours(g)) EXPECT_NE(grid.colour(g), grid.colour(h)) << g << " " << h;
  // Too narrow a real cell is refused.
  EXPECT_THROW(RegionGrid(s, L, 0.1 * L), std::runtime_error);
}

TEST(RegionPacking, NoRoomIsReportedAfterEveryRound) {
  RegionSpec s = spec(500);
  s.d_min = s.d_max = 0.05;  // equal spheres at 0.7: beyond random sequential addition
  const Vec3 expected = cell_for(expected_solid_volume(s), 0.7);
  RegionGrid grid(s, expected, expected);
  PeriodicCell cell(expected);
  std::vector<int> all(std::size_t(grid.regions()));
  std::iota(all.begin(), all.end(), 0);
  int rounds = 0;
  EXPECT_THROW(region_packing(s, grid, cell, all,
                              [&](const Particles&, const std::vector<int>&) {
                                ++rounds;
                                return Particles();
                              }),
               std::runtime_error);
  EXPECT_EQ(rounds, 8 * size_classes(s));
}
