#include "io/serial/setup_ranks.hpp"

namespace fabrica {

std::vector<int> SetupRanks::region_owners(const RegionCut& cut, const PeriodicCell&, real_t) {
  const int G = cut.grid.regions();
  std::vector<int> owner(static_cast<std::size_t>(G));
  for (int q = 0; q < G; ++q) owner[std::size_t(q)] = int(std::int64_t(q) * ranks() / G);
  return owner;
}

RegionExchange SetupRanks::region_exchange(const Scene&, const RegionCut&, const PeriodicCell&,
                                           const std::vector<int>&) {
  return [](const Particles&, const std::vector<int>&) { return Particles(); };
}

OverlapReport SetupRanks::take_share(Particles& p, const PeriodicCell& cell, real_t, Holding) {
  return largest_overlap(p, cell);
}

}  // namespace fabrica
