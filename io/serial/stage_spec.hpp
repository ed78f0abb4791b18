// One loading stage of the periodic cell (a [[stage]] table of a scene, docs/scene.md, or one
// of the stages [triaxial] expands into): for each axis stress or strain-rate control, the path
// that couples the axes, the end conditions and the contact parameters it sets.
//
// Conventions: stresses compression positive (Pa); strain rates as the cell takes them,
// extension positive (1/s); strains eps_k = ln(l_k0 / l_k), compression positive, measured from
// the stage's start.
#pragma once
#include "core/contact_law.hpp"
#include "core/types.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace fabrica {

enum class ServoMode { Stiffness, Gains };

// The servo of the stress-controlled axes (apps/servo.hpp) and the stage tolerances. For
// [triaxial] the values of that table; for a [[stage]] its own keys with these defaults.
struct ServoSettings {
  ServoMode mode = ServoMode::Stiffness;
  real_t relaxation = 0.5;             // (0, 0.5]
  real_t integral_relaxation = 0.05;   // [0, relaxation]
  real_t gain = 4.0;                   // 1/s (mode Gains)
  real_t integral_gain = 2000.0;       // 1/s^2 (mode Gains)
  real_t max_strain_rate = 1.0;        // 1/s, cap of the servo's rates
  std::int64_t interval = 2;           // steps between servo updates (stress measurements)
  real_t stress_tolerance = 0.005;     // relative, for the end condition "at rest"
  real_t unbalanced_tolerance = 1e-4;  // unbalanced-force ratio, for "at rest"
};

enum class AxisMode : std::int32_t { Stress, StrainRate };

// How the axes are coupled beyond their own control (apps/stage_control.hpp).
enum class StagePath : std::int32_t {
  Mixed,           // each axis its own control (isotropic, anisotropic, compression, hold ...)
  ConstantP,       // axis 1 at its rate; axes 2, 3 stress s = (3 p - s11) / 2: p constant
  ConstantVolume,  // axis 1 at its rate; axes 2, 3 at -rate / 2: the volume constant
  TrueTriaxial,    // axis 1 at its rate; axis 3 stress p; axis 2 s3 + b (s11 - s3)
  CyclicStrain,    // axis 1 at +-rate between eps_1 = +-amplitude, 'cycles' times; 2, 3 stress p
  CyclicStress,    // axis 1 at +-rate between q = +-amplitude, 'cycles' times; 2, 3 stress p
};

struct StageEnd {
  std::optional<std::int64_t> steps;  // after this many steps
  std::optional<real_t> strain;       // eps of 'strain_axis' reaches this (either sign)
  int strain_axis = 0;                // 0, 1, 2
  std::optional<real_t> q_p;          // q/p reaches this
  std::optional<real_t> pressure;     // p reaches this, Pa (a compression: [compress])
  bool at_rest = false;               // stress axes within tolerance and unbalanced below it
  bool cycles = false;                // the cyclic path's cycles done (implicit for cyclic)
};

// When the stage runs the fabric analysis ([fabric] enabled).
enum class StageFabric : std::int32_t { None, AtEnd, AtRows };

struct StageSpec {
  std::string name;   // the series' "stage" column
  std::string where;  // for messages: "[triaxial]" or "stage[2]"
  StagePath path = StagePath::Mixed;
  std::array<AxisMode, 3> mode{AxisMode::Stress, AxisMode::Stress, AxisMode::Stress};
  Vec3 stress = Vec3::Zero();  // Pa, targets of the stress axes
  Vec3 rate = Vec3::Zero();    // 1/s, rates of the strain-rate axes
  real_t pressure = 0;         // Pa: constant_p's p; true_triaxial's and cyclic's s3
  real_t b = 0;                // true_triaxial
  real_t amplitude = 0;        // cyclic: of eps_1 (strain) or of q (stress, Pa)
  std::int64_t cycles = 0;     // cyclic
  StageEnd end;
  // Contact parameters set at the start of the stage (the others are kept): those of
  // kLawParameters marked 'stage' (core/contact/params.hpp). A damping ratio replaces the dashpot
  // of that direction, rate form included (stage_law).
  LawChanges law;
  // The scene's own law put back first, each material's own (the triaxial test's switch after
  // consolidation, whose friction was every pair's), then 'law' set.
  bool own_law = false;
  std::optional<real_t> local_damping;
  bool reset_strain = false;  // the series' strains measured from this stage's start
  StageFabric fabric = StageFabric::None;
  bool track_peak = false;  // the result's peak q/p and lateral error over the rows
  ServoSettings servo;
  std::int64_t max_steps = 2000000;  // a stage that does not end by then stops the run
};

// The contact law in force during stage 'st', given the law before it.
inline ContactLawParams stage_law(const ContactLawParams& law, const StageSpec& st) { return st.law.applied_to(law); }

// A law whose dashpots are at least as strong as those of the scene's law and of every stage's
// (the largest damping ratio and the largest rate of each direction): the critical time step
// estimated with it holds in every stage, since damping only shortens that step.
inline ContactLawParams most_damped_law(const ContactLawParams& scene_law, const std::vector<StageSpec>& stages) {
  ContactLawParams bound = scene_law, law = scene_law;
  for (const StageSpec& st : stages) {
    law = stage_law(law, st);
    bound.damping_ratio_n = std::max(bound.damping_ratio_n, law.damping_ratio_n);
    bound.damping_ratio_s = std::max(bound.damping_ratio_s, law.damping_ratio_s);
    bound.damping_rate_n = std::max(bound.damping_rate_n, law.damping_rate_n);
    bound.damping_rate_s = std::max(bound.damping_rate_s, law.damping_rate_s);
  }
  return bound;
}

}  // namespace fabrica
