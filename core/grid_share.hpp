// A rank's share of a field grid (docs/fields.md "A share of the grid on each rank"): the box of
// node indices its own items reach, whose fixed-point sums it fills, and the slab of z-layers
// whose fields it finishes and writes (core/grid_exchange.hpp). sum_into_slabs() sends the
// box's integers to the slabs' owners.
#pragma once
#include "core/coarse_grain.hpp"
#include "core/grid_exchange.hpp"

#include <array>
#include <cstddef>

namespace fabrica {

__extension__ typedef __int128 WideSum;  // a fixed-point sum of coarse_grain.cpp

// Along axis a the nodes (first[a] + b) mod n[a], b in [0, len[a]): a box of node indices of
// the periodic grid, numbered b0 + len0 (b1 + len1 b2) (x fastest, as the grid's).
struct NodeBox {
  std::array<int, 3> first{0, 0, 0}, len{0, 0, 0}, n{1, 1, 1};
  static NodeBox whole(const FieldGrid& g) { return {{0, 0, 0}, g.n, g.n}; }
  std::size_t nodes() const { return std::size_t(len[0]) * std::size_t(len[1]) * std::size_t(len[2]); }
  // The box's index along axis a of the grid's index i (in [0, n[a])); len[a] or more: outside.
  int local(int a, int i) const {
    const int b = i - first[a];
    return b < 0 ? b + n[a] : b;
  }
};

// The box of the nodes within 'support' (plus one node of margin) of the points added (a sheared grid: the
// box of node indices that covers the real-space ball, FieldGrid::index_reach): along
// each axis the smallest run of indices, unwrapped (a rank's subdomain is one run, across a
// periodic face too), the whole axis when the run is as long as the grid.
class BoxBuilder {
 public:
  BoxBuilder(const FieldGrid& g, real_t support) : g_(g), n_(g.n), h_(g.spacing()), rs_(support) {
    if (g.sheared) reach_ = g.index_reach(support);
  }
  void add(const Vec3& x) {
    if (g_.sheared) {  // in node units of the fractional coordinates, as the spreading (coarse_grain.cpp)
      const Vec3 t = g_.index_coordinate(x);
      for (int a = 0; a < 3; ++a) {
        lo_[a] = std::min(lo_[a], std::ceil(t[a] - reach_[a] - 0.5) - 1);
        hi_[a] = std::max(hi_[a], std::floor(t[a] + reach_[a] - 0.5) + 1);
      }
    } else {
      for (int a = 0; a < 3; ++a) {
        lo_[a] = std::min(lo_[a], std::ceil((x[a] - rs_) / h_[a] - 0.5) - 1);
        hi_[a] = std::max(hi_[a], std::floor((x[a] + rs_) / h_[a] - 0.5) + 1);
      }
    }
    any_ = true;
  }
  NodeBox box() const;

 private:
  const FieldGrid& g_;
  std::array<int, 3> n_;
  Vec3 h_, reach_ = Vec3::Zero();
  real_t rs_;
  std::array<double, 3> lo_{1e300, 1e300, 1e300}, hi_{-1e300, -1e300, -1e300};
  bool any_ = false;
};

// Adds this rank's box sums ('slots' integers a node of 'box') into the slab sums of every rank
// ('slab': slots integers a node of this rank's layers 'mine', node i + n0 (j + n1 (k -
// mine.first))): each rank sends, to each owner, the box's z-layers that lie in the owner's slab,
// one layer of every slab at a time (a message is at most one z-layer of a box). The integers
// add in any order to the same sums. Collective over 'ex'.
void sum_into_slabs(const FieldGrid& grid, const NodeBox& box, const WideSum* box_sums, std::size_t slots, Layers mine,
                    WideSum* slab, GridExchange& ex);

}  // namespace fabrica
