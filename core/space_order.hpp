// The order of particles along a space-filling curve, shared by every rank.
//
// A particle's place in the order is fixed by its own wrapped position and global id only:
// the Morton (Z-order) key of its reduced coordinates x_k / L_k on a 2^21 grid per axis, then
// its id where two keys tie. Two particles therefore compare the same way on every rank that
// holds them (owner and ghost copies have the same position), so a list sorted by this order
// is sorted the same way on any number of ranks, and neighbours in space are neighbours in
// the order (cache locality at large N). Recomputed at each neighbour-list rebuild from the
// positions of that moment.
#pragma once
#include "core/cell.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

inline constexpr int kMortonBits = 21;  // per axis: 63 bits in all

// Morton key of x wrapped into [0, L): the bits of the three cell coordinates interleaved.
std::uint64_t morton_key(const Vec3& x, const Vec3& L);
// The same in a cell of any shape, from x's fractional coordinates (orthorhombic: the same
// key as above).
std::uint64_t morton_key(const Vec3& x, const PeriodicCell& cell);

// For the first n particles of p: rank[a] is a's place among them in the (key, id) order, so
// that rank[a] < rank[b] exactly when (key_a, id_a) < (key_b, id_b). 'order' (optional) receives
// the indices sorted in that order. Without 'order', owned particles found already in that
// order (a rebuild's neighbour search, after the spatial sort) are not sorted again: only the
// others are, and merged with them.
void space_ranks(const Particles& p, std::size_t n, const PeriodicCell& cell, std::vector<std::uint32_t>& rank,
                 std::vector<Index>* order = nullptr);
inline void space_ranks(const Particles& p, std::size_t n, const Vec3& L, std::vector<std::uint32_t>& rank,
                        std::vector<Index>* order = nullptr) {
  space_ranks(p, n, PeriodicCell(L), rank, order);
}

}  // namespace fabrica
