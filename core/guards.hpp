// The guards of a Simulation's steps (Simulation::step_guard()): a numerical blow-up (an overlap
// beyond kMaxOverlapRatio, a particle not finite or too fast) and a cell shrunk below two
// cutoffs. The checks ride on reductions the step makes anyway; only a guard that trips makes
// one more, to name the particle or the contact. The same message on every rank.
#pragma once
#include "core/cell.hpp"
#include "core/domain.hpp"
#include "core/forces.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <string>

namespace fabrica {

class StepGuards {
 public:
  // Empty, or the first guard that tripped (the texts at Simulation::step_guard()).
  const std::string& message() const { return message_; }
  // Filled by each force computation: the largest overlap beyond the limit on this rank.
  OverlapAlarm& overlap() { return overlap_; }

  // In step 'step' + 1, with the maxima over every rank of the speed^2 and of the overlap ratio
  // of the last force computation (made in step 'step'): the overlap guard, or else the guard
  // of the speed (more than half the smallest radius per time step 'dt', or not finite;
  // 'displacement_finite': the largest displacement^2 is). Collective.
  void check_motion(real_t max_v2, real_t max_ratio, bool displacement_finite, const Particles& p, Domain& domain,
                    std::int64_t step, real_t dt);
  // At a rebuild in step 'step' + 1, unless a guard has tripped: a cell length no longer above
  // two cutoffs (2 Rmax + skin) trips it.
  void check_cell(const PeriodicCell& cell, real_t cutoff, real_t skin, std::int64_t step);

 private:
  void speed_guard(real_t max_v2, real_t bound, const Particles& p, Domain& domain, std::int64_t step, real_t dt);
  void overlap_guard(real_t max_ratio, Domain& domain, std::int64_t step);

  std::string message_;
  real_t rmin_ = 0;       // the smallest radius over all ranks (set at the first check)
  OverlapAlarm overlap_;  // the largest overlap beyond the limit in the last force computation
};

}  // namespace fabrica
