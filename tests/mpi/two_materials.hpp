// Two materials on a set-up (the MPI tests' dense specimen): every third sphere (by id) of
// material 1, twice as dense, three times as stiff, of another friction and rolling friction
// than material 0 (the set-up's law); the time step re-estimated for the pairs.
#pragma once
#include "core/timestep.hpp"
#include "io/serial/setup.hpp"

namespace fabrica::test {

inline void two_materials(fabrica::Setup& s) {
  ContactLawParams b = s.params.law;
  b.youngs_modulus *= 3;
  b.friction = 0.5;
  b.rolling_friction = b.rolling_friction > 0 ? 2 * b.rolling_friction : 0.2;
  s.params.materials.names = {"a", "b"};
  s.params.materials.laws = {s.params.law, b};
  s.params.materials.mix_pairs();
  Particles& p = s.particles;
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    if (p.id[a] % 3 == 0) p.material[a] = 1, p.mass[a] *= 2;
  s.params.dt = 0.25 * critical_time_step(p, s.params.law, false, &s.params.materials);
}

}  // namespace fabrica::test
