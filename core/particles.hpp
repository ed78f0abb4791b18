// Sphere storage, structure of arrays. Owned particles occupy [0, n_owned); ghost copies of
// particles owned elsewhere (or periodic images) follow them in [n_owned, size()).
#pragma once
#include "core/types.hpp"

#include <span>
#include <vector>

namespace fabrica {

struct SphereInit {
  GlobalId id;
  real_t radius;   // m
  real_t density;  // kg/m^3
  Vec3 x;          // m
  Vec3 v = Vec3::Zero();  // m/s (fluctuating velocity, see docs/design.md)
  Vec3 w = Vec3::Zero();  // rad/s
};

class Particles {
 public:
  // Per-particle state. v is the velocity relative to the affine field of the deforming cell.
  std::vector<Vec3> x, v, w;       // position (m), velocity (m/s), spin (rad/s)
  std::vector<Vec3> f, t;          // force (N) and torque (N m) accumulators
  std::vector<real_t> radius;      // m
  std::vector<real_t> mass;        // kg
  std::vector<real_t> inertia;     // kg m^2 (solid sphere: 2/5 m R^2)
  std::vector<real_t> inv_mass;    // 1/kg
  std::vector<real_t> inv_inertia; // 1/(kg m^2)
  std::vector<GlobalId> id;

  std::size_t size() const { return id.size(); }
  std::size_t n_owned() const { return n_owned_; }
  std::size_t n_ghost() const { return size() - n_owned_; }

  // Appends an owned particle (only valid while there are no ghosts).
  void add(const SphereInit& s);
  // Drops every ghost.
  void clear_ghosts() { resize(n_owned_); }
  // Reorders the owned particles: new index k holds old index order[k]; 'order' may list a
  // subset, and the others are dropped (particles that migrated away). Ghosts are dropped.
  void permute_owned(std::span<const Index> order);
  // Appends n default particles (all zero, id -1) as owned (only without ghosts) or as ghosts;
  // returns the index of the first. The caller fills them (parallel/ unpacking).
  std::size_t append_owned(std::size_t n);
  std::size_t append_ghosts(std::size_t n);
  void reserve(std::size_t n);
  // Room for n more particles (ghosts about to arrive) in one reallocation, with an eighth of n
  // to spare for the next rebuild; nothing if there is room. Appending without it grows each
  // array by doubling: at 869,376 spheres on 2 ranks, 73 MB of spare capacity per rank.
  void reserve_more(std::size_t n);
  std::size_t capacity() const { return id.capacity(); }
  // The force and torque accumulators freed (the rebuild's peak memory at large N: 48 bytes per
  // particle), while nothing reads them; zero_forces() makes them again, every entry zero. In
  // between, no other member may be called but those that read x, radius and id.
  void release_forces();
  void zero_forces();
  // Density scaling: every mass and moment of inertia (ghosts included) times f, inverses
  // recomputed.
  void scale_density(real_t f);

  real_t max_radius() const;
  real_t min_radius() const;
  real_t solid_volume() const;

 private:
  void resize(std::size_t n);
  std::size_t n_owned_ = 0;
};

}  // namespace fabrica
