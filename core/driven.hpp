// Particles whose motion is prescribed (a scene's [[driven]] tables, docs/scene.md "Driven
// particles"): held fixed (velocity and spin zero) or moved at a constant velocity and spin,
// whatever the forces on them. Simulation::step() sets their velocity and spin after each
// half-kick; the work of the force that holds them, -(f . v + t . w) dt over the step, is booked
// as the drive work of the energy account.
#pragma once
#include "core/types.hpp"

#include <algorithm>
#include <vector>

namespace fabrica {

struct DrivenSet {
  std::vector<GlobalId> ids;      // sorted, unique
  GlobalId first = 0, last = -1;  // and the inclusive id range [first, last] (empty if last < first)
  Vec3 velocity = Vec3::Zero();   // m/s
  Vec3 spin = Vec3::Zero();       // rad/s

  bool contains(GlobalId id) const {
    return (id >= first && id <= last) || std::binary_search(ids.begin(), ids.end(), id);
  }
  // The number of ids the set names.
  std::int64_t size() const { return std::int64_t(ids.size()) + std::max<GlobalId>(0, last - first + 1); }
};

}  // namespace fabrica
