// Contact history keyed by the two global ids of a contact (a < b for particle pairs; walls use
// b = -1 - wall_index). Used at neighbour rebuilds to carry springs from the old contact list
// to the new one (and, with MPI, to move history with migrating particles). Open addressing
// with linear probing; the table is rebuilt from scratch at every use, so there is no erase.
#pragma once
#include "core/contact_law.hpp"

#include <bit>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace fabrica {

class HistoryMap {
 public:
  void reset(std::size_t expected) {
    const std::size_t cap = std::bit_ceil(std::max<std::size_t>(16, 2 * expected));
    slots_.assign(cap, Slot{});
    mask_ = cap - 1;
    size_ = 0;
  }

  void insert(GlobalId a, GlobalId b, const ContactHistory& h) {
    if (a == kEmpty) throw std::logic_error("HistoryMap: the id " + std::to_string(a) + " is the empty-slot marker");
    if (2 * (size_ + 1) > slots_.size()) grow();
    Slot& s = probe(a, b);
    if (s.a == kEmpty) ++size_;
    s.a = a;
    s.b = b;
    s.h = h;
  }

  const ContactHistory* find(GlobalId a, GlobalId b) const {
    if (slots_.empty()) return nullptr;
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      const Slot& s = slots_[k];
      if (s.a == kEmpty) return nullptr;
      if (s.a == a && s.b == b) return &s.h;
    }
  }

  std::size_t size() const { return size_; }

  template <class F>
  void for_each(F&& fn) const {
    for (const Slot& s : slots_)
      if (s.a != kEmpty) fn(s.a, s.b, s.h);
  }

 private:
  // The empty-slot marker: the most negative id. Particle ids are >= 0 (data files: [1, 2^53],
  // io/lammps_data.hpp; generated: 0 ... N-1) and walls' are -1 - wall index, so no key a
  // caller can insert equals it.
  static constexpr GlobalId kEmpty = std::numeric_limits<GlobalId>::min();
  struct Slot {
    GlobalId a = kEmpty, b = 0;
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

  Slot& probe(GlobalId a, GlobalId b) {
    for (std::size_t k = hash(a, b) & mask_;; k = (k + 1) & mask_) {
      Slot& s = slots_[k];
      if (s.a == kEmpty || (s.a == a && s.b == b)) return s;
    }
  }

  void grow() {
    std::vector<Slot> old;
    old.swap(slots_);
    reset(old.size());
    for (const Slot& s : old)
      if (s.a != kEmpty) insert(s.a, s.b, s.h);
  }

  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

}  // namespace fabrica
