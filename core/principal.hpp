// Principal values and directions of a symmetric tensor (a stress, a fabric or anisotropy
// tensor), for the outputs of sheared runs (docs/output.md, docs/fabric.md):
//   values   the eigenvalues of the symmetric part, descending (sigma_1 >= sigma_2 >= sigma_3 for
//            a compression-positive stress: sigma_1 the most compressive);
//   major    the unit eigenvector of the largest, its sign fixed so that its first nonzero
//            component is positive (as NetworkFabric::phi_major);
//   angle_12 the angle of the major direction's projection on the 1-2 plane from axis 1, in
//            degrees in (-90, 90] (NaN when the major direction is axis 3).
#pragma once
#include "core/types.hpp"

namespace fabrica {

struct Principal {
  Vec3 values = Vec3::Zero();
  Vec3 major = Vec3::UnitX();
  real_t angle_12 = 0;
};

Principal principal(const Mat3& m);

// The angle between two directions (axes, without sign), in degrees in [0, 90]: the
// non-coaxiality of two tensors' major directions. NaN if either is not finite.
real_t axes_angle(const Vec3& a, const Vec3& b);

}  // namespace fabrica
