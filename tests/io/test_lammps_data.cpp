// LAMMPS data files: the shared benchmark file reads as described in its README, velocities and
// spins included; malformed files are refused with the file, the line and the value, and a
// section the reader does not understand is refused rather than ignored.
#include "io/serial/lammps_data.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <gtest/gtest.h>
#include "tests/temp_dir.hpp"
#include <unistd.h>

#include <filesystem>
#include <fstream>

using namespace fabrica;

namespace {

// In this process's scratch directory (tests/temp_dir.hpp: ctest runs the tests of this file as
// concurrent processes, and two of them writing the same file name would read each other's text).
std::string write_tmp(const std::string& name, const std::string& text) {
  const auto p = test::temp_dir() / name;
  std::ofstream(p) << text;
  return p.string();
}

const char* kHeader = "test data\n\n3 atoms\n1 atom types\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 2 zlo zhi\n\nAtoms\n\n";

void expect_error(const std::string& body, std::initializer_list<std::string> fragments) {
  const std::string path = write_tmp("fabrica_bad.data", std::string(kHeader) + body);
  try {
    read_lammps_data(path);
    FAIL() << "no error for:\n" << body;
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path), std::string::npos) << m;
    for (const auto& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "missing '" << f << "' in: " << m;
  }
}

}  // namespace

TEST(LammpsData, SharedBenchmarkFile) {
  const std::string path = std::string(FABRICA_SHARED_DIR) + "/bench/dense-13584/dense.data";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
  const DataFile d = read_lammps_data(path);
  ASSERT_EQ(d.particles.n_owned(), 13584u);
  EXPECT_NEAR(d.hi[0] - d.lo[0], 0.397705156, 1e-12);
  EXPECT_NEAR(d.hi[2] - d.lo[2], 0.795410312, 1e-12);
  // README: solid volume 0.08178 m^3, diameters in [10, 60] mm.
  EXPECT_NEAR(d.particles.solid_volume(), 0.08178, 0.00001);
  EXPECT_GE(d.particles.min_radius(), 0.005 - 1e-12);
  EXPECT_LE(d.particles.max_radius(), 0.030 + 1e-12);
  // Its Velocities section (id vx vy vz wx wy wz): first and last lines of the file.
  ASSERT_TRUE(d.has_velocities);
  const Particles& p = d.particles;
  ASSERT_EQ(p.id.front(), 1);
  EXPECT_EQ(p.v.front(), Vec3(0.0013670254331688519, -0.0056850833390829705, -0.0012122080089355927));
  EXPECT_EQ(p.w.front(), Vec3(-1.1802470304325205, -1.0096064313222537, 0.22513232706954273));
  ASSERT_EQ(p.id.back(), 13584);
  EXPECT_EQ(p.v.back(), Vec3(-4.7270119630446086e-05, -8.689208417756553e-06, -8.9801880632100417e-06));
  EXPECT_EQ(p.w.back(), Vec3(-5.4023679161515344e-05, 0.00036734898874706158, 0.0006382993890906057));
}

TEST(LammpsData, VelocitiesAreReadInAnyOrder) {
  const std::string path =
      write_tmp("fabrica_vel.data",
                std::string(kHeader) +
                    "1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n\n"
                    "Velocities\n\n3 0.75 0 0 0 0 3\n1 0.25 0 0 0 0 1\n2 0.5 0 0 0 0 2\n");
  const DataFile d = read_lammps_data(path);
  ASSERT_TRUE(d.has_velocities);
  for (std::size_t a = 0; a < 3; ++a) {
    EXPECT_EQ(d.particles.v[a], Vec3(0.25 * double(d.particles.id[a]), 0, 0));
    EXPECT_EQ(d.particles.w[a], Vec3(0, 0, double(d.particles.id[a])));
  }
  const DataFile none = read_lammps_data(write_tmp(
      "fabrica_novel.data",
      std::string(kHeader) + "1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n"));
  EXPECT_FALSE(none.has_velocities);
  EXPECT_EQ(none.particles.v[1], Vec3::Zero());
}

TEST(LammpsData, MalformedFilesAreRefused) {
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n2 1 -0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n",
               {":13", "particle 2", "diameter", "-0.02"});
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 0 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n",
               {":13", "density", "0"});
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 0.2 1.5 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n",
               {"particle 2", "y = 1.5", "outside"});
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 nan 0.5 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n",
               {"particle 2", "x = nan"});
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n1 1 0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n", {"appears twice"});
  expect_error("1 1 0.02 2650 0.5 0.5\n", {":12", "expected"});
  expect_error("1 1 0.02 2650 0.5 0.5 0.5\n", {"3 atoms", "has 1"});
  const std::string atoms = "1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n\n";
  expect_error(atoms + "Velocities\n\n1 0 0 0 0 0 0\n2 0 0 0 0 0 0\n", {"Velocities section has 2"});
  expect_error(atoms + "Velocities\n\n1 0 0 0 0 0 0\n2 0 inf 0 0 0 0\n3 0 0 0 0 0 0\n",
               {":19", "particle 2", "vy = inf"});
  expect_error(atoms + "Velocities\n\n1 0 0 0 0 0 0\n7 0 0 0 0 0 0\n3 0 0 0 0 0 0\n",
               {":19", "particle 7", "not in the Atoms section"});
  expect_error(atoms + "Velocities\n\n1 0 0 0 0 0 0\n1 0 0 0 0 0 0\n", {"appears twice"});
  expect_error(atoms + "Velocities\n\n1 0 0 0\n", {":18", "expected 'id vx vy vz wx wy wz'"});
  expect_error(atoms + "Masses\n\n1 2.0\n", {":16", "Masses", "not supported"});
  EXPECT_THROW(read_lammps_data("/nonexistent/fabrica.data"), InputError);
}

TEST(LammpsData, ParticleOutsideTheSceneCellIsRefused) {
  const std::string data = write_tmp(
      "fabrica_ok.data",
      std::string(kHeader) + "1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 0.2 0.2 1.9\n3 1 0.02 2650 0.7 0.7 0.7\n");
  const std::string scene = write_tmp("fabrica_cell.toml",
                                      "[particles]\nsource = \"file\"\nfile = \"" + data +
                                          "\"\n[cell]\nsize = [1.0, 1.0, 1.0]\n[contact]\nnormal_stiffness = 1e5\n");
  try {
    make_setup(load_scene(scene));
    FAIL() << "particle outside the cell accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("[cell] size"), std::string::npos) << m;
    EXPECT_NE(m.find("particle 2"), std::string::npos) << m;
    EXPECT_NE(m.find("1.9"), std::string::npos) << m;
  }
}

namespace {
// A whole file 'text' (header included) must be refused with every fragment and the path.
void expect_file_error(const std::string& text, std::initializer_list<std::string> fragments) {
  const std::string path = write_tmp("fabrica_bad_whole.data", text);
  try {
    read_lammps_data(path);
    FAIL() << "no error for:\n" << text;
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path), std::string::npos) << m;
    for (const auto& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "missing '" << f << "' in: " << m;
  }
}
std::string header(const std::string& atoms_line, const std::string& box) {
  return "test data\n\n" + atoms_line + "\n1 atom types\n\n" + box + "\nAtoms\n\n";
}
const char* kBox = "0 1 xlo xhi\n0 1 ylo yhi\n0 2 zlo zhi\n";
const char* kOne = "1 1 0.02 2650 0.5 0.5 0.5\n";
}  // namespace

// The bad-input corpus of issue 16: each case named with the file, the line, the value and what
// was expected (before, several were silent or reported as something else).
TEST(LammpsData, AtomCountIsAWholeNumberOfAtLeastOneWithinMemory) {
  expect_file_error(header("0 atoms", kBox), {":3", "'0 atoms'", "at least 1"});
  expect_file_error(header("-5 atoms", kBox) + kOne, {":3", "'-5 atoms'", "whole number"});
  expect_file_error(header("1e30 atoms", kBox) + kOne, {":3", "'1e30 atoms'", "whole number"});
  expect_file_error(header("2.5 atoms", kBox) + kOne, {":3", "'2.5 atoms'", "whole number"});
  expect_file_error(header("99999999999999999 atoms", kBox) + kOne,
                    {":3", "'99999999999999999 atoms'", "needs at least", "of memory", "the machine has"});
}

TEST(LammpsData, IdsAreWholeNumbersInRange) {
  const std::string h = header("3 atoms", kBox);
  const std::string rest = "2 1 0.02 2650 0.2 0.2 0.2\n3 1 0.02 2650 0.7 0.7 0.7\n";
  expect_file_error(h + "1.5 1 0.02 2650 0.5 0.5 0.5\n" + rest,
                    {":12", "particle id '1.5'", "whole number in [1, 9007199254740992]"});
  expect_file_error(h + "1e30 1 0.02 2650 0.5 0.5 0.5\n" + rest, {":12", "particle id '1e30'"});
  expect_file_error(h + "0 1 0.02 2650 0.5 0.5 0.5\n" + rest, {":12", "particle id '0'"});
  expect_file_error(h + "-3 1 0.02 2650 0.5 0.5 0.5\n" + rest, {":12", "particle id '-3'"});
  expect_file_error(h + "9007199254740993 1 0.02 2650 0.5 0.5 0.5\n" + rest, {":12", "particle id '9007199254740993'"});
  expect_file_error(h + "-9223372036854775808 1 0.02 2650 0.5 0.5 0.5\n" + rest,
                    {":12", "particle id '-9223372036854775808'"});
  // The largest id is accepted, and read exactly.
  const std::string ok = write_tmp("fabrica_max_id.data", h + "9007199254740992 1 0.02 2650 0.5 0.5 0.5\n" + rest);
  EXPECT_EQ(read_lammps_data(ok).particles.id[0], 9007199254740992LL);
  const std::string atoms = h + kOne + rest + "\nVelocities\n\n";
  expect_file_error(atoms + "1 0 0 0 0 0 0\n2.5 0 0 0 0 0 0\n3 0 0 0 0 0 0\n", {":19", "particle id '2.5'"});
}

TEST(LammpsData, BoxAxesArePresentAndNotInverted) {
  expect_file_error(header("1 atoms", "1 0 xlo xhi\n0 1 ylo yhi\n0 2 zlo zhi\n") + kOne,
                    {":6", "xhi = 0 must exceed xlo = 1"});
  expect_file_error(header("1 atoms", "0 1 xlo xhi\n0 0 ylo yhi\n0 2 zlo zhi\n") + kOne,
                    {":7", "yhi = 0 must exceed ylo = 0"});
  expect_file_error(header("1 atoms", "0 1 xlo xhi\n0 2 zlo zhi\n") + kOne,
                    {":9", "section 'Atoms' before the box bounds 'ylo yhi'"});
}

TEST(LammpsData, DiametersInRangeAndADirectoryIsRefused) {
  expect_file_error(header("1 atoms", kBox) + "1 1 1e-310 2650 0.5 0.5 0.5\n",
                    {":12", "particle 1 diameter = 1e-310", "[1e-09, 1000] m"});
  expect_file_error(header("1 atoms", kBox) + "1 1 5000 2650 0.5 0.5 0.5\n", {":12", "diameter = 5000"});
  const auto dir = test::temp_dir() / "fabrica_data_dir.data";
  std::filesystem::create_directories(dir);
  try {
    read_lammps_data(dir.string());
    FAIL() << "a directory was read as a data file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(dir.string() + ": is a directory, not a particle data file"), std::string::npos)
        << e.what();
  }
}

TEST(LammpsData, BoxFarLargerThanItsSpheresIsRefusedBeforeAllocation) {
  const std::string data = write_tmp("fabrica_huge_box.data",
                                     header("2 atoms", "0 1e6 xlo xhi\n0 1e6 ylo yhi\n0 1e6 zlo zhi\n") +
                                         "1 1 0.02 2650 0.5 0.5 0.5\n2 1 0.02 2650 100 100 100\n");
  const std::string scene =
      write_tmp("fabrica_huge_box.toml", "[particles]\nsource = \"file\"\nfile = \"" + data + "\"\n");
  try {
    make_setup(load_scene(scene));
    FAIL() << "a grid of 10^21 cells was accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(data), std::string::npos) << m;
    EXPECT_NE(m.find("neighbour grid"), std::string::npos) << m;
    EXPECT_NE(m.find("more than 2^31 cells"), std::string::npos) << m;
  }
}
