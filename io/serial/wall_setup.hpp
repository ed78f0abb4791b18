// The walls of a scene ([[wall]], docs/scene.md "Walls") in a set-up: the planes checked against
// the cell, every sphere checked against every plane, and the critical time step with the
// walls' contact laws.
#pragma once
#include "core/cell.hpp"
#include "core/contact_list.hpp"
#include "core/particles.hpp"
#include "io/serial/scene.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

// The scene's walls as the core takes them. Throws InputError (file, wall, field, value) for a
// wall whose plane lies outside the cell along its axis, or two facing walls with no room
// between them or spanning the whole cell (the cell is periodic along every axis: spheres near
// the two walls would touch through the periodic boundary).
std::vector<Wall> scene_walls(const Scene& scene, const PeriodicCell& cell);

// A servo wall without [[wall]] max_speed moves at most this fraction of the smallest sphere
// radius per time step.
inline constexpr real_t kServoStepFraction = 1e-3;
// The speed cap of each servo wall without max_speed: kServoStepFraction rmin / dt (rmin: of all
// particles; dt: the run's time step).
void set_servo_speed_caps(std::vector<Wall>& walls, real_t rmin, real_t dt);

// A sphere of 'p' (owned ones) that starts with its centre on or behind a wall, or overlapping
// it by more than [run] max_initial_overlap of its radius: of the first wall with such a
// sphere, the one with the smallest id (so that the same sphere is named on any rank count);
// wall = walls.size() if there is none.
struct WallOffence {
  std::size_t wall, particle;
};
WallOffence first_wall_offence(const Scene& scene, const std::vector<Wall>& walls, const Particles& p);
// Throws its InputError (file, wall, particle id, value).
[[noreturn]] void refuse_wall_offence(const Scene& scene, const std::vector<Wall>& walls, const Particles& p,
                                      WallOffence o);

// The critical time step (core/timestep.hpp) with the walls: the scene's law with a wall as a
// partner, and each wall's own law; +infinity without walls. rmin, rmax: of all particles.
real_t walls_critical_time_step(const Scene& scene, const Particles& p, real_t rmin, real_t rmax,
                                const Materials* materials = nullptr);

// [[driven]]: how many particles of 'p' (owned ones) each set names; with the sums over every
// rank's part, check_driven_counts throws InputError for a set naming an id that is not a
// particle of the specimen.
std::vector<std::int64_t> driven_counts(const Scene& scene, const Particles& p);
void check_driven_counts(const Scene& scene, const std::vector<std::int64_t>& counts);

}  // namespace fabrica
