// The control law of one loading stage (io/serial/stage_spec.hpp): the cell's strain rates after each
// stress measurement. Stress-controlled axes follow the servo (apps/servo.hpp) to their
// targets; strain-rate axes keep their rate. The path couples them:
//   constant_p       axes 2, 3 target (3 p - s11) / 2 (s11 measured): p = (s11 + s22 + s33) / 3;
//   true_triaxial    axis 3 targets p, axis 2 p + b (s11 - p): b = (s22 - s33) / (s11 - s33);
//   constant_volume  rates (-r, r / 2, r / 2): sum zero, the volume exactly constant (the cell
//                    scales each length by exp(edot dt));
//   cyclic_strain    axis 1 reverses at eps_1 = +amplitude and -amplitude (compression first);
//   cyclic_stress    axis 1 reverses at q_s = s11 - (s22 + s33) / 2 = +amplitude, -amplitude;
//                    a cycle ends where it began (eps_1 = 0, q_s = 0), after 2 reversals.
// Shear stages (StageSpec::shears(), docs/shear.md) drive the cell's full velocity gradient G
// (update_gradient): the normal axes as above on its diagonal; each shear component at its
// engineering rate gamma_dot, rotation-free (G_ij = G_ji = gamma_dot / 2) or, for the simple
// shear paths' component, as simple shear G(direction, normal) = gamma_dot; the servo holds the
// stress-controlled shear components as it holds the normal axes. The shear paths:
//   cyclic_simple_shear  the component reverses at gamma = +-amplitude, or at tau = -s_ij =
//                        +-amplitude (forward first); a cycle ends at gamma (tau) >= 0 after 2;
//   principal_rotation   the targets of s11, s22, s33, s12 those of the principal stresses of
//                        p, q, b with the major axis at start_angle + rotation_rate t in 1-2.
// A stage that does not shear, on a cell that has never been sheared, sets only the diagonal
// (update), the path of every scene before sheared cells, bit for bit.
#pragma once
#include "apps/servo.hpp"
#include "io/serial/stage_spec.hpp"

#include <array>
#include <cstdint>

namespace fabrica {

// What a checkpoint keeps of a control to resume it bit for bit.
struct ControlState {
  Vec3 servo_integral = Vec3::Zero();
  std::int32_t direction = 1;          // cyclic: +1 compressing axis 1 (shearing forward), -1 back
  std::int64_t reversals = 0;          // cyclic: reversals so far
  Vec3 shear_integral = Vec3::Zero();  // the shear servo's (shear stages)
};

class StageControl {
 public:
  // 'interval': seconds between two updates (servo interval x time step).
  StageControl(const StageSpec& st, real_t interval);
  // Whether update() reads the specimen's response (collective: every rank asks alike).
  bool needs_response(const Mat3& stress) const { return servo_.needs_response(stress); }
  // Whether the response must include the shear components' (update_gradient with shear axes).
  bool needs_shear_response() const { return servo_.any_shear_axis(); }
  // The rates after measurement 'stress' with the stage's strains 'eps', 'elapsed' s after the
  // previous one, for the specimen's response R. Throws ServoDivergence (apps/servo.hpp).
  Vec3 update(const Mat3& stress, const Vec3& eps, real_t elapsed, const SpecimenResponse& R);
  // The full velocity gradient (shear stages, and any stage on a sheared cell): as update() on
  // the diagonal, the shear components from the stage's engineering shear strains 'gamma' and,
  // for principal_rotation, the stage's time 'stage_time' (s).
  Mat3 update_gradient(const Mat3& stress, const Vec3& eps, const Vec3& gamma, real_t elapsed, real_t stage_time,
                       const SpecimenResponse& R);
  // The stress targets of the last update (those of the stress axes; 0 elsewhere).
  Vec3 targets() const;
  const std::array<bool, 3>& stress_axes() const { return axes_; }
  // The shear targets s_ij of the last update (those of the stress-controlled components; 0
  // elsewhere) and the scale their errors are relative to (Pa).
  Vec3 shear_targets() const;
  const std::array<bool, 3>& shear_axes() const { return servo_.shear_axes(); }
  real_t shear_scale() const { return servo_.shear_scale(); }
  // Cyclic: every cycle done, back where the first began. False for the other paths.
  bool cycles_done(const Mat3& stress, const Vec3& eps) const;
  // The same for cyclic simple shear (its component's gamma or tau).
  bool shear_cycles_done(const Mat3& stress, const Vec3& gamma) const;
  // principal_rotation: the major axis has turned through the stage's angle by 'stage_time'.
  bool angle_done(real_t stage_time) const;
  const Servo& servo() const { return servo_; }
  ControlState state() const { return {servo_.integral(), direction_, reversals_, servo_.shear_integral()}; }
  void set_state(const ControlState& s);

 private:
  void follow_path(const Mat3& stress, const Vec3& eps);  // moving targets, cyclic reversals
  void follow_shear_path(const Mat3& stress, const Vec3& gamma, real_t stage_time);
  real_t shear_base_scale(const Mat3& stress) const;
  real_t cyclic_shear_value(const Mat3& stress, const Vec3& gamma) const;  // gamma or tau
  const StageSpec& st_;
  std::array<bool, 3> axes_;
  Servo servo_;
  std::int32_t direction_ = 1;
  std::int64_t reversals_ = 0;
};

// q_s = s11 - (s22 + s33) / 2 (compression positive): the signed deviator of axis 1.
inline real_t signed_deviator(const Mat3& s) { return s(0, 0) - 0.5 * (s(1, 1) + s(2, 2)); }

}  // namespace fabrica
