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
#pragma once
#include "apps/servo.hpp"
#include "io/serial/stage_spec.hpp"

#include <array>
#include <cstdint>

namespace fabrica {

// What a checkpoint keeps of a control to resume it bit for bit.
struct ControlState {
  Vec3 servo_integral = Vec3::Zero();
  std::int32_t direction = 1;  // cyclic: +1 compressing axis 1, -1 extending it
  std::int64_t reversals = 0;  // cyclic: reversals so far
};

class StageControl {
 public:
  // 'interval': seconds between two updates (servo interval x time step).
  StageControl(const StageSpec& st, real_t interval);
  // Whether update() reads the specimen's response (collective: every rank asks alike).
  bool needs_response(const Mat3& stress) const { return servo_.needs_response(stress); }
  // The rates after measurement 'stress' with the stage's strains 'eps', 'elapsed' s after the
  // previous one, for the specimen's response R. Throws ServoDivergence (apps/servo.hpp).
  Vec3 update(const Mat3& stress, const Vec3& eps, real_t elapsed, const SpecimenResponse& R);
  // The stress targets of the last update (those of the stress axes; 0 elsewhere).
  Vec3 targets() const;
  const std::array<bool, 3>& stress_axes() const { return axes_; }
  // Cyclic: every cycle done, back where the first began. False for the other paths.
  bool cycles_done(const Mat3& stress, const Vec3& eps) const;
  const Servo& servo() const { return servo_; }
  ControlState state() const { return {servo_.integral(), direction_, reversals_}; }
  void set_state(const ControlState& s);

 private:
  void follow_path(const Mat3& stress, const Vec3& eps);  // moving targets, cyclic reversals
  const StageSpec& st_;
  std::array<bool, 3> axes_;
  Servo servo_;
  std::int32_t direction_ = 1;
  std::int64_t reversals_ = 0;
};

// q_s = s11 - (s22 + s33) / 2 (compression positive): the signed deviator of axis 1.
inline real_t signed_deviator(const Mat3& s) { return s(0, 0) - 0.5 * (s(1, 1) + s(2, 2)); }

}  // namespace fabrica
