// The set-up made by all ranks together (io/mpi/distributed_setup): no rank holds more than its
// share, and the result is the serial set-up's bit for bit - the same particles, cell and time
// step, the same errors for bad data files, and the same trajectory. Run at 1, 2, 4, 8, 16 ranks.
#include "core/simulation.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "core/errors.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"
#include "mpi_test_helpers.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <filesystem>
#include <functional>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

using namespace fabrica;
using fabrica::test::comm_rank;
using fabrica::test::comm_size;
using fabrica::test::sum_all;

namespace {

std::string dense_scene() { return std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml"; }

// The directories the tests below write (rank 0, read by every rank): named by the rank count
// so that runs at several rank counts at once do not meet, and removed by rank 0 once every
// test has run, so that the suite leaves nothing in the temporary directory.
std::filesystem::path case_dir(const std::string& what) {
  return std::filesystem::temp_directory_path() / ("fabrica-dsetup-" + what + std::to_string(comm_size()));
}
struct RemoveCaseDirs : ::testing::Environment {
  void TearDown() override {
    MPI_Barrier(MPI_COMM_WORLD);
    std::error_code ec;
    if (comm_rank() == 0)
      for (const char* what : {"t-", "regions-"}) std::filesystem::remove_all(case_dir(what), ec);
  }
};
[[maybe_unused]] ::testing::Environment* const kRemoveCaseDirs =
    ::testing::AddGlobalTestEnvironment(new RemoveCaseDirs);

// The error every rank meets (InputError), or "".
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) { return e.what(); }
  return "";
}

// A scene reading 'data' (written by rank 0 into a directory of this test and rank count).
std::string write_case(const std::string& name, const std::string& data, const std::string& scene_extra = "") {
  const auto dir = case_dir("t-");
  if (comm_rank() == 0) {
    std::filesystem::create_directories(dir);
    std::ofstream(dir / (name + ".data")) << data;
    std::ofstream(dir / (name + ".toml"))
        << "[particles]\nsource = \"file\"\nfile = \"" << name << ".data\"\n"
        << "[contact]\nnormal_stiffness = 1.0e6\nfriction = 0.3\n[run]\nsteps = 10\nskin = 0.001\n"
        << scene_extra;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return (dir / (name + ".toml")).string();
}

// A cubic lattice of n^3 spheres (spacing 3 mm, radius 1 mm, box 3n mm), listed in a scrambled
// order so that each rank's byte range holds spheres from everywhere; optional velocities.
std::string lattice_data(int n, bool velocities, const std::string& extra_atoms = "",
                         const std::string& extra_velocities = "", long long header_count = -1) {
  std::ostringstream s;
  const long long count = header_count >= 0 ? header_count : (long long)n * n * n;
  s << "lattice\n\n" << count << " atoms\n1 atom types\n";
  for (const char* ax : {"x", "y", "z"}) s << "0 " << 3e-3 * n << " " << ax << "lo " << ax << "hi\n";
  s << "\nAtoms # sphere\n\n";
  const int N = n * n * n;
  for (int q = 0; q < N; ++q) {
    const int k = (q * 7919) % N;  // a permutation (7919 is prime and N is not its multiple)
    const int i = k % n, j = (k / n) % n, l = k / (n * n);
    s << k + 1 << " 1 0.002 2500 " << 3e-3 * (i + 0.5) << " " << 3e-3 * (j + 0.5) << " " << 3e-3 * (l + 0.5) << "\n";
  }
  s << extra_atoms;
  if (velocities) {
    s << "\nVelocities\n\n";
    for (int k = N - 1; k >= 0; --k) s << k + 1 << " " << 0.5 * k << " 0 0 0 0 " << -1.0 * k << "\n";
    s << extra_velocities;
  }
  return s.str();
}

MpiDomainOptions cartesian() { return {}; }

}  // namespace

TEST(DistributedSetup, SameParticlesCellAndStepAsTheSerialSetup) {
  const Scene sc = load_scene(dense_scene());
  const fabrica::Setup ref = make_setup(sc);
  const fabrica::Setup s = make_run_setup(sc, MPI_COMM_WORLD, cartesian());
  const auto N = ref.particles.n_owned();
  const auto P = std::size_t(comm_size());
  EXPECT_EQ(s.holding, P > 1 ? Holding::Share : Holding::Whole);
  EXPECT_EQ(sum_all((long long)s.particles.n_owned()), (long long)N);
  // Each rank its subdomain's share: slabs of a Cartesian cut, within 1.5 x the mean.
  if (P > 1) { EXPECT_LE(s.particles.n_owned(), 1.5 * double(N) / double(P)); }
  EXPECT_EQ(s.cell.lengths(), ref.cell.lengths());
  EXPECT_EQ(s.critical_dt, ref.critical_dt);
  EXPECT_EQ(s.params.dt, ref.params.dt);
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < N; ++a) at[ref.particles.id[a]] = a;
  long long bad = 0;
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) {
    const std::size_t b = at.at(s.particles.id[a]);
    bad += s.particles.x[a] != ref.particles.x[b] || s.particles.radius[a] != ref.particles.radius[b] ||
        s.particles.mass[a] != ref.particles.mass[b] || s.particles.v[a] != ref.particles.v[b];
  }
  EXPECT_EQ(sum_all(bad), 0);
}

TEST(DistributedSetup, TheSameTrajectoryAsTheSerialRun) {
  const Scene sc = load_scene(dense_scene());
  fabrica::Setup ref_setup = make_setup(sc);
  Simulation ref(ref_setup.particles, ref_setup.cell, ref_setup.params);
  fabrica::Setup s = make_run_setup(sc, MPI_COMM_WORLD, cartesian());
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation sim(std::move(s.particles), s.cell, s.params, &domain, s.holding);
  for (int k = 0; k < 60; ++k) ref.step(k % 20 == 0), sim.step(k % 20 == 0);
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < ref.particles().n_owned(); ++a) at[ref.particles().id[a]] = a;
  long long bad = 0;
  const Particles& p = sim.particles();
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const std::size_t b = at.at(p.id[a]);
    bad += p.x[a] != ref.particles().x[b] || p.w[a] != ref.particles().w[b];
  }
  EXPECT_EQ(sum_all(bad), 0);
  EXPECT_EQ(sim.macro().contacts, ref.macro().contacts);
  EXPECT_GT(ref.macro().contacts, 10000);
}

TEST(DistributedSetup, VelocitiesFollowTheirAtoms) {
  const std::string scene = write_case("vel", lattice_data(6, true));
  const Scene sc = load_scene(scene);
  const fabrica::Setup ref = make_setup(sc);
  const fabrica::Setup s = make_run_setup(sc, MPI_COMM_WORLD, cartesian());
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < ref.particles.n_owned(); ++a) at[ref.particles.id[a]] = a;
  long long bad = 0;
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) {
    const std::size_t b = at.at(s.particles.id[a]);
    bad += s.particles.v[a] != ref.particles.v[b] || s.particles.w[a] != ref.particles.w[b];
    bad += s.particles.v[a][0] != 0.5 * double(s.particles.id[a] - 1);  // as written
  }
  EXPECT_EQ(sum_all(bad), 0);
  EXPECT_EQ(sum_all((long long)s.particles.n_owned()), 216);
}

// Each whole-file check gives the serial reader's message, whichever ranks hold the lines.
TEST(DistributedSetup, BadDataFilesGiveTheSerialMessages) {
  struct Case {
    const char* name;
    std::string data;
  };
  const std::vector<Case> cases = {
      {"duplicate", lattice_data(6, false, "17 1 0.002 2500 0.001 0.001 0.001\n", "", 217)},
      {"orphan_velocity", lattice_data(6, true, "", "999 0 0 0 0 0 0\n")},
      {"duplicate_velocity", lattice_data(6, true, "", "5 0 0 0 0 0 0\n")},
      {"count", lattice_data(6, false, "", "", 215)},
      {"bad_line", lattice_data(6, false, "300 1 0.002 2500 0.001 zero 0.001\n", "", 217)},
      {"outside", lattice_data(6, false, "300 1 0.002 2500 0.001 0.5 0.001\n", "", 217)},
      {"twice", lattice_data(6, false, "\nAtoms\n\n", "", 216)},
      {"overlap", lattice_data(6, false, "300 1 0.002 2500 0.0015 0.0015 0.0016\n", "", 217)},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Scene sc = load_scene(write_case(c.name, c.data));
    const std::string serial = error_of([&] { make_setup(sc); });
    const std::string parallel = error_of([&] { make_run_setup(sc, MPI_COMM_WORLD, cartesian()); });
    EXPECT_FALSE(serial.empty());
    EXPECT_EQ(parallel, serial);
  }
}

// A [cell] size smaller than the file's box: the spheres beyond it are refused with the serial
// message (io/serial/setup.hpp check_inside_cell), whichever rank read them.
TEST(DistributedSetup, ParticleOutsideTheSceneCellGivesTheSerialMessage) {
  const Scene sc =
      load_scene(write_case("small_cell", lattice_data(6, false), "[cell]\nsize = [0.015, 0.018, 0.018]\n"));
  const std::string serial = error_of([&] { make_setup(sc); });
  const std::string parallel = error_of([&] { make_run_setup(sc, MPI_COMM_WORLD, cartesian()); });
  EXPECT_NE(serial.find("lies outside the cell (coordinate 1 = 0.0165)"), std::string::npos) << serial;
  EXPECT_EQ(parallel, serial);
}

// A floor through the lattice at z = 4 mm: the spheres of the first layer (centres at 1.5 mm)
// start beyond it. A floor at z = 1 mm: they overlap it by half their radius. The serial
// message, the same sphere named, whichever ranks hold them.
TEST(DistributedSetup, SphereAgainstAWallGivesTheSerialMessage) {
  struct Case {
    const char *name, *z, *message;
  };
  for (const Case& c :
       {Case{"wall_beyond", "0.004", "starts beyond the wall"}, Case{"wall_overlap", "0.001", "overlaps the wall"}}) {
    SCOPED_TRACE(c.name);
    const std::string wall = std::string("[[wall]]\npoint = [0, 0, ") + c.z + "]\nnormal = [0, 0, 1]\n";
    const Scene sc = load_scene(write_case(c.name, lattice_data(6, false), wall));
    const std::string serial = error_of([&] { make_setup(sc); });
    const std::string parallel = error_of([&] { make_run_setup(sc, MPI_COMM_WORLD, cartesian()); });
    EXPECT_NE(serial.find(c.message), std::string::npos) << serial;
    EXPECT_EQ(parallel, serial);
  }
}

// [particles] placement = "regions": each rank makes only its regions, and the specimen is the
// serial one bit for bit (100,000 spheres: 16 regions of about 6,250).
TEST(DistributedSetup, GeneratedByRegionsIsTheSameOnAnyRankCount) {
  const auto dir = case_dir("regions-");
  const auto scene = dir / "regions.toml";
  if (comm_rank() == 0) {
    std::filesystem::create_directories(dir);
    std::ofstream(scene) << "[particles]\ncount = 100000\nd_min = 0.010\nd_max = 0.060\nseed = 11\n"
                         << "solid_fraction = 0.30\nplacement = \"regions\"\n"
                         << "[contact]\nyoungs_modulus = 1.0e8\nfriction = 0.3\n[run]\nsteps = 10\n";
  }
  MPI_Barrier(MPI_COMM_WORLD);
  const Scene sc = load_scene(scene.string());
  const fabrica::Setup ref = make_setup(sc);
  const fabrica::Setup s = make_run_setup(sc, MPI_COMM_WORLD, cartesian());
  ASSERT_EQ(ref.particles.n_owned(), 100000u);
  EXPECT_EQ(sum_all((long long)s.particles.n_owned()), 100000);
  if (comm_size() > 1) { EXPECT_LE(s.particles.n_owned(), 1.5 * 100000.0 / comm_size()); }
  EXPECT_EQ(s.cell.lengths(), ref.cell.lengths());
  EXPECT_EQ(s.params.dt, ref.params.dt);
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < ref.particles.n_owned(); ++a) at[ref.particles.id[a]] = a;
  long long bad = 0;
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) {
    const std::size_t b = at.at(s.particles.id[a]);
    bad += s.particles.x[a] != ref.particles.x[b] || s.particles.radius[a] != ref.particles.radius[b];
  }
  EXPECT_EQ(sum_all(bad), 0);
}

// The sequential generator with [run] density_scaling: the critical estimate of the scaled
// masses on any rank count (the whole specimen made on every rank is checked once, with the
// scene's own numbers). A time step between the unscaled and the scaled estimate is accepted.
TEST(DistributedSetup, DensityScalingOfAGeneratedSpecimenOnAnyRankCount) {
  const std::string base =
      "[particles]\ncount = 500\nd_min = 0.010\nd_max = 0.030\nseed = 3\nsolid_fraction = 0.2\n"
      "[contact]\nyoungs_modulus = 100e6\nfriction = 0.3\n[run]\nsteps = 2\nskin = 0.001\n"
      "density_scaling = 4.0\n";
  const fabrica::Setup ref = make_setup(parse_scene(base, "scaled.toml"));
  std::ostringstream dt;
  dt.precision(17);
  dt << 0.75 * ref.critical_dt;
  const Scene sc = parse_scene(base + "time_step = " + dt.str() + "\n", "scaled.toml");
  ASSERT_GT(0.75 * ref.critical_dt, ref.critical_dt / 2);  // above the unscaled estimate (1/sqrt(4))
  const std::string serial = error_of([&] { make_setup(sc); });
  const std::string parallel = error_of([&] { make_run_setup(sc, MPI_COMM_WORLD, cartesian()); });
  EXPECT_EQ(serial, "");
  EXPECT_EQ(parallel, serial);
  const fabrica::Setup s = make_run_setup(sc, MPI_COMM_WORLD, cartesian());
  EXPECT_EQ(s.critical_dt, ref.critical_dt);
}
