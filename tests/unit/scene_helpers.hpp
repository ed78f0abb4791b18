// Small scene builders shared by the verification tests (docs/verification.md).
#pragma once
#include "core/simulation.hpp"

#include <cmath>
#include <numbers>
#include <vector>

namespace fabrica::test {

inline constexpr real_t kRho = 2650.0;  // kg/m^3

inline real_t sphere_mass(real_t R, real_t rho = kRho) { return rho * 4.0 / 3.0 * std::numbers::pi * R * R * R; }

// Particles from a list of initial states (ids in list order).
inline Particles make_particles(const std::vector<SphereInit>& s) {
  Particles p;
  for (const auto& q : s) p.add(q);
  return p;
}

// A simulation in a cubic periodic cell of side L (default 1 m, "isolated" spheres).
inline Simulation make_sim(Particles p, const ContactLawParams& law, real_t dt, real_t skin,
                           std::vector<Wall> walls = {}, Vec3 gravity = Vec3::Zero(), real_t L = 1.0) {
  SimulationParams sp;
  sp.law = law;
  sp.dt = dt;
  sp.skin = skin;
  sp.walls = std::move(walls);
  sp.gravity = gravity;
  return Simulation(std::move(p), PeriodicCell(Vec3::Constant(L)), sp);
}

// Law with the normal stiffness given directly.
inline ContactLawParams direct_law(real_t kn, real_t mu_s, real_t mu_r = 0.0, real_t kappa = 1.0) {
  ContactLawParams law;
  law.stiffness_mode = NormalStiffnessMode::Direct;
  law.normal_stiffness = kn;
  law.stiffness_ratio = kappa;
  law.friction = mu_s;
  law.rolling_friction = mu_r;
  return law;
}

// Index of the particle with global id 'id' (the engine reorders particles at rebuilds).
inline std::size_t index_of(const Particles& p, GlobalId id) {
  for (std::size_t a = 0; a < p.size(); ++a)
    if (p.id[a] == id) return a;
  return p.size();
}

}  // namespace fabrica::test
