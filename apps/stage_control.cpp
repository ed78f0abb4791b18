#include "apps/stage_control.hpp"

#include <algorithm>
#include <cmath>

namespace fabrica {

namespace {
std::array<bool, 3> axes_of(const StageSpec& st) {
  return {st.mode[0] == AxisMode::Stress, st.mode[1] == AxisMode::Stress, st.mode[2] == AxisMode::Stress};
}
Vec3 fixed_rates(const StageSpec& st) {
  Vec3 r = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    if (st.mode[k] == AxisMode::StrainRate) r[k] = st.rate[k];
  return r;
}
}  // namespace

StageControl::StageControl(const StageSpec& st, real_t interval)
    : st_(st), axes_(axes_of(st)), servo_(st.servo, interval, axes_, fixed_rates(st), st.stress) {}

void StageControl::set_state(const ControlState& s) {
  servo_.set_integral(s.servo_integral);
  direction_ = s.direction;
  reversals_ = s.reversals;
}

void StageControl::follow_path(const Mat3& stress, const Vec3& eps) {
  const real_t p = st_.pressure, floor = 0.01 * p;  // a target stays positive (relative errors)
  switch (st_.path) {
    case StagePath::ConstantP: {
      const real_t lateral = std::max(floor, 0.5 * (3 * p - stress(0, 0)));
      servo_.set_target(1, lateral);
      servo_.set_target(2, lateral);
      break;
    }
    case StagePath::TrueTriaxial:
      servo_.set_target(1, std::max(floor, p + st_.b * (stress(0, 0) - p)));
      break;
    case StagePath::CyclicStrain:
    case StagePath::CyclicStress: {
      const real_t x = st_.path == StagePath::CyclicStrain ? eps[0] : signed_deviator(stress);
      if (reversals_ < 2 * st_.cycles) {
        if (direction_ > 0 && x >= st_.amplitude) direction_ = -1, ++reversals_;
        else if (direction_ < 0 && x <= -st_.amplitude) direction_ = 1, ++reversals_;
      }
      break;
    }
    default:
      break;
  }
}

Vec3 StageControl::update(const Mat3& stress, const Vec3& eps, real_t elapsed, const SpecimenResponse& R) {
  follow_path(stress, eps);
  Vec3 r = servo_.update(stress, elapsed, R);
  if (st_.path == StagePath::CyclicStrain || st_.path == StagePath::CyclicStress)
    r[0] = -direction_ * std::abs(st_.rate[0]);
  return r;
}

Vec3 StageControl::targets() const {
  Vec3 t = Vec3::Zero();
  for (int k = 0; k < 3; ++k)
    if (axes_[k]) t[k] = servo_.target()[k];
  return t;
}

bool StageControl::cycles_done(const Mat3& stress, const Vec3& eps) const {
  if (st_.path != StagePath::CyclicStrain && st_.path != StagePath::CyclicStress) return false;
  const real_t x = st_.path == StagePath::CyclicStrain ? eps[0] : signed_deviator(stress);
  return reversals_ >= 2 * st_.cycles && x >= 0;
}

}  // namespace fabrica
