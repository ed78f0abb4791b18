#include "core/contact_store.hpp"

#include <array>

namespace fabrica {

void ContactStore::keep_springs(const Particles& p, bool rolling, bool twisting) {
  // The carry takes the list's spring pools over and keys the slots of the touching pairs. The
  // bodies of each slot are noted first (8 bytes a slot), so that the old list is freed before
  // the keys are made (the rebuild's peak at large N).
  std::vector<std::array<Index, 2>> bodies(pairs_.spring_fs.size(), {Index(-1), Index(-1)});
  for (std::size_t q = 0; q < pairs_.size(); ++q)
    if (pairs_.touching[q]) bodies[pairs_.slot[q]] = {pairs_.i[q], pairs_.j[q]};
  std::vector<Vec3> fs = std::move(pairs_.spring_fs), mr = std::move(pairs_.spring_mr);
  std::vector<real_t> mt = std::move(pairs_.spring_mt);
  const bool pairs_rolling = pairs_.rolling, pairs_twisting = pairs_.twisting;
  pairs_ = PairList();  // freed (memory at large N)
  carry_.adopt_pools(std::move(fs), std::move(mr), rolling && pairs_rolling, std::move(mt), twisting && pairs_twisting);
  for (std::size_t s = 0; s < bodies.size(); ++s)
    if (bodies[s][0] != Index(-1)) carry_.insert_slot(p.id[bodies[s][0]], p.id[bodies[s][1]], std::uint32_t(s));
  std::vector<std::array<Index, 2>>().swap(bodies);
  for (std::size_t q = 0; q < walls_.size(); ++q)
    if (walls_.touching[q]) carry_.insert(p.id[walls_.i[q]], -1 - walls_.wall[q], wall_history(q));
  walls_ = WallContactList();
  carry_.index();
}

void ContactStore::build(const Particles& p, const PeriodicCell& cell, const std::vector<Wall>& walls, real_t skin,
                         NeighborSearch& search, bool rolling, bool twisting) {
  // The walls' first: they copy their springs out of the carry, whose pools then become the
  // pairs'.
  NeighborSearch::build_walls(p, walls, skin, walls_);
  const std::size_t nw = walls_.size();
  walls_.touching.assign(nw, 0);
  walls_.fs.assign(nw, Vec3::Zero());
  if (rolling) walls_.mr.assign(nw, Vec3::Zero());
  else walls_.mr.clear();
  if (twisting) walls_.mt.assign(nw, 0.0);
  else walls_.mt.clear();
  for (std::size_t q = 0; q < nw; ++q)
    if (const std::uint32_t s = carry_.find_slot(p.id[walls_.i[q]], -1 - walls_.wall[q]); s != HistoryMap::kNone) {
      const ContactHistory h = carry_.at(s);
      walls_.touching[q] = 1;
      walls_.fs[q] = h.fs;
      if (rolling) walls_.mr[q] = h.mr;
      if (twisting) walls_.mt[q] = h.mt;
    }
  search.build(p, cell, skin, pairs_);
  attach_springs(p, cell, rolling, twisting);  // releases the carry
}

void ContactStore::set_springs(bool rolling, bool had_rolling, bool twisting, bool had_twisting) {
  if (rolling && !had_rolling) {
    pairs_.set_rolling(true);
    walls_.mr.assign(walls_.size(), Vec3::Zero());
  } else if (!rolling) {
    pairs_.set_rolling(false);
    walls_.mr.clear();
  }
  if (twisting && !had_twisting) {
    pairs_.set_twisting(true);
    walls_.mt.assign(walls_.size(), 0.0);
  } else if (!twisting) {
    pairs_.set_twisting(false);
    walls_.mt.clear();
  }
}

// The carried springs go to the new pair list, their slots renumbered in list order so that the
// force loop reads the pools nearly in order: the carry's pools are permuted in place (no second
// copy of the springs at the rebuild's peak) and become the list's; the slots no touching pair
// takes (contacts that opened, the walls', those of particles gone to other ranks) are dropped.
// The carry is released (empty) at the end.
void ContactStore::attach_springs(const Particles& p, const PeriodicCell& cell, bool rolling, bool twisting) {
  const std::size_t np = pairs_.size();
  const std::size_t m = carry_.pool_size();
  const bool had_rolling = carry_.rolling(), had_twisting = carry_.twisting();
  pairs_.rolling = rolling;
  pairs_.twisting = twisting;
  pairs_.touching.assign(np, 0);
  pairs_.slot.assign(np, 0);
  pairs_.free_slots.clear();
  std::vector<std::uint32_t> dest(m, HistoryMap::kNone);  // new slot of each carried slot
  std::uint32_t used = 0;
  if (carry_.size() != 0)
    for (std::size_t q = 0; q < np; ++q)
      if (const std::uint32_t s = carry_.find_slot(p.id[pairs_.i[q]], p.id[pairs_.j[q]]); s != HistoryMap::kNone) {
        pairs_.touching[q] = 1;
        pairs_.slot[q] = Index(used);
        dest[s] = used++;
      }
  std::vector<Vec3>& fs = pairs_.spring_fs;
  std::vector<Vec3>& mr = pairs_.spring_mr;
  std::vector<real_t>& mt = pairs_.spring_mt;
  carry_.take_pools(fs, mr, mt);
  // The keys are done with: free them before the pools may grow below (the rebuild's peak; at
  // 869,376 spheres 33 MB of keys beside a pool in two copies while it grows).
  carry_.release();
  // The unused slots after the used ones, then the permutation applied by cycles: each swap
  // puts one spring in its final place.
  for (std::uint32_t s = 0, next = used; s < m; ++s)
    if (dest[s] == HistoryMap::kNone) dest[s] = next++;
  const bool move_mr = had_rolling && rolling, move_mt = had_twisting && twisting;
  for (std::size_t s = 0; s < m; ++s)
    while (dest[s] != s) {
      const std::uint32_t d = dest[s];
      std::swap(fs[s], fs[d]);
      if (move_mr) std::swap(mr[s], mr[d]);
      if (move_mt) std::swap(mt[s], mt[d]);
      std::swap(dest[s], dest[d]);
    }
  std::vector<std::uint32_t>().swap(dest);
  fs.resize(used);
  if (rolling) mr.resize(used, Vec3::Zero());  // zero if rolling was off in the old list
  else std::vector<Vec3>().swap(mr);
  if (twisting) mt.resize(used, 0.0);  // zero if twisting was off in the old list
  else std::vector<real_t>().swap(mt);
  // Room for contacts that close before the next rebuild (the pools grow if they are more).
  // Without carried springs (the first list, a restart without history) every contact opens
  // in the next force pass: room for the pairs touching now, counted here, so that the pools
  // are not grown by doubling there (up to twice the room, 11 MB per rank at 869,376 spheres
  // on 4 ranks).
  std::size_t expect = used;
  if (used == 0) {
    std::array<Vec3, 27> shift;
    for (int c = 0; c < 27; ++c) shift[c] = image_offset(c, cell);
    for (std::size_t q = 0; q < np; ++q) {
      const Index i = pairs_.i[q], j = pairs_.j[q];
      const real_t sum_r = p.radius[i] + p.radius[j];
      expect += (p.x[j] + shift[pairs_.image[q]] - p.x[i]).squaredNorm() < sum_r * sum_r;
    }
  }
  const std::size_t room = expect + expect / 16 + 64;
  fs.reserve(room);
  if (rolling) mr.reserve(room);
  if (twisting) mt.reserve(room);
}

}  // namespace fabrica
