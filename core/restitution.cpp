#include "core/restitution.hpp"

#include <cmath>
#include <numbers>

namespace fabrica {

real_t clamped_restitution(real_t beta) {
  if (beta <= 0) return 1.0;
  const real_t s = beta;  // w_0 = 1: e depends on beta only
  if (beta < 1) {
    const real_t wd = std::sqrt(1 - beta * beta);
    const real_t theta = std::atan2(2 * s * wd, s * s - wd * wd);
    return -std::exp(-s * theta / wd) * (std::cos(theta) - s / wd * std::sin(theta));
  }
  if (beta == 1) return std::exp(-2.0);
  const real_t wp = std::sqrt(beta * beta - 1);
  const real_t theta = std::atanh(2 * s * wp / (s * s + wp * wp));
  return -std::exp(-s * theta / wp) * (std::cosh(theta) - s / wp * std::sinh(theta));
}

real_t damping_ratio_for_restitution(real_t e) {
  if (e >= 1) return 0.0;
  real_t lo = 0, hi = 1;
  while (clamped_restitution(hi) > e) hi *= 2;  // e -> 0 as beta -> infinity
  for (int k = 0; k < 200 && hi - lo > 1e-15 * hi; ++k) {
    const real_t mid = 0.5 * (lo + hi);
    (clamped_restitution(mid) > e ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

real_t shear_damping_ratio_for_restitution(real_t e) {
  if (e >= 1) return 0.0;
  const real_t l = std::log(e);
  return -l / std::sqrt(std::numbers::pi * std::numbers::pi + l * l);
}

}  // namespace fabrica
