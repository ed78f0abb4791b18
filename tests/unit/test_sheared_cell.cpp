// The sheared (parallelepiped) periodic cell (core/cell.hpp, issue 42):
//  - its geometry: wrapping into fractional coordinates [0, 1), the minimum image of any
//    lattice shift of a short vector, the heights between opposite faces, and a flip
//    (reduce()) that keeps the lattice of images (H_old^-1 H_new an integer matrix of
//    determinant 1) and brings every tilt back within the flip ratio;
//  - the neighbour search in a sheared cell against brute force (minimum image), with grids of
//    3 or more cells per axis and of fewer, before and after a flip;
//  - the affine simple shear of elastic FCC and simple cubic lattices against their shear
//    moduli from k_n and k_s: for linear springs between nearest neighbours of an FCC lattice
//    of cube edge a, G = (k_n + k_s) / a; of a simple cubic lattice of spacing a, G = k_s / (2 a)
//    (each bond's spring force from the affine relative displacement, summed over the bonds of
//    one sphere and divided by its volume); with the energy balance of the elastic lattice;
//  - a pair touching across a sheared face keeps its branch vector, force and spring through
//    a flip of the cell;
//  - a rigid rotation of a sheared specimen rotates its stress and keeps its invariants.
#include "core/guards.hpp"
#include "core/neighbor.hpp"
#include "core/generate.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <utility>
#include <vector>

namespace fabrica {
namespace {

using test::direct_law;

Mat3 tilted(real_t L, real_t t21, real_t t31, real_t t32) {
  Mat3 h = Mat3::Identity() * L;
  h(1, 0) = t21 * L;  // edge 1 leans along axis 2 (simple shear of planes normal to axis 1)
  h(2, 0) = t31 * L;
  h(2, 1) = t32 * L;
  return h;
}

TEST(ShearedCell, WrapAndMinimumImage) {
  const PeriodicCell cell = PeriodicCell::from_matrix(tilted(1.0, 0.45, -0.3, 0.2));
  ASSERT_TRUE(cell.sheared());
  Random rng(7);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 x(4 * rng.uniform() - 2, 4 * rng.uniform() - 2, 4 * rng.uniform() - 2);
    const Vec3 w = cell.wrap(x);
    const Vec3 s = cell.fractional(w);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(s[a], 0.0);
      EXPECT_LT(s[a], 1.0);
    }
    const Vec3 n = cell.fractional(w - x);  // an image: integer fractional shift
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(n[a], std::nearbyint(n[a]), 1e-12);
    // A short vector (below half the smallest height) seen through any image is itself.
    const Vec3 d =
        0.3 * cell.heights().minCoeff() * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
    const Vec3 far = d + cell.image_shift(int(rng.uniform() * 5) - 2, int(rng.uniform() * 5) - 2, 1);
    EXPECT_LT((cell.minimum_image(far) - d).norm(), 1e-12);
  }
  // Heights: the volume over the area of the other two edges' face.
  const Mat3 H = cell.matrix();
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(cell.heights()[k], H.determinant() / H.col((k + 1) % 3).cross(H.col((k + 2) % 3)).norm(), 1e-14);
}

TEST(ShearedCell, FlipKeepsTheLatticeAndUprightsTheEdges) {
  for (const Vec3 t : {Vec3(0.61, 0, 0), Vec3(1.7, 0, 0), Vec3(-0.65, 0.7, -0.9), Vec3(2.2, -1.4, 0.8)}) {
    PeriodicCell cell = PeriodicCell::from_matrix(tilted(1.0, t[0], t[1], t[2]));
    const Mat3 before = cell.matrix();
    ASSERT_TRUE(cell.reduce());
    const Mat3 after = cell.matrix();
    const Mat3 m = before.inverse() * after;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) EXPECT_NEAR(m(a, b), std::nearbyint(m(a, b)), 1e-12);
    EXPECT_NEAR(std::abs(m.determinant()), 1.0, 1e-12);
    EXPECT_NEAR(cell.volume(), before.determinant(), 1e-12);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (i != j)
          EXPECT_LE(std::abs(after.col(i).dot(after.col(j)) / after.col(j).squaredNorm()), PeriodicCell::kFlipRatio);
    EXPECT_FALSE(cell.reduce());  // nothing left to flip
  }
  PeriodicCell upright = PeriodicCell::from_matrix(tilted(1.0, 0.59, 0, 0));
  EXPECT_FALSE(upright.reduce());
}

// n spheres of radii in [rmin, 3 rmin] at random fractional positions of the cell.
Particles random_spheres(const PeriodicCell& cell, int n, real_t rmin, Random& rng) {
  Particles p;
  for (int k = 0; k < n; ++k)
    p.add({GlobalId(k), rmin * (1 + 2 * rng.uniform()), 2650.0,
           cell.cartesian(Vec3(rng.uniform(), rng.uniform(), rng.uniform()))});
  return p;
}

std::vector<std::pair<GlobalId, GlobalId>> listed(const Particles& p, const PeriodicCell& cell, const PairList& pl) {
  std::vector<std::pair<GlobalId, GlobalId>> out;
  for (std::size_t q = 0; q < pl.size(); ++q) {
    const Index i = pl.i[q], j = pl.j[q];
    const Vec3 d = p.x[j] + image_offset(pl.image[q], cell) - p.x[i];
    EXPECT_LT((d - cell.minimum_image(p.x[j] - p.x[i])).norm(), 1e-12) << "wrong image";
    out.emplace_back(p.id[i], p.id[j]);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ShearedCell, NeighbourSearchAgainstBruteForce) {
  Random rng(11);
  // (tilts, rmin): many grid cells per axis, then fewer than 3 (the per-candidate image).
  for (const auto& [t, rmin] : {std::pair{Vec3(0.45, 0.0, 0.0), 0.01}, std::pair{Vec3(-0.58, 0.3, -0.4), 0.012},
                                std::pair{Vec3(0.5, 0.2, 0.1), 0.06}, std::pair{Vec3(1.4, 0.0, 0.0), 0.01}}) {
    PeriodicCell cell = PeriodicCell::from_matrix(tilted(1.0, t[0], t[1], t[2]));
    cell.reduce();  // the last case is flipped first
    Particles p = random_spheres(cell, 1500, rmin, rng);
    const real_t skin = 0.3 * rmin;
    check_cell_size(cell, p.max_radius(), skin);
    NeighborSearch search;
    PairList pl;
    search.build(p, cell, skin, pl);
    const auto found = listed(p, cell, pl);
    const auto truth = brute_force_pairs(p, cell, skin);
    EXPECT_GT(truth.size(), 100u);
    EXPECT_EQ(found, truth) << "tilts " << t.transpose() << ", rmin " << rmin;
  }
}

TEST(ShearedCell, TooThinAfterShearIsRefusedWithItsHeight) {
  const PeriodicCell cell = PeriodicCell::from_matrix(tilted(0.1, 3.0, 0, 0));  // h2 = L / sqrt(10)
  try {
    check_cell_size(cell, 0.01, 0.002);
    FAIL() << "not refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("sheared periodic cell height h"), std::string::npos) << e.what();
  }
}

// The guard of every rebuild (core/guards.cpp) names a sheared cell's height.
TEST(ShearedCell, ThinnedDuringARunStopsItWithItsHeight) {
  StepGuards guards;
  guards.check_cell(PeriodicCell::from_matrix(tilted(0.1, 0.3, 0, 0)), 0.02, 0.002, 41);
  EXPECT_TRUE(guards.message().empty()) << guards.message();
  guards.check_cell(PeriodicCell::from_matrix(tilted(0.1, 3.0, 0, 0)), 0.02, 0.002, 41);
  EXPECT_NE(guards.message().find("at step 42: the sheared periodic cell has thinned to a height h2 = 0.0316228 m, "
                                  "no longer above 2 (2 Rmax + skin) = 0.04 m"),
            std::string::npos)
      << guards.message();
}

// A lattice of cube edge a, n x n x n cubes, with basis points b (in units of a), spheres of
// radius R whose nearest neighbours overlap by 'overlap', linear springs k_n = k_s = kn. The
// shear strains asked of it keep the tangential spring displacement (gamma a / 2) below the
// friction limit mu_s overlap, and the pre-stress's share of the shear stiffness (of order
// overlap / a, 1e-5) below the tolerance.
struct Lattice {
  real_t R = 0.01, kn = 1e8, overlap = 2e-7, a = 0;
  int n = 3;
  std::vector<Vec3> basis;
  Simulation make(real_t dt_fraction = 0.05) const {
    Particles p;
    GlobalId id = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k)
          for (const Vec3& b : basis) p.add({id++, R, 2650.0, (Vec3(i, j, k) + b + Vec3::Constant(0.25)) * a});
    SimulationParams sp;
    sp.law = direct_law(kn, 10.0);  // mu_s = 10: no sliding at these strains
    sp.dt = dt_fraction * std::sqrt(test::sphere_mass(R) / kn);
    sp.skin = 0.002;
    return Simulation(std::move(p), PeriodicCell(Vec3::Constant(n * a)), sp);
  }
};

Lattice fcc() {
  Lattice l;
  l.a = std::sqrt(2.0) * (2 * l.R - l.overlap);
  l.basis = {Vec3(0, 0, 0), Vec3(0.5, 0.5, 0), Vec3(0.5, 0, 0.5), Vec3(0, 0.5, 0.5)};
  return l;
}

Lattice simple_cubic() {
  Lattice l;
  l.a = 2 * l.R - l.overlap;
  l.n = 4;
  l.basis = {Vec3(0, 0, 0)};
  return l;
}

// Shears the lattice at engineering rate gd (g21 = gd: simple shear, planes normal to axis 1
// sliding along axis 2; pure = true: g12 = g21 = gd / 2, no rotation) to the shear strain gamma;
// returns the shear stress s12 over gamma (compression positive: the shear stress of a positive
// shear is negative) and the energy balance's error relative to the elastic energy.
std::pair<real_t, real_t> shear_modulus(const Lattice& l, bool pure, real_t gamma) {
  Simulation sim = l.make();
  const real_t period = 2 * std::numbers::pi * std::sqrt(test::sphere_mass(l.R) / l.kn);
  const real_t gd = gamma / (400 * period);  // quasi-static: 400 periods of a contact
  Mat3 g = Mat3::Zero();
  if (pure) g(0, 1) = g(1, 0) = 0.5 * gd;
  else g(1, 0) = gd;
  sim.cell().set_velocity_gradient(g);
  // The spheres spin with the material from the start (the field's vorticity (g21 - g12) / 2
  // about axis 3), as they would after the first instants of a slow shear.
  for (std::size_t a = 0; a < sim.particles().n_owned(); ++a)
    sim.particles().w[a] = Vec3(0, 0, 0.5 * (g(1, 0) - g(0, 1)));
  const auto steps = std::int64_t(std::llround(gamma / (gd * sim.params().dt)));
  const real_t s0 = sim.macro().stress(0, 1);
  for (std::int64_t k = 0; k < steps; ++k) sim.step(k + 1 == steps);
  const real_t done = steps * sim.params().dt * gd;
  const MacroState& m = sim.macro();
  const real_t elastic = m.e_normal + m.e_shear + m.kinetic;
  return {(m.stress(0, 1) - s0) / done, std::abs(m.energy_input - elastic - m.dissipated.friction) / elastic};
}

TEST(ShearedCell, AffineShearOfAnFccLatticeAgainstItsShearModulus) {
  const Lattice l = fcc();
  const real_t G = (l.kn + l.kn) / l.a;  // k_n + k_s, k_s = k_n
  for (const bool pure : {true, false}) {
    const auto [tau_per_gamma, energy_error] = shear_modulus(l, pure, 1e-6);
    std::printf("%s, %s: G measured / closed form - 1 = %.2e, energy balance error %.2e\n",
                l.basis.size() == 4 ? "FCC" : "simple cubic", pure ? "pure shear" : "simple shear",
                -tau_per_gamma / G - 1, energy_error);
    EXPECT_NEAR(-tau_per_gamma / G, 1.0, 1e-4) << (pure ? "pure shear" : "simple shear");
    EXPECT_LT(energy_error, 1e-6) << (pure ? "pure shear" : "simple shear");
  }
}

TEST(ShearedCell, AffineShearOfASimpleCubicLatticeAgainstItsShearModulus) {
  const Lattice l = simple_cubic();
  const real_t G = l.kn / (2 * l.a);  // k_s / (2 a)
  for (const bool pure : {true, false}) {
    const auto [tau_per_gamma, energy_error] = shear_modulus(l, pure, 1e-6);
    std::printf("%s, %s: G measured / closed form - 1 = %.2e, energy balance error %.2e\n",
                l.basis.size() == 4 ? "FCC" : "simple cubic", pure ? "pure shear" : "simple shear",
                -tau_per_gamma / G - 1, energy_error);
    EXPECT_NEAR(-tau_per_gamma / G, 1.0, 1e-4) << (pure ? "pure shear" : "simple shear");
    EXPECT_LT(energy_error, 1e-6) << (pure ? "pure shear" : "simple shear");
  }
}

// Two spheres touching across the face between edge 1's ends, held with no motion of their
// own (driven, velocity and spin zero) so that they follow the affine field: sheared at g21
// through a flip of the cell, the pair's branch vector stays F d0 = d0 + gamma d0_1 e2 and its
// (frictionless, linear) force k_n (2 R - |d|) along it, to rounding, before, at and after the
// flip, which wraps a sphere anew.
TEST(ShearedCell, APairAcrossAShearedFaceThroughAFlip) {
  const real_t R = 0.05, L = 0.5, kn = 1e6, overlap = 2e-3;
  PeriodicCell cell = PeriodicCell::from_matrix(tilted(L, 0.55, 0, 0));
  // Sphere 0 near the face s1 = 1, sphere 1 just across it, seen through the image +1 of edge 1.
  const Vec3 x0 = cell.cartesian(Vec3(0.97, 0.5, 0.5));
  const Vec3 d0(2 * R - overlap, 0, 0);
  Particles p;
  p.add({0, R, 2650.0, x0});
  p.add({1, R, 2650.0, cell.wrap(x0 + d0)});
  SimulationParams sp;
  sp.law = direct_law(kn, 0.0);  // frictionless: the force is normal
  sp.dt = 0.05 * std::sqrt(test::sphere_mass(R) / kn);
  sp.skin = 0.01;
  DrivenSet held;
  held.first = 0, held.last = 1;
  sp.driven = {held};
  Simulation sim(std::move(p), cell, sp);
  const int steps = 150;
  const real_t rate = 0.15 / (steps * sp.dt);  // the tilt grows by 0.15 of the edge: past 0.6
  Mat3 g = Mat3::Zero();
  g(1, 0) = rate;
  sim.cell().set_velocity_gradient(g);
  bool flipped = false, rewrapped = false;
  Vec3 last[2] = {sim.particles().x[0], sim.particles().x[1]};
  for (int k = 1; k <= steps; ++k) {
    const real_t tilt = sim.cell().matrix()(1, 0) / L;
    sim.step(true);
    flipped |= sim.cell().matrix()(1, 0) / L < tilt - 0.5;
    const Particles& q = sim.particles();
    const PairList& pl = sim.pairs();
    ASSERT_EQ(pl.size(), 1u) << "step " << k;
    for (int a = 0; a < 2; ++a) {  // a sphere moved by a lattice vector: wrapped anew
      rewrapped |= (q.x[a] - last[q.id[a]]).norm() > 0.5 * L;
      last[q.id[a]] = q.x[a];
    }
    const Vec3 d = q.x[pl.j[0]] + image_offset(pl.image[0], sim.cell()) - q.x[pl.i[0]];
    const Vec3 branch = q.id[pl.i[0]] == 0 ? d : Vec3(-d);
    const real_t gamma = k * sp.dt * rate;
    const Vec3 expect = d0 + gamma * d0[0] * Vec3::UnitY();
    ASSERT_LT((branch - expect).norm(), 1e-12) << "step " << k;
    // The contact stress times V: f (x) d = k_n (2 R - |d|) d (x) d / |d|.
    const real_t fn = kn * (2 * R - expect.norm());
    const Mat3 fb = fn * expect * expect.transpose() / expect.norm();
    ASSERT_LT((sim.macro().stress * sim.cell().volume() - fb).norm(), 1e-9 * fb.norm()) << "step " << k;
  }
  EXPECT_TRUE(flipped) << "the cell did not flip";
  EXPECT_TRUE(rewrapped) << "the flip should wrap a sphere anew (its fractional coordinates changed)";
}

// A rigid rotation Q of a sheared specimen (positions, and the cell's edges: H -> Q H, a cell
// with no zero in its matrix) rotates its stress, Q sigma Q^T, and keeps p and q: the FCC
// lattice sheared affinely by gamma = 0.3 (normal forces from its pre-overlap, the springs of
// a fresh list zero), built again rotated by 30 degrees about (1, 2, 3).
TEST(ShearedCell, ARigidRotationRotatesTheStress) {
  Lattice l = fcc();
  l.overlap = 2e-5;  // a pre-stress of a few percent of the shear stiffness times gamma
  const Simulation upright = l.make();
  Mat3 F = Mat3::Identity();
  F(1, 0) = 0.3;
  const Mat3 Q = Eigen::AngleAxisd(std::numbers::pi / 6, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  auto build = [&](const Mat3& map) {
    Particles p;
    const Particles& q = upright.particles();
    for (std::size_t a = 0; a < q.n_owned(); ++a) p.add({q.id[a], q.radius[a], 2650.0, Vec3(map * q.x[a])});
    const PeriodicCell cell = PeriodicCell::from_matrix(map * upright.cell().matrix());
    SimulationParams sp = upright.params();
    return Simulation(std::move(p), cell, sp);
  };
  const Simulation sheared = build(F), turned = build(Q * F);
  const Mat3 s = sheared.macro().stress, t = turned.macro().stress;
  ASSERT_GT(std::abs(s(0, 1)), 0.01 * s.norm());  // a shear stress to rotate
  EXPECT_EQ(turned.macro().contacts, sheared.macro().contacts);
  EXPECT_LT((t - Q * s * Q.transpose()).norm(), 1e-10 * s.norm());
  EXPECT_NEAR(turned.macro().p, sheared.macro().p, 1e-10 * sheared.macro().p);
  EXPECT_NEAR(turned.macro().q, sheared.macro().q, 1e-10 * sheared.macro().p);
}

}  // namespace
}  // namespace fabrica
