#include "core/wall_servo.hpp"

#include <algorithm>

namespace fabrica {

std::size_t servo_wall_count(const std::vector<Wall>& walls) {
  return std::size_t(std::count_if(walls.begin(), walls.end(), [](const Wall& w) { return w.servo(); }));
}

real_t servo_speed(const Wall& w, real_t push, real_t stiffness, real_t area, real_t dt) {
  const real_t error = w.servo_pressure * area - push;  // > 0: the wall must go into the spheres
  const real_t u = stiffness > 0 ? w.servo_relaxation * error / (stiffness * dt)
                                 : (error > 0 ? w.servo_max_speed : -w.servo_max_speed);
  return std::clamp(u, -w.servo_max_speed, w.servo_max_speed);
}

void update_servo_walls(std::vector<Wall>& walls, std::span<const double> load, const PeriodicCell& cell, real_t dt) {
  const Vec3 L = cell.lengths();
  const real_t V = L.prod();
  for (std::size_t k = 0; k < walls.size(); ++k) {
    Wall& w = walls[k];
    if (!w.servo()) continue;
    int axis = 0;  // walls are perpendicular to a cell axis (io/serial/scene.cpp)
    w.normal.cwiseAbs().maxCoeff(&axis);
    const real_t u = servo_speed(w, load[2 * k], load[2 * k + 1], V / L[axis], dt);
    w.velocity = w.velocity - w.velocity.dot(w.normal) * w.normal + u * w.normal;
  }
}

ExactSums* ServoWallLoads::start(std::size_t n_walls) {
  if (sums_.slots() != 2 * n_walls) sums_ = ExactSums(2 * n_walls);
  std::fill(sums_.words().begin(), sums_.words().end(), 0);
  return &sums_;
}

void ServoWallLoads::finish(Domain& domain, std::vector<Wall>& walls, const PeriodicCell& cell, real_t dt) {
  sums_.normalize();
  domain.sum_all(sums_.words());
  sums_.normalize();
  load_.resize(sums_.slots());
  for (std::size_t k = 0; k < sums_.slots(); ++k) load_[k] = sums_.value(k);
  update_servo_walls(walls, load_, cell, dt);
}

}  // namespace fabrica
