// Neighbour search: linked cells per size class, feeding a Verlet list with a skin.
//
// With a diameter ratio of 6, one grid sized for the largest pair would make every small
// sphere scan ~30 cells' worth of candidates. Spheres are therefore split into size classes
// (radius bands of a factor 2), and each pair of classes (a <= b) gets its own grid of class-b
// spheres with cell edge >= Rmax_a + Rmax_b + skin; a sphere of class a scans the 27 cells
// around it in that grid only. Candidates within R_i + R_j + skin join the list.
//
// Requirement: every cell length (a sheared cell: every height between opposite faces) exceeds
// 2 (2 Rmax + skin), so that a pair within the cutoff has exactly one periodic image (checked
// by check_cell_size). A sheared cell's grids are cut along its fractional coordinates.
#pragma once
#include "core/cell.hpp"
#include "core/contact_list.hpp"
#include "core/particles.hpp"

#include <utility>
#include <vector>

namespace fabrica {

// Throws std::invalid_argument naming the axis and lengths if the cell is too small.
void check_cell_size(const PeriodicCell& cell, real_t max_radius, real_t skin);

class NeighborSearch {
 public:
  // Fills out.i, out.j, out.image (springs are left to the caller) with every pair that has at
  // least one owned particle. Pairs are oriented from the lower to the higher global id and
  // sorted by the places of i, then j, in the space-filling-curve order of core/space_order.hpp
  // (the same relative order on every rank). Positions must lie in [0, L) (ghosts included).
  void build(const Particles& p, const PeriodicCell& cell, real_t skin, PairList& out);

  // Sphere-wall candidates: distance from the plane below R_i + skin.
  static void build_walls(const Particles& p, const std::vector<Wall>& walls, real_t skin, WallContactList& out);

  // The owned particles in the space-filling-curve order (core/space_order.hpp), for cache
  // locality.
  std::vector<Index> spatial_order(const Particles& p, const PeriodicCell& cell) const;

  struct CellCopies;  // one grid's spheres in cell order (neighbor.cpp)

 private:
  void order_pairs(const Particles& p, const PeriodicCell& cell, std::size_t m, PairList& out);
  std::vector<int> cls_;           // size class of each particle
  std::vector<Index> cell_start_;  // counting-sort buffer of the pair order
  std::vector<Index> tmp_i_, tmp_j_;
  std::vector<std::uint8_t> tmp_img_;
  std::vector<std::uint32_t> rank_;  // place of each particle in the space-filling-curve order
  std::size_t last_pairs_ = 0;       // pairs found by the previous build
};

// Reference: every pair within R_i + R_j + skin by testing all N^2/2 pairs (minimum image),
// as (lower id, higher id). For tests.
std::vector<std::pair<GlobalId, GlobalId>> brute_force_pairs(const Particles& p, const PeriodicCell& cell, real_t skin);

}  // namespace fabrica
