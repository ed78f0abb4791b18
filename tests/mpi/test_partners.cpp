// Neighbour-only communication at 1 to 16 ranks (issue: large specimens). A long specimen
// (0.08 x 0.08 x 0.64 m, 2,000 spheres moving at random) is compressed along its long axis by
// 35 % and extended across it, so that its bins thin out and the domain is decomposed anew
// (and particles cross many subdomain boundaries). Checked against the serial run of the same
// scene, by id, on every rank:
//  - the trajectory is the serial one bit for bit (positions, velocities, spins, contacts);
//  - ghosts and migrants travel only between partners (ranks owning bins within reach): on 8
//    and 16 ranks, a rank has fewer partners than there are other ranks, and migrations between
//    decompositions were point to point (all-to-all only right after a new decomposition).
#include "core/generate.hpp"
#include "core/simulation.hpp"
#include "core/timestep.hpp"
#include "parallel/mpi_domain.hpp"

#include "mpi_test_helpers.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <unordered_map>

using namespace fabrica;

namespace {

using test::comm_rank;
using test::comm_size;
using test::max_all;
using test::sum_all;

struct Scene {
  Particles p;
  PeriodicCell cell;
  SimulationParams par;
};

Scene long_specimen() {
  Scene s;
  Random rng(2026);
  const std::vector<real_t> d = fractal_diameters(2000, 1.9, 0.008, 0.016, rng);
  const Vec3 L(0.08, 0.08, 0.64);
  s.cell = PeriodicCell(L);
  s.p = random_packing(d, 2650, s.cell, rng);
  for (std::size_t a = 0; a < s.p.n_owned(); ++a)
    s.p.v[a] = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 0.4;
  s.par.law.stiffness_mode = NormalStiffnessMode::Direct;
  s.par.law.normal_stiffness = 1e5;
  s.par.law.friction = 0.3;
  s.par.law.rolling_friction = 0.1;
  s.par.law.damping_ratio_n = 0.1;
  s.par.skin = 0.001;
  s.par.dt = 0.3 * critical_time_step(s.p, s.par.law, false);
  return s;
}

}  // namespace

TEST(Partners, SameTrajectoryAndNeighbourOnlyExchangesUnderLargeDeformation) {
  Scene s = long_specimen();
  const int steps = 1000;
  // -35 % along axis 3 over the run, +20 % along axes 1 and 2 (strain rates of the cell).
  const real_t T = steps * s.par.dt;
  s.cell.set_strain_rate(Vec3(std::log(1.2) / T, std::log(1.2) / T, std::log(0.65) / T));
  Simulation serial(s.p, s.cell, s.par);
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation par(s.p, s.cell, s.par, &domain);
  const int partners_at_start = int(domain.partners().size());
  for (int k = 1; k <= steps; ++k) {
    serial.step(k % 500 == 0);
    par.step(k % 500 == 0);
  }
  EXPECT_LT(serial.cell().lengths()[2], 0.66 * 0.64);
  EXPECT_GT(serial.cell().lengths()[0], 1.19 * 0.08);

  std::unordered_map<GlobalId, std::size_t> at;
  const Particles& S = serial.particles();
  for (std::size_t a = 0; a < S.n_owned(); ++a) at[S.id[a]] = a;
  const Particles& P = par.particles();
  double dx = 0, dv = 0, dw = 0;
  for (std::size_t a = 0; a < P.n_owned(); ++a) {
    const std::size_t b = at.at(P.id[a]);
    dx = std::max(dx, (P.x[a] - S.x[b]).cwiseAbs().maxCoeff());
    dv = std::max(dv, (P.v[a] - S.v[b]).cwiseAbs().maxCoeff());
    dw = std::max(dw, (P.w[a] - S.w[b]).cwiseAbs().maxCoeff());
  }
  EXPECT_EQ(sum_all((long long)P.n_owned()), (long long)S.n_owned());
  EXPECT_EQ(max_all(dx), 0.0) << "positions differ from the serial run";
  EXPECT_EQ(max_all(dv), 0.0);
  EXPECT_EQ(max_all(dw), 0.0);
  EXPECT_EQ(par.macro().contacts, serial.macro().contacts);
  EXPECT_GT(serial.macro().contacts, 100);
  EXPECT_GT(serial.rebuild_count(), 10);

  const int P_ = comm_size();
  const DomainStats& st = domain.stats();
  if (P_ > 1) {
    EXPECT_GT(sum_all((long long)st.particles_migrated), 20) << "the particles did cross subdomains";
    EXPECT_GE(st.migrations_all_to_all, 1) << "the deformation made a new decomposition";
    EXPECT_LE(st.migrations_all_to_all, 3) << "a new decomposition survives 20 % of strain";
    EXPECT_GT(st.migrations - st.migrations_all_to_all, 4 * st.migrations_all_to_all)
        << "most migrations were point to point";
  }
  if (P_ >= 8) {
    EXPECT_LT(partners_at_start, P_ - 1) << "a rank exchanges with its partners only";
    EXPECT_LT(int(domain.partners().size()), P_ - 1);
  }
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0)
    std::printf(
        "[partners] %d ranks: %d partners at the start, %d at the end; %lld migrations, "
        "%lld of them all-to-all; %lld particles migrated by rank 0\n",
        P_, partners_at_start, int(domain.partners().size()), (long long)st.migrations,
        (long long)st.migrations_all_to_all, (long long)st.particles_migrated);
}
