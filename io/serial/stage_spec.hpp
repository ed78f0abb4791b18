// One loading stage of the periodic cell (a [[stage]] table of a scene, docs/scene.md, or one
// of the stages [triaxial] expands into): for each axis stress or strain-rate control, the path
// that couples the axes, the end conditions and the contact parameters it sets.
//
// Conventions: stresses compression positive (Pa); strain rates as the cell takes them,
// extension positive (1/s); strains eps_k = ln(l_k0 / l_k), compression positive, measured from
// the stage's start. Shear components are numbered c = 0, 1, 2 for 12, 13, 23 (kShearPairs);
// a shear rate is an engineering rate gamma_dot = 2 D_ij (D the cell's rate of deformation), a
// shear strain gamma_ij = 2 int D_ij dt (the cell's kinematic sign: a velocity gradient
// G(j, i) > 0 makes gamma_ij grow), and a shear stress s_ij keeps the compression-positive sign
// of the stress tensor (so a positive gamma_ij is resisted by a negative s_ij; tau = -s_ij).
#pragma once
#include "core/contact_law.hpp"
#include "core/types.hpp"

#include <algorithm>
#include <array>
#include <cmath>
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
  // The shear paths (docs/shear.md). The shear plane's normal axis 'shear_normal' and the
  // direction 'shear_direction' it slides along: G(direction, normal) = shear rate.
  SimpleShear,        // the plane's normal axis stress 'pressure' (or fixed), the others fixed
  CyclicShearStrain,  // simple shear at +-rate between gamma = +-amplitude, 'cycles' times
  CyclicShearStress,  // simple shear at +-rate between tau = -s_ij = +-amplitude, 'cycles' times
  PrincipalRotation,  // s11, s22, s33, s12 servo-held on p, q, b with the major axis turning in 1-2
};

// The shear components in their order c = 0, 1, 2: the index pairs of 12, 13, 23.
inline constexpr int kShearPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
inline constexpr const char* kShearNames[3] = {"12", "13", "23"};
// The component c of the pair (i, j) in either order, i != j.
inline int shear_component(int i, int j) { return i + j - 1; }

struct StageEnd {
  std::optional<std::int64_t> steps;   // after this many steps
  std::optional<real_t> strain;        // eps of 'strain_axis' reaches this (either sign)
  int strain_axis = 0;                 // 0, 1, 2
  std::optional<real_t> q_p;           // q/p reaches this
  std::optional<real_t> pressure;      // p reaches this, Pa (a compression: [compress])
  bool at_rest = false;                // stress axes within tolerance and unbalanced below it
  bool cycles = false;                 // the cyclic path's cycles done (implicit for cyclic)
  std::optional<real_t> shear_strain;  // gamma of 'shear_component' reaches this (either sign)
  int shear_component = 0;             // 0, 1, 2: 12, 13, 23
  bool angle = false;                  // principal_rotation: turned through its angle (implicit)
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
  // Shear components 12, 13, 23 (kShearPairs): stress or engineering strain-rate control. The
  // defaults, rate 0 on the three, leave the cell's shape as it is: a stage without shear
  // controls runs on the orthorhombic cell exactly as before sheared cells.
  std::array<AxisMode, 3> shear_mode{AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};
  Vec3 shear_stress = Vec3::Zero();  // Pa, targets s_ij of the stress-controlled components
  Vec3 shear_rate = Vec3::Zero();    // 1/s, engineering rates of the rate-controlled components
  // Simple shear (the shear paths): the component shear_component(normal, direction) is driven
  // as G(direction, normal) = rate (with its spin); every other shear term is rotation-free,
  // G_ij = G_ji = rate / 2. -1: no simple shear.
  int shear_normal = -1, shear_direction = -1;
  real_t q = 0;              // principal_rotation: the deviator held (Pa)
  real_t rotation_rate = 0;  // principal_rotation: rad/s, the major axis' turn (sign: the way)
  real_t angle = 0;          // principal_rotation: rad, the turn (> 0)
  real_t start_angle = 0;    // principal_rotation: rad, the major axis at the start, from axis 1
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

  // Whether the stage deforms the cell's shape (a shear control, a shear path): it then drives
  // the cell through its full velocity gradient (PeriodicCell::set_velocity_gradient).
  bool shears() const {
    if (path == StagePath::SimpleShear || path == StagePath::CyclicShearStrain ||
        path == StagePath::CyclicShearStress || path == StagePath::PrincipalRotation)
      return true;
    for (int c = 0; c < 3; ++c)
      if (shear_mode[c] == AxisMode::Stress || shear_rate[c] != 0) return true;
    return false;
  }
  bool cyclic_shear() const { return path == StagePath::CyclicShearStrain || path == StagePath::CyclicShearStress; }
};

// The principal stresses s1 >= s2 >= s3 of mean stress p, deviator q and b = (s2 - s3) / (s1 - s3):
// s1 - s3 = q / sqrt(1 - b + b^2), p = s3 + (s1 - s3) (1 + b) / 3.
inline Vec3 principal_stresses(real_t p, real_t q, real_t b) {
  const real_t d = q / std::sqrt(1 - b + b * b), s3 = p - d * (1 + b) / 3;
  return Vec3(s3 + d, s3 + b * d, s3);
}

// principal_rotation's stress: s1 along (cos a, sin a, 0), s3 along (-sin a, cos a, 0), s2 along
// axis 3.
inline Mat3 rotated_stress(const Vec3& s, real_t a) {
  const real_t c = 0.5 * (s[0] + s[2]), r = 0.5 * (s[0] - s[2]);
  Mat3 m = Mat3::Zero();
  m(0, 0) = c + r * std::cos(2 * a);
  m(1, 1) = c - r * std::cos(2 * a);
  m(2, 2) = s[1];
  m(0, 1) = m(1, 0) = r * std::sin(2 * a);
  return m;
}

// Whether any stage of the list shears the cell (the run's outputs then carry the shear columns).
inline bool any_shears(const std::vector<StageSpec>& stages) {
  return std::any_of(stages.begin(), stages.end(), [](const StageSpec& s) { return s.shears(); });
}

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
