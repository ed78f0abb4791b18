// The largest difference of x, v, w between a parallel run's owners and a serial run of the same
// scene, particle by particle (by id), over all ranks; and how many particles the ranks own in
// all (each exactly once: the particle count). Shared by the rank-count independence tests.
#pragma once
#include "core/simulation.hpp"

#include "mpi_test_helpers.hpp"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

namespace fabrica::test {

struct Diff {
  double x = 0, v = 0, w = 0;
  std::int64_t compared = 0;
};

inline Diff compare(const Simulation& par, const Simulation& ser) {
  const Particles& P = par.particles();
  const Particles& S = ser.particles();
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < S.n_owned(); ++a) at[S.id[a]] = a;
  Diff d;
  for (std::size_t a = 0; a < P.n_owned(); ++a) {
    const std::size_t b = at.at(P.id[a]);
    d.x = std::max(d.x, (P.x[a] - S.x[b]).cwiseAbs().maxCoeff());
    d.v = std::max(d.v, (P.v[a] - S.v[b]).cwiseAbs().maxCoeff());
    d.w = std::max(d.w, (P.w[a] - S.w[b]).cwiseAbs().maxCoeff());
  }
  d.x = max_all(d.x), d.v = max_all(d.v), d.w = max_all(d.w);
  d.compared = std::int64_t(sum_all(double(P.n_owned())));
  return d;
}

}  // namespace fabrica::test
