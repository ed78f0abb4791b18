// Rank-count independence in a sheared cell (issue 42). A granular gas of 2,000 polydisperse
// spheres (solid fraction 0.35, random velocities, so that contacts open and close all the
// time) is sheared in simple shear (G21) from the orthorhombic cell to a shear strain of 2.2,
// through two flips of the cell (at tilts of 0.6 of the edge, core/cell.hpp), the heights
// between its faces staying above 0.8 of the edge, serially on every rank and over all
// ranks (Cartesian and METIS decompositions): the parallel owners' positions, velocities and
// spins must equal the serial run's bit for bit, as in an orthorhombic cell
// (tests/mpi/test_decomposition.cpp). Registered at 2, 4 and 16 ranks (8 passes too; left out
// for the suite's time).
#include "core/generate.hpp"
#include "core/simulation.hpp"
#include "parallel/mpi_domain.hpp"

#include "compare_runs.hpp"
#include "mpi_test_helpers.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

using namespace fabrica;

namespace {

using test::comm_rank;
using test::comm_size;
using test::max_all;
using test::sum_all;

struct Gas {
  Particles particles;
  PeriodicCell cell;
  SimulationParams params;
};

Gas make_gas() {
  Random rng(2026);
  std::vector<real_t> d = fractal_diameters(2000, 2.0, 0.004, 0.012, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  Gas g;
  g.cell = PeriodicCell(Vec3::Constant(std::cbrt(vs / 0.35)));
  g.particles = random_packing(d, 2650.0, g.cell, rng);
  for (std::size_t a = 0; a < g.particles.n_owned(); ++a)
    g.particles.v[a] = 0.05 * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
  g.params.law.stiffness_mode = NormalStiffnessMode::Direct;
  g.params.law.normal_stiffness = 2e4;
  g.params.law.friction = 0.5;
  g.params.law.damping_ratio_n = 0.3;
  const real_t m = 2650.0 * std::numbers::pi / 6 * 0.004 * 0.004 * 0.004;
  g.params.dt = 0.1 * std::sqrt(m / 2e4);
  g.params.skin = 0.001;
  return g;
}

using test::compare;
using test::Diff;

class ShearedRun : public ::testing::TestWithParam<DecompositionKind> {};

}  // namespace

TEST_P(ShearedRun, SameTrajectoryOnEveryRankCountThroughAFlip) {
  const Gas g = make_gas();
  MpiDomainOptions opt;
  opt.kind = GetParam();
  MpiDomain domain(MPI_COMM_WORLD, opt);
  Simulation serial(g.particles, g.cell, g.params);
  Simulation par(g.particles, g.cell, g.params, &domain);
  const int steps = 2200;
  Mat3 G = Mat3::Zero();
  G(1, 0) = 2.2 / (steps * g.params.dt);  // a shear strain of 2.2
  serial.cell().set_velocity_gradient(G);
  par.cell().set_velocity_gradient(G);
  int flips = 0;
  real_t lowest = 1;  // the smallest height over the edge length
  for (int k = 1; k <= steps; ++k) {
    const real_t tilt = serial.cell().matrix()(1, 0);
    serial.step(k % 500 == 0);
    par.step(k % 500 == 0);
    flips += serial.cell().matrix()(1, 0) < tilt - 0.5 * serial.cell().matrix()(1, 1);
    lowest = std::min(lowest, serial.cell().heights().minCoeff() / g.cell.lengths()[0]);
  }
  EXPECT_EQ(flips, 2);
  EXPECT_GT(lowest, 0.8);  // 0.86 at the flip ratio, less the tilt taken before the next rebuild
  EXPECT_NEAR(2 * serial.cell().strain()(0, 1), 2.2, 1e-9);  // the engineering shear strain
  EXPECT_EQ(par.cell().matrix(), serial.cell().matrix());
  const Diff d = compare(par, serial);
  EXPECT_EQ(d.compared, std::int64_t(g.particles.n_owned()));  // every particle owned exactly once
  EXPECT_EQ(d.x, 0.0) << "positions differ from the serial run by " << d.x << " m";
  EXPECT_EQ(d.v, 0.0);
  EXPECT_EQ(d.w, 0.0);
  EXPECT_EQ(par.macro().contacts, serial.macro().contacts);
  EXPECT_GT(serial.macro().contacts, 100);  // a gas that collides
  EXPECT_EQ(par.rebuild_count(), serial.rebuild_count());
  EXPECT_GT(serial.rebuild_count(), 5);
  EXPECT_NEAR(par.macro().stress(0, 1), serial.macro().stress(0, 1), 1e-9 * serial.macro().p);
  if (comm_rank() == 0 && comm_size() > 1)
    std::printf("ranks %d %s: %lld contacts, %lld rebuilds, migrated %lld\n", comm_size(),
                GetParam() == DecompositionKind::Metis ? "metis" : "cartesian", (long long)par.macro().contacts,
                (long long)par.rebuild_count(), (long long)domain.stats().particles_migrated);
}

INSTANTIATE_TEST_SUITE_P(Kinds, ShearedRun, ::testing::Values(DecompositionKind::Cartesian, DecompositionKind::Metis),
                         [](const auto& info) {
                           return info.param == DecompositionKind::Metis ? std::string("Metis")
                                                                         : std::string("Cartesian");
                         });
