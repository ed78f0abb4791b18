// Orthorhombic periodic cell [0, L1) x [0, L2) x [0, L3) that deforms homogeneously.
// Each axis i has a strain rate edot_i = (dL_i/dt) / L_i (extension positive). Particles
// follow the affine field x_i <- x_i * L_i(t+dt) / L_i(t) plus their own (fluctuating) motion,
// so the velocity of particle b relative to particle a includes edot (.) (x_b - x_a).
#pragma once
#include "core/types.hpp"

#include <cmath>

namespace fabrica {

class PeriodicCell {
 public:
  PeriodicCell() = default;
  explicit PeriodicCell(const Vec3& lengths) : L_(lengths) {}

  const Vec3& lengths() const { return L_; }
  real_t volume() const { return L_.prod(); }
  const Vec3& strain_rate() const { return edot_; }
  void set_strain_rate(const Vec3& edot) { edot_ = edot; }

  // Advances the cell by dt at the current strain rates; returns the per-axis scale factors
  // L(t+dt)/L(t) that positions must be multiplied by (exact exponential update, so that the
  // logarithmic strain ln(L0/L) is integrated without error).
  Vec3 deform(real_t dt) {
    const Vec3 s((edot_.array() * dt).exp());
    L_ = L_.cwiseProduct(s);
    return s;
  }

  // Minimum-image vector for a raw difference d = x_b - x_a.
  Vec3 minimum_image(Vec3 d) const {
    for (int k = 0; k < 3; ++k) d[k] -= L_[k] * std::nearbyint(d[k] / L_[k]);
    return d;
  }

  // Maps a position into [0, L).
  Vec3 wrap(Vec3 x) const {
    for (int k = 0; k < 3; ++k) {
      x[k] -= L_[k] * std::floor(x[k] / L_[k]);
      if (x[k] >= L_[k]) x[k] -= L_[k];  // rounding guard
    }
    return x;
  }

 private:
  Vec3 L_ = Vec3::Ones();
  Vec3 edot_ = Vec3::Zero();
};

}  // namespace fabrica
