// The end conditions of a stage (io/serial/stage_spec.hpp, StageEnd), checked at its measurements:
// the stage ends when any one it gives is met.
//   steps     the stage's step count reaches it (the driver measures at that step);
//   strain    eps of the axis, from the stage's start, reaches the value (its sign: the way);
//   q_p       q/p reaches the value;
//   pressure  p reaches the value (a compression: the plain run's [compress], apps/plain_run.hpp);
//   at_rest   every stress-controlled axis within stress_tolerance of its target (relative)
//             and the unbalanced-force ratio below unbalanced_tolerance;
//   cycles    a cyclic path's cycles done (apps/stage_control.hpp);
//   shear_strain  the engineering shear strain of the component, from the stage's start, reaches
//             the value (its sign: the way; cyclic simple shear: |gamma| reaches |value|);
//   angle     principal_rotation's major axis turned through the stage's angle.
// 'at_rest' also asks every stress-controlled shear component within stress_tolerance of its
// target, relative to the control's shear scale (the targets may be zero).
#pragma once
#include "core/measures.hpp"
#include "io/serial/stage_spec.hpp"

#include <cstdint>

namespace fabrica {

struct EndProbe {
  std::int64_t steps = 0;  // of the stage
  const MacroState* m = nullptr;
  Vec3 eps = Vec3::Zero();      // the stage's strains
  Vec3 targets = Vec3::Zero();  // stress targets of the stress axes (0 elsewhere)
  bool cycles_done = false;
  Vec3 gamma = Vec3::Zero();          // the stage's engineering shear strains 12, 13, 23
  Vec3 shear_targets = Vec3::Zero();  // targets s_ij of the stress-controlled shear components
  real_t shear_scale = 1;             // Pa, the scale of their errors
  bool angle_done = false;
};

bool stage_done(const StageSpec& st, const EndProbe& at);
// 'at_rest' alone (without the other conditions).
bool at_rest(const StageSpec& st, const EndProbe& at);

}  // namespace fabrica
