#include "apps/servo.hpp"

#include "core/specimen_response.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <span>

namespace fabrica {

namespace {
// x to 6 significant digits: the reduced stiffness differs between rank counts in the last
// bits (summation order); rounded, the servo acts identically on any number of ranks.
real_t round6(real_t x) {
  if (x == 0 || !std::isfinite(x)) return x;
  const real_t scale = std::pow(10.0, 5 - std::floor(std::log10(std::abs(x))));
  return std::round(x * scale) / scale;
}

}  // namespace

SpecimenResponse specimen_response(Simulation& sim, bool shear) {
  double m[24] = {};
  add_specimen_response(sim.particles(), sim.pairs(), sim.cell(), sim.params().law, m, &sim.params().materials);
  if (shear)
    add_shear_response(sim.particles(), sim.pairs(), sim.cell(), sim.params().law, m + 18, &sim.params().materials);
  sim.domain().sum_all(std::span<double>(m, shear ? 24 : 18));
  const real_t V = sim.cell().volume();
  SpecimenResponse r;
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) {
      r.stiffness(k, l) = m[3 * k + l] / V;
      r.viscosity(k, l) = m[9 + 3 * k + l] / V;
    }
  for (int c = 0; c < 3; ++c) {
    r.shear_stiffness[c] = m[18 + c] / V;
    r.shear_viscosity[c] = m[21 + c] / V;
  }
  return r;
}

Servo::Servo(const ServoSettings& s, real_t interval, std::array<bool, 3> axes, Vec3 fixed, Vec3 target)
    : mode_(s.mode), target_(target), kp_(s.gain), ki_(s.integral_gain), cap_(s.max_strain_rate), relax_(s.relaxation),
      irelax_(s.integral_relaxation), interval_(interval), axes_(axes), fixed_(fixed) {}

void Servo::set_shear(std::array<bool, 3> axes, Vec3 fixed, Vec3 target) {
  shear_axes_ = axes;
  shear_fixed_ = fixed;
  shear_target_ = target;
}

real_t Servo::rate(Slots& sl, int k, real_t value, real_t target, real_t scale, real_t S, real_t C, real_t elapsed,
                   bool seen, const std::string& what) {
  if (mode_ == ServoMode::Stiffness || seen) sl.stiffness[k] = S, sl.viscosity[k] = C;  // the last seen
  // Pa s: the stress a unit rate moves within one interval (elastic + viscous).
  const real_t resist = S * interval_ + C;
  // The error is read to 1e-6: the reduced stress differs between rank counts in the last
  // bits (summation order), and a dense packing amplifies any difference in the imposed
  // strain rate to O(1) within ~1000 steps; rounded, the servo acts identically on any number
  // of ranks (tests/regression, SameCurveOnOneAndManyRanks). A normal axis' scale is its target.
  const real_t e = std::round((value - target) / scale * 1e6) * 1e-6;
  if (mode_ == ServoMode::Gains) {
    sl.gain[k] = kp_;
    // The multiply-adds are explicit, rounded as the fixed-gain servo always was (GCC fused
    // them so under -march=native when the servo lived in apps/triaxial.cpp): a rate that
    // differs in its last bit changes a dense packing's trajectory, and with it the demo's
    // and the paper scene's output.
    const real_t pe = kp_ * e;
    const real_t i_trial = std::fma(e, elapsed, sl.integral[k]);
    const real_t trial = std::fma(ki_, i_trial, pe);
    if (std::abs(trial) < cap_) sl.integral[k] = i_trial;  // anti-windup
    const real_t r = std::clamp(std::fma(ki_, sl.integral[k], pe), -cap_, cap_);
    // Over-correction: a loop gain above 2 with the error alternating in sign, above 5 %,
    // at 20 updates in a row (the issue-13 lattice: p between 31 and 149 kPa for ever).
    const real_t loop = kp_ * resist / scale;
    sl.flips[k] = loop > 2 && std::abs(e) > 0.05 && e * sl.last_error[k] < 0 ? sl.flips[k] + 1 : 0;
    sl.last_error[k] = e;
    if (sl.flips[k] >= 20)
      throw ServoDivergence(fmt::format(
          "the servo cannot converge on {}: the stress error alternated in sign at the last "
          "20 updates (now {:.3g}); servo_gain = {:.6g} 1/s against a specimen stiffness of "
          "{:.6g} Pa over a servo interval of {:.6g} s{} is a loop gain of {:.3g} (above 2 each "
          "correction overshoots by more than the error it corrects); use servo = \"stiffness\" "
          "(the default without servo_gain) or a servo_gain below {:.6g} 1/s",
          what, e, kp_, S, interval_, C > 0 ? fmt::format(" and a viscosity of {:.6g} Pa s", C) : std::string(), loop,
          2 * scale / resist));
    return r;
  }
  if (resist <= 0) {  // no contact resists: approach at the cap
    sl.gain[k] = INFINITY;
    return e > 0 ? cap_ : (e < 0 ? -cap_ : 0.0);
  }
  const real_t g = scale / resist;  // 1/s: the rate that moves the stress by 'scale' in T
  sl.gain[k] = relax_ * g;
  const real_t trial = g * (relax_ * e + irelax_ * (sl.integral[k] + e));
  if (std::abs(trial) < cap_) sl.integral[k] += e;  // anti-windup
  return std::clamp(g * (relax_ * e + irelax_ * sl.integral[k]), -cap_, cap_);
}

Vec3 Servo::update(const Mat3& stress, real_t elapsed, const SpecimenResponse& R) {
  Vec3 r = fixed_;
  for (int k = 0; k < 3; ++k) {
    if (!axes_[k]) continue;
    // The stiffness and viscosity against the servo's own strain: every controlled axis moves.
    real_t S = 0, C = 0;
    for (int l = 0; l < 3; ++l)
      if (axes_[l]) S += R.stiffness(k, l), C += R.viscosity(k, l);
    r[k] = rate(normal_, k, stress(k, k), target_[k], target_[k], round6(S), round6(C), elapsed, !R.empty(),
                fmt::format("axis {}", k + 1));
  }
  return r;
}

Vec3 Servo::update_shear(const Mat3& stress, real_t elapsed, const SpecimenResponse& R) {
  Vec3 r = shear_fixed_;
  for (int c = 0; c < 3; ++c) {
    if (!shear_axes_[c]) continue;
    const int i = kShearPairs[c][0], j = kShearPairs[c][1];
    // The symmetric part: the contact stress is symmetric only in equilibrium.
    const real_t s = 0.5 * (stress(i, j) + stress(j, i));
    const real_t scale = std::max(shear_scale_, std::abs(shear_target_[c]));
    r[c] =
        rate(shear_, c, s, shear_target_[c], scale, round6(R.shear_stiffness[c]), round6(R.shear_viscosity[c]), elapsed,
             !R.shear_stiffness.isZero() || !R.shear_viscosity.isZero(), std::string("shear ") + kShearNames[c]);
  }
  return r;
}

bool Servo::needs_response(const Mat3& stress) const {
  if (mode_ == ServoMode::Stiffness) return true;
  for (int k = 0; k < 3; ++k) {
    if (!axes_[k]) continue;
    const real_t e = std::round((stress(k, k) - target_[k]) / target_[k] * 1e6) * 1e-6;
    if (std::abs(e) > 0.05 && e * normal_.last_error[k] < 0) return true;
  }
  for (int c = 0; c < 3; ++c) {
    if (!shear_axes_[c]) continue;
    const int i = kShearPairs[c][0], j = kShearPairs[c][1];
    const real_t scale = std::max(shear_scale_, std::abs(shear_target_[c]));
    const real_t e = std::round((0.5 * (stress(i, j) + stress(j, i)) - shear_target_[c]) / scale * 1e6) * 1e-6;
    if (std::abs(e) > 0.05 && e * shear_.last_error[c] < 0) return true;
  }
  return false;
}

std::string Servo::describe() const {
  const Slots& n = normal_;
  std::string s = fmt::format("gain ({:.4g}, {:.4g}, {:.4g}) 1/s, stiffness ({:.4g}, {:.4g}, {:.4g}) Pa", n.gain[0],
                              n.gain[1], n.gain[2], n.stiffness[0], n.stiffness[1], n.stiffness[2]);
  if (!normal_.viscosity.isZero())
    s += fmt::format(", viscosity ({:.4g}, {:.4g}, {:.4g}) Pa s", normal_.viscosity[0], normal_.viscosity[1],
                     normal_.viscosity[2]);
  if (shear_axes_[0] || shear_axes_[1] || shear_axes_[2])
    s += fmt::format("; shear gain ({:.4g}, {:.4g}, {:.4g}) 1/s, stiffness ({:.4g}, {:.4g}, {:.4g}) Pa", shear_.gain[0],
                     shear_.gain[1], shear_.gain[2], shear_.stiffness[0], shear_.stiffness[1], shear_.stiffness[2]);
  return s;
}

}  // namespace fabrica
