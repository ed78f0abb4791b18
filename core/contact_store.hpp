// The contacts of a Simulation: the pair and wall lists with their springs, and the carry of the
// springs of touching contacts from one list to the next (keyed by the two global ids, the key
// that also moves them between ranks, core/history_map.hpp). Simulation::rebuild() keeps the
// springs (keep_springs), lets the domain move them with their particles (carry()), and makes
// the new lists with the springs attached (build).
#pragma once
#include "core/cell.hpp"
#include "core/contact_list.hpp"
#include "core/history_map.hpp"
#include "core/neighbor.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

class ContactStore {
 public:
  PairList& pairs() { return pairs_; }
  const PairList& pairs() const { return pairs_; }
  WallContactList& walls() { return walls_; }
  const WallContactList& walls() const { return walls_; }
  // The springs between two lists, keyed by global ids: filled by keep_springs (or a restored
  // snapshot, restore()), moved between ranks with their particles, emptied by build().
  HistoryMap& carry() { return carry_; }
  void restore(HistoryMap history) { carry_ = std::move(history); }

  // The springs of touching pair q and wall contact q (those the law keeps; the others zero).
  ContactHistory pair_history(std::size_t q) const {
    return {pairs_.shear_spring(q), pairs_.rolling_spring(q), pairs_.twisting_spring(q)};
  }
  ContactHistory wall_history(std::size_t q) const {
    return {walls_.fs[q], walls_.mr.size() == walls_.size() ? walls_.mr[q] : Vec3(Vec3::Zero()),
            walls_.mt.size() == walls_.size() ? walls_.mt[q] : 0.0};
  }

  // The touching contacts in one order: the pairs whose lower-id body is owned ('p'), then the
  // walls' (b = -1 - wall index). for_each(p, fn) calls fn(id_a, id_b, history) for each;
  // for_each_in the contacts [first, first + n) of that order, 'at' carrying the place in the
  // lists from one call to the next (start with {}): ranges taken in order, as a checkpoint
  // writes its blocks, cost one pass over the lists in all, not one pass per range.
  struct Cursor {
    std::size_t q = 0;    // the next entry of the pair list, then of the wall list
    std::uint64_t k = 0;  // the contacts before it
  };
  template <class F>
  void for_each_in(const Particles& p, std::uint64_t first, std::uint64_t n, Cursor& at, F&& fn) const {
    if (first < at.k) at = {};
    const std::uint64_t end = n > ~std::uint64_t(0) - first ? ~std::uint64_t(0) : first + n;
    const std::size_t np = pairs_.size(), nq = np + walls_.size();
    for (; at.q < nq && at.k < end; ++at.q) {
      const std::size_t q = at.q;
      if (q < np) {
        if (!pairs_.touching[q] || std::size_t(pairs_.i[q]) >= p.n_owned()) continue;
        if (at.k++ >= first) fn(p.id[pairs_.i[q]], p.id[pairs_.j[q]], pair_history(q));
      } else {
        const std::size_t w = q - np;
        if (!walls_.touching[w]) continue;
        if (at.k++ >= first) fn(p.id[walls_.i[w]], GlobalId(-1 - walls_.wall[w]), wall_history(w));
      }
    }
  }
  template <class F>
  void for_each(const Particles& p, F&& fn) const {
    Cursor at;
    for_each_in(p, 0, ~std::uint64_t(0), at, fn);
  }

  // Step 1 of a rebuild: the springs of the touching contacts into the carry, keyed by global
  // ids (local indices change); the lists are freed. 'rolling', 'twisting': the law keeps those
  // springs.
  void keep_springs(const Particles& p, bool rolling, bool twisting);
  // Step 3: new lists at the particles' positions (walls, then pairs by 'search'), with the
  // carried springs attached; releases the carry.
  void build(const Particles& p, const PeriodicCell& cell, const std::vector<Wall>& walls, real_t skin,
             NeighborSearch& search, bool rolling, bool twisting);
  // The law's springs changed: 'rolling' ('twisting') now, and before.
  void set_springs(bool rolling, bool had_rolling, bool twisting, bool had_twisting);

 private:
  // Part of build(): the carried springs into the new pair list (slots in list order).
  void attach_springs(const Particles& p, const PeriodicCell& cell, bool rolling, bool twisting);

  PairList pairs_;
  WallContactList walls_;
  HistoryMap carry_;
};

}  // namespace fabrica
