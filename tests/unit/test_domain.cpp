// The serial domain (core/serial_domain.hpp) and how a Simulation is copied: Domain is
// abstract; a Simulation has no public plain copy (it would share the source's domain), only
// the branching constructor; a moved or branched serial run communicates through the shared
// stateless SerialDomain and continues bit for bit like its source.
#include "core/serial_domain.hpp"
#include "core/simulation.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <type_traits>

namespace fabrica {
namespace {

static_assert(std::is_abstract_v<Domain>);
static_assert(!std::is_copy_constructible_v<Simulation>);
static_assert(!std::is_copy_assignable_v<Simulation>);
static_assert(std::is_move_constructible_v<Simulation>);

// The identity reductions of one process.
TEST(SerialDomain, ReductionsAreTheIdentity) {
  SerialDomain d;
  EXPECT_EQ(d.max_all(2.5), 2.5);
  double v[2] = {1.5, -3.0};
  d.sum_all(std::span<double>(v, 2));
  d.max_all(std::span<double>(v, 2));
  EXPECT_EQ(v[0], 1.5);
  EXPECT_EQ(v[1], -3.0);
  std::int64_t n[1] = {7};
  d.sum_all(std::span<std::int64_t>(n, 1));
  EXPECT_EQ(n[0], 7);
  EXPECT_EQ(d.rank(), 0);
  EXPECT_EQ(d.size(), 1);
  EXPECT_TRUE(d.decomposition_record().empty());
  EXPECT_NE(dynamic_cast<SerialDomain*>(d.clone().get()), nullptr);
}

// Two spheres in contact, 300 steps: the source, a move of it, and a branch of it each use the
// shared serial domain, and the branch continues exactly as the source does.
TEST(SerialDomain, MovedAndBranchedRunsKeepAValidDomain) {
  auto make = [] {
    Particles p = test::make_particles({{0, 0.01, test::kRho, Vec3(0.3, 0.5, 0.5), Vec3(0.2, 0.05, 0)},
                                        {1, 0.01, test::kRho, Vec3(0.3199, 0.5, 0.5), Vec3(-0.2, 0, 0)}});
    return test::make_sim(std::move(p), test::direct_law(1e4, 0.3, 0.1), 1e-5, 0.002);
  };
  Simulation a = make();
  for (int s = 0; s < 100; ++s) a.step();
  Simulation moved(std::move(a));
  EXPECT_EQ(&moved.domain(), &serial_domain());
  Simulation branch(moved, nullptr);
  EXPECT_EQ(&branch.domain(), &serial_domain());
  for (int s = 0; s < 200; ++s) moved.step(s == 199), branch.step(s == 199);
  EXPECT_GT(moved.macro().contacts + moved.dissipation().friction, 0.0);  // they did interact
  for (std::size_t q = 0; q < moved.particles().n_owned(); ++q) {
    EXPECT_EQ(moved.particles().x[q], branch.particles().x[q]);
    EXPECT_EQ(moved.particles().w[q], branch.particles().w[q]);
  }
  EXPECT_EQ(moved.macro().stress, branch.macro().stress);
}

}  // namespace
}  // namespace fabrica
