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

SpecimenResponse specimen_response(Simulation& sim) {
  double m[18] = {};
  add_specimen_response(sim.particles(), sim.pairs(), sim.cell(), sim.params().law, m, &sim.params().materials);
  sim.domain().sum_all(std::span<double>(m, 18));
  const real_t V = sim.cell().volume();
  SpecimenResponse r;
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) {
      r.stiffness(k, l) = m[3 * k + l] / V;
      r.viscosity(k, l) = m[9 + 3 * k + l] / V;
    }
  return r;
}

Servo::Servo(const ServoSettings& s, real_t interval, std::array<bool, 3> axes, Vec3 fixed, Vec3 target)
    : mode_(s.mode), target_(target), kp_(s.gain), ki_(s.integral_gain), cap_(s.max_strain_rate), relax_(s.relaxation),
      irelax_(s.integral_relaxation), interval_(interval), axes_(axes), fixed_(fixed) {}

Vec3 Servo::update(const Mat3& stress, real_t elapsed, const SpecimenResponse& R) {
  Vec3 r = fixed_;
  for (int k = 0; k < 3; ++k) {
    if (!axes_[k]) continue;
    const real_t target = target_[k];
    // The stiffness and viscosity against the servo's own strain: every controlled axis moves.
    real_t S = 0, C = 0;
    for (int l = 0; l < 3; ++l)
      if (axes_[l]) S += R.stiffness(k, l), C += R.viscosity(k, l);
    S = round6(S);
    C = round6(C);
    if (mode_ == ServoMode::Stiffness || !R.empty()) stiffness_[k] = S, viscosity_[k] = C;  // the last seen
    // Pa s: the stress a unit rate moves within one interval (elastic + viscous).
    const real_t resist = S * interval_ + C;
    // The error is read to 1e-6: the reduced stress differs between rank counts in the last
    // bits (summation order), and a dense packing amplifies any difference in the imposed
    // strain rate to O(1) within ~1000 steps; rounded, the servo acts identically on any number
    // of ranks (tests/regression, SameCurveOnOneAndManyRanks).
    const real_t e = std::round((stress(k, k) - target) / target * 1e6) * 1e-6;
    if (mode_ == ServoMode::Gains) {
      gain_[k] = kp_;
      // The multiply-adds are explicit, rounded as the fixed-gain servo always was (GCC fused
      // them so under -march=native when the servo lived in apps/triaxial.cpp): a rate that
      // differs in its last bit changes a dense packing's trajectory, and with it the demo's
      // and the paper scene's output.
      const real_t pe = kp_ * e;
      const real_t i_trial = std::fma(e, elapsed, integral_[k]);
      const real_t trial = std::fma(ki_, i_trial, pe);
      if (std::abs(trial) < cap_) integral_[k] = i_trial;  // anti-windup
      r[k] = std::clamp(std::fma(ki_, integral_[k], pe), -cap_, cap_);
      // Over-correction: a loop gain above 2 with the error alternating in sign, above 5 %,
      // at 20 updates in a row (the issue-13 lattice: p between 31 and 149 kPa for ever).
      const real_t loop = kp_ * resist / target;
      flips_[k] = loop > 2 && std::abs(e) > 0.05 && e * last_error_[k] < 0 ? flips_[k] + 1 : 0;
      last_error_[k] = e;
      if (flips_[k] >= 20)
        throw ServoDivergence(fmt::format(
            "the servo cannot converge on axis {}: the stress error alternated in sign at the last "
            "20 updates (now {:.3g}); servo_gain = {:.6g} 1/s against a specimen stiffness of "
            "{:.6g} Pa over a servo interval of {:.6g} s{} is a loop gain of {:.3g} (above 2 each "
            "correction overshoots by more than the error it corrects); use servo = \"stiffness\" "
            "(the default without servo_gain) or a servo_gain below {:.6g} 1/s",
            k + 1, e, kp_, S, interval_, C > 0 ? fmt::format(" and a viscosity of {:.6g} Pa s", C) : std::string(),
            loop, 2 * target / resist));
      continue;
    }
    if (resist <= 0) {  // no contact resists: approach at the cap
      gain_[k] = INFINITY;
      r[k] = e > 0 ? cap_ : (e < 0 ? -cap_ : 0.0);
      continue;
    }
    const real_t g = target / resist;  // 1/s: the rate that moves sigma by 'target' in T
    gain_[k] = relax_ * g;
    const real_t trial = g * (relax_ * e + irelax_ * (integral_[k] + e));
    if (std::abs(trial) < cap_) integral_[k] += e;  // anti-windup
    r[k] = std::clamp(g * (relax_ * e + irelax_ * integral_[k]), -cap_, cap_);
  }
  return r;
}

bool Servo::needs_response(const Mat3& stress) const {
  if (mode_ == ServoMode::Stiffness) return true;
  for (int k = 0; k < 3; ++k) {
    if (!axes_[k]) continue;
    const real_t e = std::round((stress(k, k) - target_[k]) / target_[k] * 1e6) * 1e-6;
    if (std::abs(e) > 0.05 && e * last_error_[k] < 0) return true;
  }
  return false;
}

std::string Servo::describe() const {
  std::string s = fmt::format("gain ({:.4g}, {:.4g}, {:.4g}) 1/s, stiffness ({:.4g}, {:.4g}, {:.4g}) Pa", gain_[0],
                              gain_[1], gain_[2], stiffness_[0], stiffness_[1], stiffness_[2]);
  if (!viscosity_.isZero())
    s += fmt::format(", viscosity ({:.4g}, {:.4g}, {:.4g}) Pa s", viscosity_[0], viscosity_[1], viscosity_[2]);
  return s;
}

}  // namespace fabrica
