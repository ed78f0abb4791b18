// Materials ([[material]], [[material_pair]], walls naming a material; core/contact/materials.hpp,
// docs/scene.md "Materials", docs/verification.md "Two materials"), through scene files:
//  - the mixing rules against the formulas written out here;
//  - the assignment of generated spheres (counts within 3 of fraction x N, masses from each
//    material's density) and of a data file's atom types;
//  - two identical materials give the one-material run bit for bit (the per-contact law of the
//    mixed kernel is the one-material kernel's arithmetic);
//  - the elastic Hertz impact of two spheres of two materials and of a sphere on a wall of
//    another material against 2.868 (m*^2 / (R* E*^2 v))^{1/5} and (15 m* v^2 / (16 E* sqrt R*))^{2/5}
//    with E* of the two materials; the linear law's pi sqrt(m* / k_n) with k_n of the harmonic
//    mean of the two E;
//  - bad input refused before the run, naming the file, table, key and value.
#include "core/contact/materials.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <gtest/gtest.h>
#include "tests/temp_dir.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

namespace fabrica {
namespace {

namespace fs = std::filesystem;
constexpr real_t kPi = std::numbers::pi;

// ---- Mixing rules -----------------------------------------------------------------------------

TEST(Materials, MixingRulesAreTheStatedFormulas) {
  ContactLawParams a, b;
  a.model = b.model = ContactModel::HertzMindlin;
  a.youngs_modulus = 60e9, a.poisson_ratio = 0.22, a.friction = 0.4, a.rolling_friction = 0.1;
  b.youngs_modulus = 200e9, b.poisson_ratio = 0.29, b.friction = 0.2, b.rolling_friction = 0.3;
  a.damping_ratio_n = 0.2, b.damping_ratio_n = 0.4, a.twisting_friction = 0.05;
  const ContactLawParams m = mix(a, b);
  const real_t estar = 1 / ((1 - 0.22 * 0.22) / 60e9 + (1 - 0.29 * 0.29) / 200e9);
  const real_t gstar = 1 / (2 * (2 - 0.22) * (1 + 0.22) / 60e9 + 2 * (2 - 0.29) * (1 + 0.29) / 200e9);
  EXPECT_NEAR(HertzMindlin::effective_modulus(m) / estar, 1.0, 1e-15);
  EXPECT_NEAR(HertzMindlin::effective_shear_modulus(m) / gstar, 1.0, 1e-15);
  EXPECT_EQ(m.friction, 0.2);
  EXPECT_EQ(m.rolling_friction, 0.1);
  EXPECT_EQ(m.twisting_friction, 0.0);
  EXPECT_NEAR(m.damping_ratio_n, 0.3, 1e-16);
  // One material's pair: its own moduli, E* = E / (2 (1 - nu^2)), exactly.
  EXPECT_EQ(mix(a, a).pair_estar, 0.0);
  EXPECT_EQ(HertzMindlin::effective_modulus(mix(a, a)), HertzMindlin::effective_modulus(a));

  ContactLawParams c, d;  // linear, deformability: E and k_s in series
  c.youngs_modulus = 1e8, c.stiffness_ratio = 2.0;
  d.youngs_modulus = 3e8, d.stiffness_ratio = 1.0;
  const ContactLawParams l = mix(c, d);
  EXPECT_NEAR(l.youngs_modulus, 2 * 1e8 * 3e8 / 4e8, 1e-7);
  const real_t ks_share = 2 * (1e8 / 2.0) * (3e8 / 1.0) / (1e8 / 2.0 + 3e8);
  EXPECT_NEAR(l.youngs_modulus / l.stiffness_ratio / ks_share, 1.0, 1e-15);
  ContactLawParams e = c, f = d;  // direct
  e.stiffness_mode = f.stiffness_mode = NormalStiffnessMode::Direct;
  e.normal_stiffness = 1e5, f.normal_stiffness = 4e5;
  EXPECT_NEAR(mix(e, f).normal_stiffness, 2 * 1e5 * 4e5 / 5e5, 1e-9);
  // Equal numbers are kept as they are (bit for bit).
  const ContactLawParams same = mix(c, c);
  EXPECT_EQ(same.youngs_modulus, c.youngs_modulus);
  EXPECT_EQ(same.stiffness_ratio, c.stiffness_ratio);
}

// ---- Scenes -----------------------------------------------------------------------------------

fs::path scene_dir(const std::string& name) {
  const fs::path dir = test::temp_dir() / ("materials-" + name);
  fs::create_directories(dir);
  return dir;
}

Scene scene_of(const std::string& name, const std::string& toml) {
  const fs::path p = scene_dir(name) / "s.toml";
  std::ofstream(p) << toml;
  return load_scene(p.string());
}

const char* kGenerated = R"([particles]
count = 1000
seed = 5
density = 2650.0
[contact]
youngs_modulus = 1e8
friction = 0.3
[run]
steps = 10
)";

TEST(Materials, GeneratedSpheresTakeTheirFractionAndDensity) {
  const Scene sc = scene_of("generated", std::string(kGenerated) + R"(
[[material]]
name = "light"
fraction = 0.3
density = 1000.0
[[material]]
name = "heavy"
fraction = 0.7
density = 8000.0
friction = 0.5
)");
  ASSERT_EQ(sc.materials.size(), 2u);
  const fabrica::Setup s = make_setup(sc);
  ASSERT_EQ(s.params.materials.size(), 2u);
  std::size_t n[2] = {0, 0};
  const Particles& p = s.particles;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const int m = p.material[a];
    ASSERT_LT(m, 2);
    ++n[m];
    const real_t R = p.radius[a];
    EXPECT_EQ(p.mass[a], sc.materials[std::size_t(m)].density * 4.0 / 3.0 * kPi * R * R * R);
  }
  std::printf("[materials] generated: %zu and %zu of 1000 (fractions 0.3, 0.7)\n", n[0], n[1]);
  EXPECT_LE(std::abs(double(n[0]) - 300.0), 3.0);
  EXPECT_EQ(n[0] + n[1], 1000u);
  EXPECT_EQ(s.params.materials.pair(0, 1).friction, 0.3);  // min(0.3 of [contact], 0.5)
  EXPECT_EQ(s.params.materials.pair(1, 1).friction, 0.5);
}

// One material given as a table is the scene's law and density: no table of pairs.
TEST(Materials, OneMaterialIsTheScenesLaw) {
  const Scene sc = scene_of("one", std::string(kGenerated) + R"(
[[material]]
name = "only"
fraction = 1.0
density = 3000.0
friction = 0.45
)");
  EXPECT_EQ(sc.law.friction, 0.45);
  EXPECT_EQ(sc.density, 3000.0);
  EXPECT_TRUE(scene_materials(sc).empty());
}

// Two materials of the same numbers run the one-material scene bit for bit (the mixed kernel,
// one contact at a time, against the one-material kernel, four at a time).
TEST(Materials, IdenticalMaterialsGiveTheOneMaterialRun) {
  const std::string base = R"([particles]
count = 400
seed = 11
solid_fraction = 0.45
density = 2650.0
[contact]
youngs_modulus = 1e8
friction = 0.3
rolling_friction = 0.1
damping_ratio_normal = 0.1
[run]
steps = 10
)";
  const std::string two = base + R"(
[[material]]
name = "a"
fraction = 0.5
[[material]]
name = "b"
fraction = 0.5
)";
  fabrica::Setup s1 = make_setup(scene_of("identical-one", base));
  fabrica::Setup s2 = make_setup(scene_of("identical-two", two));
  ASSERT_EQ(s2.params.materials.size(), 2u);
  s2.params.dt = s1.params.dt;
  Simulation a(std::move(s1.particles), s1.cell, s1.params), b(std::move(s2.particles), s2.cell, s2.params);
  a.cell().set_strain_rate(Vec3(-8.0, -8.0, -8.0));
  b.cell().set_strain_rate(Vec3(-8.0, -8.0, -8.0));
  for (int k = 1; k <= 3000; ++k) {
    a.step(k % 500 == 0);
    b.step(k % 500 == 0);
  }
  ASSERT_GT(a.macro().contacts, 100);
  const Particles &pa = a.particles(), &pb = b.particles();
  ASSERT_EQ(pa.n_owned(), pb.n_owned());
  std::size_t same = 0;
  for (std::size_t i = 0; i < pa.n_owned(); ++i)
    same += pa.id[i] == pb.id[i] && pa.x[i] == pb.x[i] && pa.w[i] == pb.w[i];
  EXPECT_EQ(same, pa.n_owned());
  EXPECT_EQ(a.macro().stress, b.macro().stress);
  EXPECT_EQ(a.macro().dissipated.viscous, b.macro().dissipated.viscous);
}

// Two different materials in the SIMD law: each lane its own pair's numbers (LawLanes). A dense
// Hertz-Mindlin packing with rolling and twisting resistance and dashpots, 3,000 steps of
// compression, with the pair loop four contacts at a time and one at a time: bit for bit.
TEST(Materials, MixedLanesGiveTheOneLaneRun) {
  const std::string scene = R"([particles]
count = 400
seed = 12
solid_fraction = 0.45
[contact]
model = "hertz_mindlin"
friction = 0.3
rolling_friction = 0.1
twisting_friction = 0.05
restitution_normal = 0.7
[run]
steps = 10
[[material]]
name = "soft"
fraction = 0.6
youngs_modulus = 5e7
poisson_ratio = 0.4
friction = 0.5
[[material]]
name = "stiff"
fraction = 0.4
density = 7800.0
youngs_modulus = 2e9
poisson_ratio = 0.2
rolling_friction = 0.3
restitution_normal = 0.4
)";
  fabrica::Setup s4 = make_setup(scene_of("lanes-4", scene)), s1 = make_setup(scene_of("lanes-1", scene));
  s4.params.kernel_lanes = 4;
  s1.params.kernel_lanes = 1;
  Simulation a(std::move(s4.particles), s4.cell, s4.params), b(std::move(s1.particles), s1.cell, s1.params);
  a.cell().set_strain_rate(Vec3(-8.0, -8.0, -8.0));
  b.cell().set_strain_rate(Vec3(-8.0, -8.0, -8.0));
  for (int k = 1; k <= 3000; ++k) {
    a.step(k % 500 == 0);
    b.step(k % 500 == 0);
  }
  ASSERT_GT(a.macro().contacts, 100);
  EXPECT_GT(a.macro().rolling, 0);
  const Particles &pa = a.particles(), &pb = b.particles();
  std::size_t same = 0;
  for (std::size_t i = 0; i < pa.n_owned(); ++i)
    same += pa.id[i] == pb.id[i] && pa.x[i] == pb.x[i] && pa.w[i] == pb.w[i];
  EXPECT_EQ(same, pa.n_owned());
  EXPECT_EQ(a.macro().stress, b.macro().stress);
  EXPECT_EQ(a.macro().dissipated.viscous, b.macro().dissipated.viscous);
  EXPECT_EQ(a.macro().dissipated.rolling, b.macro().dissipated.rolling);
}

// ---- Impacts of two materials ------------------------------------------------------------------

// Two spheres of types 1 and 2 (radii R1, R2, densities rho1, rho2) approaching head-on at
// relative speed v along x, or sphere 1 falling on a wall of material 'wall' (R2 = 0).
struct Measured {
  real_t contact_time = 0, max_overlap = 0, v_ratio = 0;
};
Measured impact(const std::string& name, const std::string& contact_and_materials, real_t R1, real_t rho1, real_t R2,
                real_t rho2, real_t v, real_t dt) {
  const fs::path dir = scene_dir(name);
  const Vec3 L(0.1, 0.1, 0.1);
  const bool wall = R2 == 0;
  const real_t gap = 5 * v * dt;
  std::ostringstream d;
  d.precision(17);
  d << "two materials\n\n"
    << (wall ? 1 : 2) << " atoms\n2 atom types\n\n0 0.1 xlo xhi\n0 0.1 ylo yhi\n0 0.1 zlo zhi\n\n";
  d << "Atoms\n\n1 1 " << 2 * R1 << " " << rho1 << " " << 0.05 - R1 - gap << " 0.05 0.05\n";
  if (!wall) d << "2 2 " << 2 * R2 << " " << rho2 << " " << 0.05 + R2 << " 0.05 0.05\n";
  d << "\nVelocities\n\n1 " << v << " 0 0 0 0 0\n";
  if (!wall) d << "2 0 0 0 0 0 0\n";
  std::ofstream(dir / "s.data") << d.str();
  std::ostringstream t;
  t.precision(17);
  t << "[particles]\nsource = \"file\"\nfile = \"s.data\"\n[cell]\nsize = [0.1, 0.1, 0.1]\n"
    << contact_and_materials << "[run]\ntime_step = " << dt << "\nskin = 0.0005\n";
  if (wall) t << "[[wall]]\npoint = [0.05, 0, 0]\nnormal = [-1, 0, 0]\nmaterial = \"wall\"\n";
  std::ofstream(dir / "s.toml") << t.str();
  fabrica::Setup s = make_setup(load_scene((dir / "s.toml").string()));
  Simulation sim(std::move(s.particles), s.cell, s.params);
  auto state = [&](real_t& un, real_t& vn) {
    const Particles& p = sim.particles();
    const std::size_t a = p.id[0] == 1 ? 0 : 1;
    if (wall) {
      un = p.x[0].x() + R1 - 0.05, vn = p.v[0].x();
      return;
    }
    un = R1 + R2 - (p.x[1 - a] - p.x[a]).norm();
    vn = p.v[a].x() - p.v[1 - a].x();
  };
  Measured m;
  real_t un = 0, vn = 0, prev = 0, t0 = -1, t1 = -1;
  state(un, vn);
  const real_t v_in = vn;
  for (int k = 0; k < 10000000 && t1 < 0; ++k) {
    prev = un;
    sim.step();
    state(un, vn);
    m.max_overlap = std::max(m.max_overlap, un);
    if (t0 < 0 && prev <= 0 && un > 0) t0 = sim.time() - dt * un / (un - prev);
    if (t0 >= 0 && prev > 0 && un <= 0) t1 = sim.time() - dt * un / (un - prev);
  }
  EXPECT_GT(t1, 0.0) << "no separation";
  for (int k = 0; k < 3; ++k) sim.step();
  state(un, vn);
  m.contact_time = t1 - t0;
  m.v_ratio = -vn / v_in;
  return m;
}

const char* kHertzMaterials = R"([contact]
model = "hertz_mindlin"
friction = 0.3
[[material]]
name = "glass"
type = 1
youngs_modulus = 63e9
poisson_ratio = 0.23
[[material]]
name = "steel"
type = 2
youngs_modulus = 210e9
poisson_ratio = 0.3
[[material]]
name = "wall"
youngs_modulus = 3e9
poisson_ratio = 0.4
)";

real_t estar_of(real_t E1, real_t n1, real_t E2, real_t n2) { return 1 / ((1 - n1 * n1) / E1 + (1 - n2 * n2) / E2); }

// Hertz, elastic, v = 0.4 m/s, dt = t_c / 2000; tolerances as for one material (tests/unit/
// test_hertz.cpp): contact time and largest overlap 1e-3, rebound speed 1e-6.
void check_hertz(const std::string& label, real_t R1, real_t rho1, real_t R2, real_t rho2, real_t Estar) {
  const real_t v = 0.4;
  const real_t m1 = rho1 * 4 / 3.0 * kPi * R1 * R1 * R1, m2 = rho2 * 4 / 3.0 * kPi * R2 * R2 * R2;
  const real_t mstar = R2 > 0 ? m1 * m2 / (m1 + m2) : m1, rstar = R2 > 0 ? R1 * R2 / (R1 + R2) : R1;
  const real_t tc = 2.868 * std::pow(mstar * mstar / (rstar * Estar * Estar * v), 0.2);
  const real_t umax = std::pow(15 * mstar * v * v / (16 * Estar * std::sqrt(rstar)), 0.4);
  const Measured r = impact(label, kHertzMaterials, R1, rho1, R2, rho2, v, tc / 2000);
  std::printf(
      "[materials] hertz %s: t_c %.6e s (closed form %.6e, rel err %.2e), u_max rel err %.2e, v_out/v_in - 1 = %.2e\n",
      label.c_str(), r.contact_time, tc, r.contact_time / tc - 1, r.max_overlap / umax - 1, r.v_ratio - 1);
  EXPECT_NEAR(r.contact_time / tc, 1.0, 1e-3);
  EXPECT_NEAR(r.max_overlap / umax, 1.0, 1e-3);
  EXPECT_NEAR(r.v_ratio, 1.0, 1e-6);
}

TEST(Materials, HertzImpactOfTwoMaterials) {
  check_hertz("glass-steel", 0.002, 2500, 0.003, 7800, estar_of(63e9, 0.23, 210e9, 0.3));
}

TEST(Materials, HertzImpactOnAWallOfAnotherMaterial) {
  check_hertz("glass-wall", 0.002, 2500, 0.0, 0, estar_of(63e9, 0.23, 3e9, 0.4));
}

// Linear law: k_n = pi r^2 E_h / (R1 + R2), E_h = 2 E1 E2 / (E1 + E2); contact time
// pi sqrt(m* / k_n) (no damping), tolerance 1e-3 (the crossings interpolated at t_c / 2000).
TEST(Materials, LinearImpactOfTwoMaterials) {
  const char* law = R"([contact]
friction = 0.3
[[material]]
name = "soft"
type = 1
youngs_modulus = 5e7
[[material]]
name = "stiff"
type = 2
youngs_modulus = 4e8
)";
  const real_t R1 = 0.004, R2 = 0.005, rho1 = 1200, rho2 = 2650, v = 0.2;
  const real_t m1 = rho1 * 4 / 3.0 * kPi * R1 * R1 * R1, m2 = rho2 * 4 / 3.0 * kPi * R2 * R2 * R2;
  const real_t Eh = 2 * 5e7 * 4e8 / (5e7 + 4e8);
  const real_t kn = kPi * R1 * R1 * Eh / (R1 + R2);
  const real_t tc = kPi * std::sqrt(m1 * m2 / (m1 + m2) / kn);
  const Measured r = impact("linear", law, R1, rho1, R2, rho2, v, tc / 2000);
  std::printf("[materials] linear soft-stiff: t_c %.6e s (closed form %.6e, rel err %.2e)\n", r.contact_time, tc,
              r.contact_time / tc - 1);
  EXPECT_NEAR(r.contact_time / tc, 1.0, 1e-3);
  EXPECT_NEAR(r.v_ratio, 1.0, 1e-6);
}

// A [[material_pair]]'s restitution replaces the mixed dashpot: the damped Hertz impact of the
// pair rebounds at the pair's e (0.5 % at t_c / 4000, as for one material), between materials
// whose own restitutions are 0.9 and 0.95.
TEST(Materials, PairRestitutionIsThePairs) {
  const std::string law = R"([contact]
model = "hertz_mindlin"
friction = 0.3
[[material]]
name = "glass"
type = 1
youngs_modulus = 63e9
poisson_ratio = 0.23
restitution_normal = 0.9
[[material]]
name = "steel"
type = 2
youngs_modulus = 210e9
poisson_ratio = 0.3
restitution_normal = 0.95
[[material_pair]]
materials = ["steel", "glass"]
restitution_normal = 0.6
)";
  const real_t R1 = 0.002, R2 = 0.003, rho1 = 2500, rho2 = 7800, v = 0.4;
  const real_t m1 = rho1 * 4 / 3.0 * kPi * R1 * R1 * R1, m2 = rho2 * 4 / 3.0 * kPi * R2 * R2 * R2;
  const real_t mstar = m1 * m2 / (m1 + m2), rstar = R1 * R2 / (R1 + R2);
  const real_t Estar = estar_of(63e9, 0.23, 210e9, 0.3);
  const real_t tc = 2.868 * std::pow(mstar * mstar / (rstar * Estar * Estar * v), 0.2);
  const Measured r = impact("pair-restitution", law, R1, rho1, R2, rho2, v, tc / 4000);
  std::printf("[materials] pair restitution: e = %.5f (input 0.6)\n", r.v_ratio);
  EXPECT_NEAR(r.v_ratio, 0.6, 0.005 * 0.6);
}

// ---- Oblique impact against the measured tangential restitution --------------------------------

// Kharaz, Gorham & Salman 2001 (Powder Technol. 120:281): 5 mm aluminium oxide spheres (4,000
// kg/m^3, E = 380 GPa, nu = 0.23) on a thick soda-lime glass anvil (E = 70 GPa, nu = 0.25) at
// 3.9 m/s, mu = 0.092: the tangential coefficient of restitution e_t = v_t' / v_t of the centre
// against the impact angle from the normal, the data Di Renzo & Di Maio 2004 (Chem. Eng. Sci.
// 59:525, figure 8) compare their models with (as tabulated in MFIX's DEM05 verification case).
struct Measurement {
  real_t angle_deg, et;
};
constexpr Measurement kKharaz[] = {{2.0275, 0.7938},  {3.9282, 0.7450},  {9.6304, 0.6728},  {20.0845, 0.5964},
                                   {30.2218, 0.6883}, {39.3031, 0.7719}, {49.5459, 0.8469}, {59.8416, 0.9019}};

// The sphere (material "alumina") on a wall of material "glass", elastic (e_n = 1, as Di Renzo &
// Di Maio run it), Hertz-Mindlin; returns e_t at the given angle.
real_t kharaz_et(real_t angle_deg, real_t dt) {
  const fs::path dir = scene_dir("kharaz");
  const real_t R = 0.0025, v = 3.9, a = angle_deg * kPi / 180;
  const real_t vn = v * std::cos(a), vt = v * std::sin(a);
  std::ostringstream d;
  d.precision(17);
  d << "kharaz\n\n1 atoms\n1 atom types\n\n0 0.1 xlo xhi\n0 0.1 ylo yhi\n0 0.1 zlo zhi\n\nAtoms\n\n1 1 " << 2 * R
    << " 4000 0.05 0.05 " << 0.02 + R + 3 * vn * dt << "\n\nVelocities\n\n1 " << vt << " 0 " << -vn << " 0 0 0\n";
  std::ofstream(dir / "s.data") << d.str();
  std::ostringstream t;
  t.precision(17);
  t << "[particles]\nsource = \"file\"\nfile = \"s.data\"\n[cell]\nsize = [0.1, 0.1, 0.1]\n[contact]\n"
       "model = \"hertz_mindlin\"\nfriction = 0.092\n[run]\ntime_step = "
    << dt
    << "\nskin = 0.0005\n[[material]]\nname = \"alumina\"\ntype = 1\nyoungs_modulus = 380e9\npoisson_ratio = 0.23\n"
       "[[material]]\nname = \"glass\"\nyoungs_modulus = 70e9\npoisson_ratio = 0.25\n"
       "[[wall]]\npoint = [0, 0, 0.02]\nnormal = [0, 0, 1]\nmaterial = \"glass\"\n";
  std::ofstream(dir / "s.toml") << t.str();
  fabrica::Setup s = make_setup(load_scene((dir / "s.toml").string()));
  Simulation sim(std::move(s.particles), s.cell, s.params);
  bool touched = false;
  for (int k = 0; k < 1000000; ++k) {
    sim.step();
    const bool touching = sim.wall_contacts().size() == 1 && sim.wall_contacts().touching[0];
    touched = touched || touching;
    if (touched && !touching) break;
  }
  EXPECT_TRUE(touched);
  return sim.particles().v[0].x() / vt;
}

// Fabrica's Hertz-Mindlin against the 8 measured points. Tolerances: 0.02 where the sphere slides
// throughout (from 30 degrees on: e_t = 1 - mu (1 + e) / tan(angle), rigid-body sliding, which
// the measurements follow to about 0.01); 0.15 below, in the partial-slip regime, the spread of
// the published models there (at 2 degrees the linear spring-dashpot gives 0.864 and a Hertzian
// model without Mindlin's micro-slip 0.997 in MFIX's tabulation of Di Renzo & Di Maio's cases,
// against the measured 0.794): the elastic models do not have the experiment's e_n = 0.98 nor
// its micro-slip. And the shape: e_t smallest at the same measured angle (20 degrees).
TEST(Materials, ObliqueImpactAgainstKharazMeasurements) {
  const real_t R = 0.0025, m = 4000 * 4 / 3.0 * kPi * R * R * R;
  const real_t estar = estar_of(380e9, 0.23, 70e9, 0.25);
  const real_t tc = 2.868 * std::pow(m * m / (R * estar * estar * 3.9), 0.2);
  real_t lowest = 2, at = 0;
  for (const Measurement& x : kKharaz) {
    const real_t et = kharaz_et(x.angle_deg, tc / 1000);
    const real_t sliding = 1 - 0.092 * 2 / std::tan(x.angle_deg * kPi / 180);
    std::printf("[materials] Kharaz: angle %7.4f deg: e_t %.4f, measured %.4f (difference %+.4f), rigid sliding %.4f\n",
                x.angle_deg, et, x.et, et - x.et, sliding);
    EXPECT_NEAR(et, x.et, x.angle_deg >= 30 ? 0.02 : 0.15) << x.angle_deg << " degrees";
    if (et < lowest) lowest = et, at = x.angle_deg;
  }
  EXPECT_EQ(at, 20.0845);
}

// ---- Bad input ----------------------------------------------------------------------------------

void expect_error(const std::string& name, const std::string& toml, std::initializer_list<std::string> fragments,
                  const std::string& data = "") {
  const fs::path dir = scene_dir(name);
  if (!data.empty()) std::ofstream(dir / "s.data") << data;
  try {
    Scene sc = scene_of(name, toml);
    (void)make_setup(sc);
    ADD_FAILURE() << "accepted: " << toml;
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const auto& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "'" << f << "' not in: " << m;
  }
}

TEST(Materials, BadInputIsRefusedWithFileTableKeyAndValue) {
  const std::string g = kGenerated;
  const std::string two = "[[material]]\nname = \"a\"\nfraction = 0.5\n[[material]]\nname = \"b\"\nfraction = 0.5\n";
  expect_error("no-name", g + "[[material]]\nfraction = 1.0\n", {"s.toml", "[material #1]", "name", "(missing)"});
  expect_error("twice", g + "[[material]]\nname = \"a\"\nfraction = 0.5\n[[material]]\nname = \"a\"\nfraction = 0.5\n",
               {"[material #2]", "name", "\"a\"", "another"});
  expect_error("sum", g + "[[material]]\nname = \"a\"\nfraction = 0.5\n[[material]]\nname = \"b\"\nfraction = 0.6\n",
               {"fraction", "1.1", "not 1"});
  expect_error("type-generated", g + "[[material]]\nname = \"a\"\ntype = 1\nfraction = 1.0\n",
               {"[material #1]", "type = 1", "source = \"file\""});
  expect_error("nu-hertz",
               "[particles]\ncount = 100\n[contact]\nmodel = \"hertz_mindlin\"\n[run]\nsteps = 1\n"
               "[[material]]\nname = \"a\"\nfraction = 1.0\npoisson_ratio = 0.5\n",
               {"[material #1]", "poisson_ratio = 0.5", "(-1, 0.5)"});
  expect_error("kn-and-E",
               g +
                   "[[material]]\nname = \"a\"\nfraction = 0.5\n[[material]]\nname = \"b\"\nfraction = 0.5\n"
                   "normal_stiffness = 1e5\n",
               {"[material #2]", "normal_stiffness = 100000", "every material"});
  expect_error("rate", g + "[[material]]\nname = \"a\"\nfraction = 1.0\ndamping_rate_normal = 3\n",
               {"[material #1]", "damping_rate_normal = 3", "[contact]"});
  expect_error("pair-unknown", g + two + "[[material_pair]]\nmaterials = [\"a\", \"c\"]\nfriction = 0.1\n",
               {"[material_pair #1]", "materials", "\"c\" is not a [[material]]"});
  expect_error("pair-empty", g + two + "[[material_pair]]\nmaterials = [\"a\", \"b\"]\n",
               {"[material_pair #1]", "gives no number"});
  expect_error("pair-negative", g + two + "[[material_pair]]\nmaterials = [\"a\", \"b\"]\nfriction = -1\n",
               {"[material_pair #1]", "friction = -1", ">= 0"});
  expect_error("wall-unknown", g + two + "[[wall]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nmaterial = \"steel\"\n",
               {"[wall #1]", "material = \"steel\"", "not the name of a [[material]]"});
  expect_error("wall-key", g + two + "[[wall]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nfriction = 0.2\n",
               {"[wall #1]", "friction = 0.2", "material"});
  expect_error("unused", g + "[[material]]\nname = \"a\"\n", {"no material is given to spheres"});
  // A data file with an atom type of no material: refused with the file, line, particle and type.
  const std::string data =
      "bad types\n\n2 atoms\n2 atom types\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n\nAtoms\n\n"
      "1 1 0.1 2650 0.2 0.5 0.5\n2 3 0.1 2650 0.6 0.5 0.5\n";
  expect_error("type-missing",
               "[particles]\nsource = \"file\"\nfile = \"s.data\"\n[run]\nsteps = 1\n"
               "[[material]]\nname = \"a\"\ntype = 1\n[[material]]\nname = \"b\"\ntype = 2\n",
               {"s.data:13", "particle 2 type = 3", "no [[material]]"}, data);
}

}  // namespace
}  // namespace fabrica
