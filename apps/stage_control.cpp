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
std::array<bool, 3> shear_axes_of(const StageSpec& st) {
  return {st.shear_mode[0] == AxisMode::Stress, st.shear_mode[1] == AxisMode::Stress,
          st.shear_mode[2] == AxisMode::Stress};
}
Vec3 fixed_shear_rates(const StageSpec& st) {
  Vec3 r = Vec3::Zero();
  for (int c = 0; c < 3; ++c)
    if (st.shear_mode[c] == AxisMode::StrainRate) r[c] = st.shear_rate[c];
  return r;
}
// x to 6 significant digits (a reduced stress differs between rank counts in its last bits).
real_t round6(real_t x) {
  if (x == 0 || !std::isfinite(x)) return x;
  const real_t scale = std::pow(10.0, 5 - std::floor(std::log10(std::abs(x))));
  return std::round(x * scale) / scale;
}
}  // namespace

StageControl::StageControl(const StageSpec& st, real_t interval)
    : st_(st), axes_(axes_of(st)), servo_(st.servo, interval, axes_, fixed_rates(st), st.stress) {
  if (st.shears()) servo_.set_shear(shear_axes_of(st), fixed_shear_rates(st), st.shear_stress);
}

void StageControl::set_state(const ControlState& s) {
  servo_.set_integral(s.servo_integral);
  servo_.set_shear_integral(s.shear_integral);
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

// The scale of the shear errors: principal_rotation's p; else the mean target of the stress-
// controlled normal axes; else the measured p (to 6 digits), at least 1 Pa.
real_t StageControl::shear_base_scale(const Mat3& stress) const {
  if (st_.path == StagePath::PrincipalRotation) return st_.pressure;
  real_t sum = 0;
  int n = 0;
  for (int k = 0; k < 3; ++k)
    if (axes_[k]) sum += servo_.target()[k], ++n;
  if (n > 0) return sum / n;
  return std::max<real_t>(1, round6(stress.trace() / 3));
}

// Cyclic simple shear: the engineering strain of its component, or its shear stress in the
// sense of the forward shear, tau = -s_ij (compression positive: a forward shear makes s_ij < 0).
real_t StageControl::cyclic_shear_value(const Mat3& stress, const Vec3& gamma) const {
  const int c = shear_component(st_.shear_normal, st_.shear_direction);
  if (st_.path == StagePath::CyclicShearStrain) return gamma[c];
  const int i = kShearPairs[c][0], j = kShearPairs[c][1];
  return -0.5 * (stress(i, j) + stress(j, i));
}

void StageControl::follow_shear_path(const Mat3& stress, const Vec3& gamma, real_t stage_time) {
  if (st_.cyclic_shear()) {
    const real_t x = cyclic_shear_value(stress, gamma);
    if (reversals_ < 2 * st_.cycles) {
      if (direction_ > 0 && x >= st_.amplitude) direction_ = -1, ++reversals_;
      else if (direction_ < 0 && x <= -st_.amplitude) direction_ = 1, ++reversals_;
    }
  } else if (st_.path == StagePath::PrincipalRotation) {
    const real_t turned = std::clamp(st_.rotation_rate * stage_time, -st_.angle, st_.angle);
    const Mat3 t = rotated_stress(principal_stresses(st_.pressure, st_.q, st_.b), st_.start_angle + turned);
    for (int k = 0; k < 3; ++k) servo_.set_target(k, t(k, k));
    servo_.set_shear_target(0, t(0, 1));
  }
}

Mat3 StageControl::update_gradient(const Mat3& stress, const Vec3& eps, const Vec3& gamma, real_t elapsed,
                                   real_t stage_time, const SpecimenResponse& R) {
  follow_shear_path(stress, gamma, stage_time);
  const Vec3 normal = update(stress, eps, elapsed, R);
  servo_.set_shear_scale(shear_base_scale(stress));
  Vec3 shear = servo_.update_shear(stress, elapsed, R);
  const int simple = st_.shear_normal >= 0 ? shear_component(st_.shear_normal, st_.shear_direction) : -1;
  if (st_.cyclic_shear()) shear[simple] = direction_ * std::abs(st_.shear_rate[simple]);
  Mat3 G = Mat3::Zero();
  G.diagonal() = normal;
  for (int c = 0; c < 3; ++c) {
    const int i = kShearPairs[c][0], j = kShearPairs[c][1];
    if (c == simple) {
      G(st_.shear_direction, st_.shear_normal) += shear[c];  // simple shear, with its spin
    } else {
      G(i, j) += 0.5 * shear[c];  // rotation-free
      G(j, i) += 0.5 * shear[c];
    }
  }
  return G;
}

Vec3 StageControl::shear_targets() const {
  Vec3 t = Vec3::Zero();
  for (int c = 0; c < 3; ++c)
    if (servo_.shear_axes()[c]) t[c] = servo_.shear_target()[c];
  return t;
}

bool StageControl::shear_cycles_done(const Mat3& stress, const Vec3& gamma) const {
  if (!st_.cyclic_shear()) return false;
  return reversals_ >= 2 * st_.cycles && cyclic_shear_value(stress, gamma) >= 0;
}

bool StageControl::angle_done(real_t stage_time) const {
  return st_.path == StagePath::PrincipalRotation && std::abs(st_.rotation_rate * stage_time) >= st_.angle;
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
