// Random loose packings made region by region ([particles] placement = "regions"), so that each
// MPI rank makes only the regions of its share and the specimen is the same bit for bit on any
// number of ranks (docs/scene.md, docs/large.md).
//
// The cell is cut into a grid of G = G1 G2 G3 boxes, G_k even and each side at least 4 d_max
// for the expected cell (or G_k = 2; at least d_max for the real one, checked). Region g holds the ids
// [N g / G, N (g+1) / G). Its diameters are a stratified sample of the gradation (the uniform
// numbers (j + v_j) / n_g, j = 0 .. n_g - 1, shuffled, from the region's own random stream), so
// every region holds nearly the same solid volume. The spheres are placed by size class
// (diameters in (d_max / 2^(c+1), d_max / 2^c], c = 0, 1, ...: the largest first everywhere, as
// a sequential addition over the whole cell would) and within a class in 8 rounds by the
// parity of the regions' grid coordinates (colour): regions of one colour are never adjacent,
// so they are independent, and each is placed by random sequential addition (largest first,
// candidate centres uniform in its box) against the spheres placed before in it and in the
// adjacent regions.
#pragma once
#include "core/cell.hpp"
#include "core/generate.hpp"
#include "core/particles.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace fabrica {

struct RegionSpec {
  std::int64_t count = 0;                      // N
  real_t D = 1.9, d_min = 0.01, d_max = 0.06;  // the truncated fractal gradation (core/generate.hpp)
  std::uint64_t seed = 1;
  real_t density = 2650;
};

// The expected solid volume of the N spheres (closed form of the gradation's mean d^3).
real_t expected_solid_volume(const RegionSpec& s);

class RegionGrid {
 public:
  // Cut for cells of about 'expected' lengths; throws std::runtime_error if a side of 'actual'
  // falls below d_max.
  RegionGrid(const RegionSpec& s, const Vec3& expected, const Vec3& actual);
  int regions() const { return dims_[0] * dims_[1] * dims_[2]; }
  const std::array<int, 3>& dims() const { return dims_; }
  int colour(int g) const;                   // 0..7
  std::vector<int> neighbours(int g) const;  // the distinct adjacent regions (periodic), not g
  int region_of(const Vec3& x) const;        // x in [0, L)
  Vec3 lower(int g) const;
  const Vec3& side() const { return side_; }
  std::int64_t first_id(int g) const { return count_ * g / regions(); }

 private:
  std::array<int, 3> dims_{};
  Vec3 side_;
  std::int64_t count_;
};

// The diameters of region g's spheres (ids first_id(g) ..), from its own stream.
std::vector<real_t> region_diameters(const RegionSpec& s, const RegionGrid& grid, int g);

// The size classes of the gradation, and whether diameter d falls in class c.
int size_classes(const RegionSpec& s);
bool in_size_class(const RegionSpec& s, int c, real_t d);

// Places region g's spheres of size class 'size_class' (all if < 0; ids from first_id(g)) in the
// periodic cell without overlapping one another or 'near' (spheres placed before, in g and its
// adjacent regions). Throws std::runtime_error if a sphere finds no room.
Particles place_region(const RegionSpec& s, const RegionGrid& grid, const PeriodicCell& cell, int g,
                       const Particles& near, int size_class = -1);

// The regions 'mine' (any subset, each in one rank's list), colour by colour. After each colour,
// 'exchange' gets the spheres this rank placed in it (with their regions) and returns the ones
// other ranks placed in regions adjacent to 'mine' (a serial run returns none). 'exchange' is
// called 8 times per size class whatever happens (it may be collective); a sphere that found no room throws
// std::runtime_error after the last call.
using RegionExchange = std::function<Particles(const Particles& placed, const std::vector<int>& region_of_placed)>;
Particles region_packing(const RegionSpec& s, const RegionGrid& grid, const PeriodicCell& cell,
                         std::span<const int> mine, const RegionExchange& exchange);

}  // namespace fabrica
