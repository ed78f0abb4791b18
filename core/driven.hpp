// Particles whose motion is prescribed (a scene's [[driven]] tables, docs/scene.md "Driven
// particles"): held fixed (velocity and spin zero) or moved at a constant velocity and spin,
// whatever the forces on them. Simulation::step() sets their velocity and spin after each
// half-kick; the work of the force that holds them, -(f . v + t . w) dt over the step, is booked
// as the drive work of the energy account.
#pragma once
#include "core/particles.hpp"
#include "core/types.hpp"

#include <algorithm>
#include <cstdint>
#include <utility>
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

// The owned particles of a rank that belong to a driven set, found anew at each rebuild.
class DrivenMembers {
 public:
  bool empty() const { return members_.empty(); }
  // The owned particles of 'p' in one of 'sets' (the first that holds each).
  void find(const Particles& p, const std::vector<DrivenSet>& sets);
  // Sets their velocity and spin after a half-kick of dt_half; returns the work of the force
  // that holds them over it (local): -(f . v + t . w) dt_half, f and t the force and torque of
  // the half-kick (contacts and gravity), v and w the prescribed motion.
  real_t impose(Particles& p, const std::vector<DrivenSet>& sets, real_t dt_half) const;

 private:
  std::vector<std::pair<Index, std::int32_t>> members_;  // a particle and its set
};

}  // namespace fabrica
