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

namespace fabrica {

real_t hertz_clamped_restitution(real_t beta) {
  if (beta <= 0) return 1.0;
  const real_t c = std::sqrt(5.0) * beta;
  // xi'' = a(xi, xi') = -xi^{3/2} - c xi^{1/4} xi' while positive force, i.e. -a > 0.
  auto acc = [c](real_t x, real_t v) {
    const real_t xp = x > 0 ? x : 0.0;
    const real_t q = std::sqrt(std::sqrt(xp));
    return -(xp * std::sqrt(xp) + c * q * v);
  };
  constexpr real_t h = 2e-5;
  real_t x = 0, v = 1;
  for (long k = 0; k < 50'000'000; ++k) {
    const real_t k1x = v, k1v = acc(x, v);
    const real_t k2x = v + 0.5 * h * k1v, k2v = acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const real_t k3x = v + 0.5 * h * k2v, k3v = acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const real_t k4x = v + h * k3v, k4v = acc(x + h * k3x, v + h * k3v);
    const real_t xn = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const real_t vn = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    // The force -acc vanishes (or the overlap closes) within this step: the rebound speed
    // where it does, by linear interpolation of the force.
    const real_t f0 = -acc(x, v), f1 = xn > 0 ? -acc(xn, vn) : -1.0;
    if (k > 0 && f1 <= 0) {
      const real_t w = f0 / (f0 - f1);
      return -(v + w * (vn - v));
    }
    x = xn, v = vn;
  }
  return 0.0;  // not reached for finite beta
}

real_t hertz_damping_for_restitution(real_t e) {
  if (e >= 1) return 0.0;
  real_t lo = 0, hi = 1;
  while (hertz_clamped_restitution(hi) > e) hi *= 2;
  while (hi - lo > 1e-10 * hi) {
    const real_t mid = 0.5 * (lo + hi);
    (hertz_clamped_restitution(mid) > e ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace fabrica
