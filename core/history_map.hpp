// Contact history keyed by the two global ids of a contact (a < b for particle pairs; walls use
// b = -1 - wall_index). Used at neighbour rebuilds to carry springs from the old contact list
// to the new one (and, with MPI, to move history with migrating particles). The table is
// rebuilt from scratch at every use, so there is no erase.
//
// Layout, for memory at large N: the springs sit in two pools (shear, rolling) indexed by
// slot; the key of a slot (a, b: 16 bytes) sits at the same place of an array beside them, a
// bit says which slots are keyed, and an open-addressing table of 4-byte slots (linear
// probing, load at most 1/2) finds them. At a rebuild the map takes over the pools of the old
// contact list (adopt_pools: moved, not copied) and only keys their slots, so that the springs
// are never held twice: about 24 bytes per contact on top of the springs themselves. Every id
// value is a valid key; no value is reserved as an empty marker.
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

  // Empties the map, with room for 'expected' contacts before it grows. Rolling springs kept,
  // and twisting springs if 'twisting'.
  void reset(std::size_t expected, bool twisting) {
    clear_keys(expected);
    fs_.clear();
    mr_.clear();
    mt_.clear();
    fs_.reserve(expected);
    mr_.reserve(expected);
    if (twisting) mt_.reserve(expected);
    rolling_ = true;
    twisting_ = twisting;
    rehash(expected);
  }

  // Empties the map and takes over the spring pools of a contact list (the slots of its
  // touching contacts are then keyed with insert_slot). Without rolling, 'mr' is ignored and
  // every rolling spring reads zero; without twisting, 'mt' likewise. The table that finds the
  // keys is made by index() (or by the first insert()), so that the caller can free the list
  // first (the rebuild's peak at large N: the table is 8 bytes per contact).
  void adopt_pools(std::vector<Vec3>&& fs, std::vector<Vec3>&& mr, bool rolling, std::vector<real_t>&& mt,
                   bool twisting) {
    fs_ = std::move(fs);
    rolling_ = rolling;
    if (rolling) {
      mr_ = std::move(mr);
      mr_.resize(fs_.size(), Vec3::Zero());
    } else {
      std::vector<Vec3>().swap(mr_);
    }
    twisting_ = twisting;
    if (twisting) {
      mt_ = std::move(mt);
      mt_.resize(fs_.size(), 0.0);
    } else {
      std::vector<real_t>().swap(mt_);
    }
    clear_keys(0);
    keys_.resize(fs_.size());
    keyed_.assign(fs_.size(), false);
  }

  // Makes the table over the keys, if there is none (find_slot needs it).
  void index() {
    if (slots_.empty()) rehash(count_);
  }

  // Frees every buffer (the map is empty and usable afterwards).
  void release() {
    std::vector<Key>().swap(keys_);
    std::vector<bool>().swap(keyed_);
    std::vector<std::uint32_t>().swap(slots_);
    std::vector<Vec3>().swap(fs_);
    std::vector<Vec3>().swap(mr_);
    std::vector<real_t>().swap(mt_);
    mask_ = 0;
    count_ = 0;
  }

  // Contact (a, b) has the springs at 'slot' of the adopted pools. Only before index(), each
  // slot and each (a, b) at most once.
  void insert_slot(GlobalId a, GlobalId b, std::uint32_t slot) {
    if (!slots_.empty()) throw std::logic_error("HistoryMap::insert_slot after index()");
    keys_[slot] = {a, b};
    if (!keyed_[slot]) ++count_;
    keyed_[slot] = true;
  }

  // Contact (a, b) has history h: a new slot at the end of the pools, or its own slot
  // overwritten if (a, b) is already in the map.
  void insert(GlobalId a, GlobalId b, const ContactHistory& h) {
    if (2 * (count_ + 1) > slots_.size()) rehash(2 * (count_ + 1));  // also the first table
    std::uint32_t& s = probe(a, b);
    if (s == kEmpty) {
      s = std::uint32_t(fs_.size());
      fs_.push_back(h.fs);
      if (rolling_) mr_.push_back(h.mr);
      if (twisting_) mt_.push_back(h.mt);
      keys_.push_back({a, b});
      keyed_.push_back(true);
      ++count_;
    } else {
      fs_[s] = h.fs;
      if (rolling_) mr_[s] = h.mr;
      if (twisting_) mt_[s] = h.mt;
    }
  }

  // The slot of contact (a, b) in the pools, or kNone.
  std::uint32_t find_slot(GlobalId a, GlobalId b) const {
    if (slots_.empty()) {
      if (count_ != 0) throw std::logic_error("HistoryMap::find_slot before index()");
      return kNone;
    }
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      const std::uint32_t s = slots_[k];
      if (s == kEmpty) return kNone;
      if (keys_[s].a == a && keys_[s].b == b) return s;
    }
  }

  // The springs at a slot of the pools.
  ContactHistory at(std::uint32_t slot) const {
    return {fs_[slot], rolling_ ? mr_[slot] : Vec3(Vec3::Zero()), twisting_ ? mt_[slot] : 0.0};
  }

  std::size_t size() const { return count_; }
  // Slots in the pools (keyed or not).
  std::size_t pool_size() const { return fs_.size(); }
  bool rolling() const { return rolling_; }
  bool twisting() const { return twisting_; }

  // Moves the pools out (the map keeps its keys, whose slots name places in them).
  void take_pools(std::vector<Vec3>& fs, std::vector<Vec3>& mr, std::vector<real_t>& mt) {
    fs = std::move(fs_);
    mr = std::move(mr_);
    mt = std::move(mt_);
    fs_.clear();
    mr_.clear();
    mt_.clear();
  }

  // Calls fn(a, b, history) for every contact, in the order of their slots.
  template <class F>
  void for_each(F&& fn) const {
    for (std::size_t s = 0; s < keys_.size(); ++s)
      if (keyed_[s]) fn(keys_[s].a, keys_[s].b, at(std::uint32_t(s)));
  }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  struct Key {
    GlobalId a, b;
  };

  static std::size_t hash(GlobalId a, GlobalId b) {
    std::uint64_t x = static_cast<std::uint64_t>(a) * 0x9E3779B97F4A7C15ull;
    x ^= static_cast<std::uint64_t>(b) + 0x7F4A7C159E3779B9ull + (x << 6) + (x >> 2);
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    return static_cast<std::size_t>(x);
  }

  void clear_keys(std::size_t expected) {
    keys_.clear();
    keys_.reserve(expected);
    keyed_.clear();
    keyed_.reserve(expected);
    std::vector<std::uint32_t>().swap(slots_);
    mask_ = 0;
    count_ = 0;
  }

  // The table entry of (a, b): its slot, or kEmpty where it would go.
  std::uint32_t& probe(GlobalId a, GlobalId b) {
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      std::uint32_t& s = slots_[k];
      if (s == kEmpty || (keys_[s].a == a && keys_[s].b == b)) return s;
    }
  }

  // A table for at least 'n' keys at load <= 1/2, refilled from the keyed slots.
  void rehash(std::size_t n) {
    if (n >= std::size_t(kEmpty) / 2 || keys_.size() >= std::size_t(kEmpty))
      throw std::length_error("HistoryMap: too many contacts");
    const std::size_t cap = std::bit_ceil(std::max<std::size_t>(16, 2 * n));
    slots_.assign(cap, kEmpty);
    mask_ = cap - 1;
    for (std::size_t s = 0; s < keys_.size(); ++s)
      if (keyed_[s]) probe(keys_[s].a, keys_[s].b) = std::uint32_t(s);
  }

  std::vector<Key> keys_;             // the key of each slot, by slot (meaningful where keyed_)
  std::vector<bool> keyed_;           // which slots are keyed
  std::vector<std::uint32_t> slots_;  // the table: keyed slots, kEmpty where none
  std::vector<Vec3> fs_, mr_;         // the springs, by slot
  std::vector<real_t> mt_;            // the twisting springs, by slot
  bool rolling_ = true;               // mr_ kept
  bool twisting_ = false;             // mt_ kept
  std::size_t mask_ = 0;
  std::size_t count_ = 0;  // keyed slots
};

}  // namespace fabrica
