#include "core/principal.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

Principal principal(const Mat3& m) {
  Principal out;
  const Mat3 sym = 0.5 * (m + m.transpose());
  if (!sym.allFinite()) {
    out.values = out.major = Vec3::Constant(std::numeric_limits<real_t>::quiet_NaN());
    out.angle_12 = std::numeric_limits<real_t>::quiet_NaN();
    return out;
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(sym);
  out.values = eig.eigenvalues().reverse();
  Vec3 v = eig.eigenvectors().col(2);
  for (int i = 0; i < 3; ++i)
    if (v[i] != 0) {
      if (v[i] < 0) v = -v;
      break;
    }
  out.major = v;
  // With v[0] >= 0 the angle lies in [-90, 90]; -90 (v[0] = 0, v[1] < 0) cannot occur since
  // then v[1] is the first nonzero component and positive.
  const real_t planar = std::hypot(v[0], v[1]);
  out.angle_12 =
      planar > 1e-12 ? std::atan2(v[1], v[0]) * 180 / std::numbers::pi : std::numeric_limits<real_t>::quiet_NaN();
  return out;
}

real_t axes_angle(const Vec3& a, const Vec3& b) {
  if (!a.allFinite() || !b.allFinite()) return std::numeric_limits<real_t>::quiet_NaN();
  const real_t c = std::min<real_t>(1, std::abs(a.normalized().dot(b.normalized())));
  return std::acos(c) * 180 / std::numbers::pi;
}

}  // namespace fabrica
