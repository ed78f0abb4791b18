// Contact history keyed by the two global ids of a contact (a < b for particle pairs; walls use
// b = -1 - wall_index). Used at neighbour rebuilds to carry springs from the old contact list
// to the new one (and, with MPI, to move history with migrating particles). The table is
// rebuilt from scratch at every use, so there is no erase.
//
// Layout, for memory at large N: the records (a, b, history: 64 bytes) are stored densely, in
// insertion order, and an open-addressing table of 4-byte record indices (linear probing, load
// at most 1/2) finds them: about 72 bytes per contact instead of 128 to 256 for a table of
// records. Every id value is a valid key; no value is reserved as an empty marker.
#pragma once
#include "core/contact_law.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace fabrica {

class HistoryMap {
 public:
  // Empties the map, with room for 'expected' contacts before it grows.
  void reset(std::size_t expected) {
    recs_.clear();
    recs_.reserve(expected);
    rehash(expected);
  }

  // Frees every buffer (the map is empty and usable afterwards).
  void release() {
    std::vector<Record>().swap(recs_);
    std::vector<std::uint32_t>().swap(slots_);
    mask_ = 0;
  }

  void insert(GlobalId a, GlobalId b, const ContactHistory& h) {
    if (2 * (recs_.size() + 1) > slots_.size()) rehash(2 * (recs_.size() + 1));
    std::uint32_t& s = probe(a, b);
    if (s == kEmpty) {
      s = std::uint32_t(recs_.size());
      recs_.push_back({a, b, h});
    } else {
      recs_[s].h = h;
    }
  }

  const ContactHistory* find(GlobalId a, GlobalId b) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      const std::uint32_t s = slots_[k];
      if (s == kEmpty) return nullptr;
      if (recs_[s].a == a && recs_[s].b == b) return &recs_[s].h;
    }
  }

  std::size_t size() const { return recs_.size(); }

  // Calls fn(a, b, history) for every contact, in insertion order.
  template <class F>
  void for_each(F&& fn) const {
    for (const Record& r : recs_) fn(r.a, r.b, r.h);
  }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  struct Record {
    GlobalId a, b;
    ContactHistory h;
  };

  static std::size_t hash(GlobalId a, GlobalId b) {
    std::uint64_t x = static_cast<std::uint64_t>(a) * 0x9E3779B97F4A7C15ull;
    x ^= static_cast<std::uint64_t>(b) + 0x7F4A7C159E3779B9ull + (x << 6) + (x >> 2);
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    return static_cast<std::size_t>(x);
  }

  std::uint32_t& probe(GlobalId a, GlobalId b) {
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      std::uint32_t& s = slots_[k];
      if (s == kEmpty || (recs_[s].a == a && recs_[s].b == b)) return s;
    }
  }

  // A table for at least 'n' records at load <= 1/2, refilled from the records.
  void rehash(std::size_t n) {
    if (n >= std::size_t(kEmpty) / 2) throw std::length_error("HistoryMap: too many contacts");
    const std::size_t cap = std::bit_ceil(std::max<std::size_t>(16, 2 * n));
    slots_.assign(cap, kEmpty);
    mask_ = cap - 1;
    for (std::size_t r = 0; r < recs_.size(); ++r) probe(recs_[r].a, recs_[r].b) = std::uint32_t(r);
  }

  std::vector<Record> recs_;
  std::vector<std::uint32_t> slots_;
  std::size_t mask_ = 0;
};

}  // namespace fabrica
