// Servo-controlled walls ([[wall]] pressure, docs/scene.md "Walls"): a wall that keeps the
// spheres' push on it at a target pressure by moving along its normal, with the gain derived
// from the stiffness of its contacts at every step (as PFC's wall servo derives its gain from the
// contact stiffness and count).
//
// After the forces of a step, with F the elastic part of the spheres' push on the wall, the sum
// of k_n u_n over its touching contacts (N, summed over every rank), and K the sum of their normal
// stiffnesses k_n (N/m), the wall's normal speed for the next step is
//     u = relaxation (pressure A - F) / (K dt),   capped at |u| <= max_speed,
// A the cell's cross-section across the wall's axis (V / L_axis): moving by u dt with the spheres
// held still corrects the fraction 'relaxation' of the force error; without a contact (K = 0)
// the wall approaches at max_speed. u > 0 moves the wall along its normal, into the spheres.
// The velocity's part in the wall's plane is kept (a drag, as for a moving wall). The servo reads
// the elastic push, not the total: with normal dashpots the total holds c_n u from the wall's
// own speed, which fed back through the gain 1 / (K dt) makes the servo chatter between +-cap;
// at rest the two are equal.
#pragma once
#include "core/cell.hpp"
#include "core/contact_list.hpp"
#include "core/domain.hpp"
#include "core/exact_sum.hpp"

#include <span>
#include <vector>

namespace fabrica {

// Number of servo walls in 'walls'.
std::size_t servo_wall_count(const std::vector<Wall>& walls);

// The servo update of every servo wall. 'load' holds, per wall of 'walls' (servo or not), the
// pair {push F [N], stiffness K [N/m]}, summed over every rank.
void update_servo_walls(std::vector<Wall>& walls, std::span<const double> load, const PeriodicCell& cell, real_t dt);

// The normal speed the servo gives one wall (the formula above).
real_t servo_speed(const Wall& w, real_t push, real_t stiffness, real_t area, real_t dt);

// The servo walls' loads over one force computation: the exact sums of push and stiffness per
// wall (ForceContext::wall_load), kept between steps so that a step allocates nothing.
class ServoWallLoads {
 public:
  // The sums, zero, for 'n_walls' walls.
  ExactSums* start(std::size_t n_walls);
  // The sums reduced over the ranks, then update_servo_walls: the walls' velocities for the next
  // step, the same on every rank and rank count.
  void finish(Domain& domain, std::vector<Wall>& walls, const PeriodicCell& cell, real_t dt);

 private:
  ExactSums sums_;
  std::vector<double> load_;  // their values (the last step)
};

}  // namespace fabrica
