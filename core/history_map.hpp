// Contact history keyed by the two global ids of a contact (a < b for particle pairs; walls use
// b = -1 - wall_index). Used at neighbour rebuilds to carry springs from the old contact list
// to the new one (and, with MPI, to move history with migrating particles). The table is
// rebuilt from scratch at every use, so there is no erase.
//
// Layout, for memory at large N: the springs sit in two pools (shear, rolling) indexed by
// slot; the records (a, b, slot: 24 bytes) are stored densely, in insertion order, and an
// open-addressing table of 4-byte record indices (linear probing, load at most 1/2) finds them.
// At a rebuild the map takes over the pools of the old contact list (adopt_pools: moved, not
// copied) and only keys their slots, so that the springs are never held twice: about 32 bytes
// per contact on top of the springs themselves. Every id value is a valid key; no value is
// reserved as an empty marker.
#pragma once
#include "core/contact_law.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace fabrica {

class HistoryMap {
 public:
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

  // Empties the map, with room for 'expected' contacts before it grows. Rolling springs kept.
  void reset(std::size_t expected) {
    recs_.clear();
    recs_.reserve(expected);
    fs_.clear();
    mr_.clear();
    fs_.reserve(expected);
    mr_.reserve(expected);
    rolling_ = true;
    rehash(expected);
  }

  // Empties the map and takes over the spring pools of a contact list (the slots of its
  // touching contacts are then keyed with insert_slot). Without rolling, 'mr' is ignored and
  // every rolling spring reads zero. Room for 'expected' keys. The table that finds them is
  // made by index() (or by the first insert()), so that the caller can free the list first
  // (the rebuild's peak at large N: the table is 8 bytes per contact).
  void adopt_pools(std::vector<Vec3>&& fs, std::vector<Vec3>&& mr, bool rolling,
                   std::size_t expected) {
    recs_.clear();
    recs_.reserve(expected);
    std::vector<std::uint32_t>().swap(slots_);
    mask_ = 0;
    fs_ = std::move(fs);
    rolling_ = rolling;
    if (rolling) {
      mr_ = std::move(mr);
      mr_.resize(fs_.size(), Vec3::Zero());
    } else {
      std::vector<Vec3>().swap(mr_);
    }
  }

  // Makes the table over the keys, if there is none (find_slot needs it).
  void index() {
    if (slots_.empty()) rehash(recs_.size());
  }

  // Frees every buffer (the map is empty and usable afterwards).
  void release() {
    std::vector<Record>().swap(recs_);
    std::vector<std::uint32_t>().swap(slots_);
    std::vector<Vec3>().swap(fs_);
    std::vector<Vec3>().swap(mr_);
    mask_ = 0;
  }

  // Contact (a, b) has the springs at 'slot' of the pools (a slot keyed at most once). Before
  // index() the key is only recorded: each (a, b) must then come at most once.
  void insert_slot(GlobalId a, GlobalId b, std::uint32_t slot) {
    if (slots_.empty()) recs_.push_back({a, b, slot});
    else recs_[find_or_add(a, b)].slot = slot;
  }

  // Contact (a, b) has history h: a new slot at the end of the pools, or its own slot
  // overwritten if (a, b) is already in the map.
  void insert(GlobalId a, GlobalId b, const ContactHistory& h) {
    const std::uint32_t r = find_or_add(a, b);
    if (recs_[r].slot == kNone) {
      recs_[r].slot = std::uint32_t(fs_.size());
      fs_.push_back(h.fs);
      if (rolling_) mr_.push_back(h.mr);
    } else {
      fs_[recs_[r].slot] = h.fs;
      if (rolling_) mr_[recs_[r].slot] = h.mr;
    }
  }

  // The slot of contact (a, b) in the pools, or kNone.
  std::uint32_t find_slot(GlobalId a, GlobalId b) const {
    if (slots_.empty()) {
      if (!recs_.empty()) throw std::logic_error("HistoryMap::find_slot before index()");
      return kNone;
    }
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      const std::uint32_t s = slots_[k];
      if (s == kEmpty) return kNone;
      if (recs_[s].a == a && recs_[s].b == b) return recs_[s].slot;
    }
  }

  // The springs at a slot of the pools.
  ContactHistory at(std::uint32_t slot) const {
    return {fs_[slot], rolling_ ? mr_[slot] : Vec3(Vec3::Zero())};
  }

  std::size_t size() const { return recs_.size(); }
  // Slots in the pools (keyed or not).
  std::size_t pool_size() const { return fs_.size(); }
  bool rolling() const { return rolling_; }

  // Moves the pools out (the map keeps its keys, whose slots name places in them).
  void take_pools(std::vector<Vec3>& fs, std::vector<Vec3>& mr) {
    fs = std::move(fs_);
    mr = std::move(mr_);
    fs_.clear();
    mr_.clear();
  }

  // Calls fn(a, b, history) for every contact, in insertion order.
  template <class F>
  void for_each(F&& fn) const {
    for (const Record& r : recs_) fn(r.a, r.b, at(r.slot));
  }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  struct Record {
    GlobalId a, b;
    std::uint32_t slot;
  };

  static std::size_t hash(GlobalId a, GlobalId b) {
    std::uint64_t x = static_cast<std::uint64_t>(a) * 0x9E3779B97F4A7C15ull;
    x ^= static_cast<std::uint64_t>(b) + 0x7F4A7C159E3779B9ull + (x << 6) + (x >> 2);
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    return static_cast<std::size_t>(x);
  }

  // The record of (a, b), added with slot kNone if absent.
  std::uint32_t find_or_add(GlobalId a, GlobalId b) {
    if (2 * (recs_.size() + 1) > slots_.size()) rehash(2 * (recs_.size() + 1));
    std::uint32_t& s = probe(a, b);
    if (s == kEmpty) {
      s = std::uint32_t(recs_.size());
      recs_.push_back({a, b, kNone});
    }
    return s;
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
  std::vector<Vec3> fs_, mr_;  // the springs, by slot
  bool rolling_ = true;        // mr_ kept
  std::size_t mask_ = 0;
};

}  // namespace fabrica
