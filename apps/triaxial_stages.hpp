// [triaxial] as stages (docs/triaxial.md, "As stages"): the study's protocol is
//   consolidation   isotropic at confining_pressure, mu_s = consolidation_friction, mu_r = 0,
//                   local damping preparation_damping; ends at rest; fabric at its end;
//   equilibration   the same stress, mu_s of [contact] and mu_r = 0 for every case, the case's
//                   mu_r from the start of the shear ([triaxial] equilibration = "common", the
//                   default); "case": the case's mu_r here; "none": no such stage, mu_s and mu_r
//                   switched at the start of the shear;
//   shear           axis 1 compressed at axial_strain_rate, axes 2, 3 at confining_pressure,
//                   local damping shear_damping, strains measured from its start; ends at
//                   eps_1 = axial_strain; fabric at its rows; peak q/p and lateral error.
// Each with the servo settings, tolerances and max_stage_steps of [triaxial].
#pragma once
#include "io/serial/scene.hpp"

namespace fabrica {

enum TriaxialStageIndex : std::int32_t { kConsolidation = 0, kEquilibration = 1, kShear = 2 };

StageSpec consolidation_stage(const Scene& scene);
StageSpec equilibration_stage(const Scene& scene, real_t rolling_friction);
// mu_r of the equilibration of a case whose shear has mu_r = case_rolling_friction.
real_t equilibration_rolling_friction(const Scene& scene, real_t case_rolling_friction);
StageSpec shear_stage(const Scene& scene, real_t rolling_friction);

}  // namespace fabrica
