// Basic types shared by every part of Fabrica. SI units throughout (m, kg, s, N, Pa).
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace fabrica {

using real_t = double;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using GlobalId = std::int64_t;  // global particle id, unique over all MPI ranks
using Index = std::int32_t;     // local index into a rank's particle storage

}  // namespace fabrica
