// Sphere storage, structure of arrays. Owned particles occupy [0, n_owned); ghost copies of
// particles owned elsewhere (or periodic images) follow them in [n_owned, size()).
#pragma once
#include "core/types.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace fabrica {

struct SphereInit {
  GlobalId id;
  real_t radius;              // m
  real_t density;             // kg/m^3
  Vec3 x;                     // m
  Vec3 v = Vec3::Zero();      // m/s (fluctuating velocity, see docs/design.md)
  Vec3 w = Vec3::Zero();      // rad/s
  std::uint8_t material = 0;  // its material (core/contact/materials.hpp; 0 with one material)
};

class Particles {
 public:
  // Per-particle state. v is the velocity relative to the affine field of the deforming cell.
  std::vector<Vec3> x, v, w;   // position (m), velocity (m/s), spin (rad/s)
  std::vector<Vec3> f, t;      // force (N) and torque (N m) accumulators
  std::vector<real_t> radius;  // m
  std::vector<real_t> mass;    // kg
  std::vector<GlobalId> id;
  // The material of each sphere (core/contact/materials.hpp): all 0 in a scene of one material.
  std::vector<std::uint8_t> material;

  // The moment of inertia of a solid sphere, 2/5 m R^2, and the inverses the half kicks use are
  // derived from mass and radius where they are needed, not stored (24 bytes per particle):
  // each is the one expression every use evaluates, so a value is the same bits wherever it
  // is computed (core/integrator.hpp inverse_masses, the vectorised form).
  real_t inertia(std::size_t a) const { return 0.4 * mass[a] * radius[a] * radius[a]; }
  real_t inv_mass(std::size_t a) const { return 1.0 / mass[a]; }
  real_t inv_inertia(std::size_t a) const { return 1.0 / inertia(a); }

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
  // between, reordering and ghosts leave f and t out (permute_owned, reserve, reserve_more,
  // append_ghosts, clear_ghosts), and no other member may be called but those that read x,
  // radius and id.
  void release_forces();
  void zero_forces();
  // Density scaling: every mass (ghosts included) times f; the moments of inertia and the
  // inverses follow, being derived.
  void scale_density(real_t f);

  real_t max_radius() const;
  real_t min_radius() const;
  real_t solid_volume() const;

 private:
  void resize(std::size_t n);
  std::size_t n_owned_ = 0;
  bool forces_released_ = false;  // release_forces() until zero_forces()
};

}  // namespace fabrica
