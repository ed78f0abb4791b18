#include "core/cell.hpp"

#include <unsupported/Eigen/MatrixFunctions>

namespace fabrica {

PeriodicCell PeriodicCell::from_matrix(const Mat3& h) {
  PeriodicCell c(Vec3(h.diagonal()));
  Mat3 off = h;
  off.diagonal().setZero();
  if (!off.isZero()) c.set_matrix(h);
  return c;
}

void PeriodicCell::set_matrix(const Mat3& h) {
  sheared_ = true;
  H_ = h;
  Hinv_ = h.inverse();
  L_ = h.diagonal();
}

Vec3 PeriodicCell::heights() const {
  if (!sheared_) return L_;
  const real_t v = std::abs(H_.determinant());
  Vec3 h;
  for (int k = 0; k < 3; ++k) h[k] = v / H_.col((k + 1) % 3).cross(H_.col((k + 2) % 3)).norm();
  return h;
}

void PeriodicCell::set_velocity_gradient(const Mat3& g) {
  Mat3 off = g;
  off.diagonal().setZero();
  if (!sheared_ && off.isZero()) {
    edot_ = g.diagonal();
    return;
  }
  if (!sheared_) set_matrix(Mat3(L_.asDiagonal()));
  G_ = g;
  edot_ = g.diagonal();
}

CellStep PeriodicCell::deform(real_t dt) {
  CellStep step;
  if (!sheared_) {
    step.scale = (edot_.array() * dt).exp();
    L_ = L_.cwiseProduct(step.scale);
    return step;
  }
  step.sheared = true;
  step.F = Mat3(G_ * dt).exp();
  set_matrix(step.F * H_);
  strain_ += 0.5 * (G_ + G_.transpose()) * dt;
  return step;
}

Vec3 PeriodicCell::minimum_image(Vec3 d) const {
  if (!sheared_) {
    for (int k = 0; k < 3; ++k) d[k] -= L_[k] * std::nearbyint(d[k] / L_[k]);
    return d;
  }
  const Vec3 s = Hinv_ * d;
  return d - image_shift(int(std::nearbyint(s[0])), int(std::nearbyint(s[1])), int(std::nearbyint(s[2])));
}

Vec3 PeriodicCell::wrap(Vec3 x) const {
  if (!sheared_) {
    for (int k = 0; k < 3; ++k) {
      x[k] -= L_[k] * std::floor(x[k] / L_[k]);
      if (x[k] >= L_[k]) x[k] -= L_[k];  // rounding guard
    }
    return x;
  }
  const Vec3 s = Hinv_ * x;
  x -= image_shift(int(std::floor(s[0])), int(std::floor(s[1])), int(std::floor(s[2])));
  // Rounding guard: a point whose fractional coordinate rounds to 1 (or just below 0) after
  // the shift is moved by one more edge.
  const Vec3 t = Hinv_ * x;
  for (int k = 0; k < 3; ++k) {
    if (t[k] >= 1) x -= H_.col(k);
    else if (t[k] < 0) x += H_.col(k);
  }
  return x;
}

bool PeriodicCell::reduce() {
  if (!sheared_) return false;
  Mat3 h = H_;
  bool changed = false;
  // Each pass makes every edge as upright as whole steps along each other edge allow; the
  // lattice of a deformed box needs one or two passes (bounded: rounding cannot cycle).
  for (int pass = 0; pass < 8; ++pass) {
    bool again = false;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        if (i == j) continue;
        const real_t r = h.col(i).dot(h.col(j)) / h.col(j).squaredNorm();
        if (std::abs(r) > kFlipRatio) {
          h.col(i) -= std::nearbyint(r) * h.col(j);
          again = changed = true;
        }
      }
    if (!again) break;
  }
  if (changed) set_matrix(h);
  return changed;
}

void PeriodicCell::restore_sheared(const Mat3& h, const Mat3& g, const Mat3& strain) {
  set_matrix(h);
  G_ = g;
  edot_ = g.diagonal();
  strain_ = strain;
}

}  // namespace fabrica
