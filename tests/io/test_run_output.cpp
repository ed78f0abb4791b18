// Round trip of OUT/run.h5 (io/mpi/run_output -> io/mpi/snapshot), run through mpiexec at 1 and 2 ranks:
// a compressed polydisperse packing with sliding and rolling contacts is written collectively,
// then every rank reads the file back serially and finds each of its own particles and contact
// records with every value equal bit for bit (tolerance 0: the file stores IEEE doubles as they
// are), the totals equal the reduced counts, ids in increasing order; the series rows and the
// scene text come back exactly; a second RunOutput on the same directory is refused unless
// overwrite; the reader refuses missing, foreign and truncated files naming the file.
// RunOutputSheared: a sheared cell's snapshots (the cell matrix, the cell's XDMF sidecar) and
// its [fields], on one rank (ctest io.run_output.sheared, below).
#include "core/contact_snapshot.hpp"
#include "core/generate.hpp"
#include "core/timestep.hpp"
#include "io/mpi/h5.hpp"
#include "io/mpi/run_fields.hpp"
#include "io/mpi/run_output.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/mpi/snapshot_writer.hpp"
#include "parallel/mpi_domain.hpp"
#include "tests/sheared_specimen.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>

namespace fabrica {
namespace {

namespace fs = std::filesystem;

int rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int size() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

// A directory shared by the ranks, empty at the start: under the working directory (ctest's is
// this build's tests/io), not the shared /tmp, where another build's run of the same test on the
// same machine emptied or filled it under this one (seen with a sanitizer build beside a
// release build).
std::string fresh_dir(const std::string& name) {
  const std::string d = (fs::current_path() / ("fabrica-" + name + "-np" + std::to_string(size()))).string();
  if (rank() == 0) {
    fs::remove_all(d);
    fs::create_directories(d);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return d;
}

struct Packing {
  std::unique_ptr<MpiDomain> domain;
  std::unique_ptr<Simulation> sim;
};

Packing compressed_packing() {
  Random rng(7);
  std::vector<real_t> d = fractal_diameters(300, 1.9, 0.01, 0.05, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  const PeriodicCell cell(Vec3::Constant(std::cbrt(vs / 0.35)));
  Particles p = random_packing(d, 2650.0, cell, rng);
  SimulationParams sp;
  sp.law.youngs_modulus = 50e6;
  sp.law.friction = 0.3;
  sp.law.rolling_friction = 0.1;
  sp.skin = 0.002;
  sp.dt = 0.3 * critical_time_step(p, sp.law, true);
  sp.local_damping = 0.2;
  Packing k;
  if (size() > 1) k.domain = std::make_unique<MpiDomain>(MPI_COMM_WORLD, MpiDomainOptions{});
  k.sim = std::make_unique<Simulation>(std::move(p), cell, sp, k.domain.get());
  const int n = 2500;
  k.sim->cell().set_strain_rate(Vec3::Constant(std::log(0.8) / (n * sp.dt)));
  for (int s = 0; s < n; ++s) k.sim->step(s == n - 1);
  return k;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

Scene test_scene() {
  Scene sc;
  sc.path = "memory/test.toml";
  sc.text = "# a scene text with \"quotes\", <xml> & newlines\n[run]\nsnapshot_every = 7\n";
  sc.snapshot_every = 7;
  return sc;
}

TEST(RunOutput, RoundTripOfEveryDataset) {
  const std::string dir = fresh_dir("roundtrip");
  Packing k = compressed_packing();
  const Simulation& sim = *k.sim;
  const Scene sc = test_scene();
  const std::string header = "stage,step,time,p,q,Z\n";
  const Vec3 strain(0.01, -0.02, 0.03);
  {
    RunOutput out(MPI_COMM_WORLD, sc, dir, false);
    for (int r = 0; r < 300; ++r) {  // more than one buffer of rows
      const double v[] = {r * 1e-3, 1e5 + r, 2e4 / (r + 1), 4.5 + r * 1e-7};
      out.series_row("case_a", header, r < 100 ? "consolidation" : "shear", 10 * r, v);
    }
    out.snapshot("case_a", sim, strain);
    out.snapshot("case_a", sim, strain);  // the same step again: skipped
    out.close();
    EXPECT_EQ(out.snapshots(), 1);
  }
  // Each rank checks its own particles and contacts against the file.
  const std::string file = RunOutput::file_name(dir);
  const ParticleSnapshot ps = read_particle_snapshot(file, "case_a", sim.step_count());
  const Particles& p = sim.particles();
  long long owned = (long long)p.n_owned(), total = 0;
  MPI_Allreduce(&owned, &total, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  ASSERT_EQ((long long)ps.id.size(), total);
  EXPECT_EQ(ps.info.step, sim.step_count());
  EXPECT_EQ(ps.info.time, sim.time());
  EXPECT_EQ(ps.info.cell_lengths, sim.cell().lengths());
  // An orthorhombic cell's matrix is diag(L), and the run writes no cell sidecar.
  EXPECT_EQ(ps.info.cell_matrix, Mat3(sim.cell().lengths().asDiagonal()));
  EXPECT_FALSE(ps.info.sheared());
  EXPECT_EQ(ps.info.volume(), sim.cell().lengths()[0] * sim.cell().lengths()[1] * sim.cell().lengths()[2]);
  EXPECT_FALSE(fs::exists(fs::path(dir) / "run_cell.xmf"));
  EXPECT_EQ(ps.info.strain, strain);
  for (std::size_t i = 1; i < ps.id.size(); ++i) ASSERT_LT(ps.id[i - 1], ps.id[i]);
  std::map<GlobalId, std::size_t> at;
  for (std::size_t i = 0; i < ps.id.size(); ++i) at[ps.id[i]] = i;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    ASSERT_TRUE(at.count(p.id[a]));
    const std::size_t i = at[p.id[a]];
    ASSERT_EQ(ps.position[i], p.x[a]);
    ASSERT_EQ(ps.velocity[i], p.v[a]);
    ASSERT_EQ(ps.spin[i], p.w[a]);
    ASSERT_EQ(ps.radius[i], p.radius[a]);
  }

  const ContactSnapshot cs = read_contact_snapshot(file, "case_a", sim.step_count());
  const auto mine = contact_records(p, sim.cell(), sim.params().law, sim.pairs());
  long long nmine = (long long)mine.size(), ntotal = 0, nroll = 0, nslide = 0;
  for (const auto& c : mine) nroll += c.rolling && c.mr.norm() > 0, nslide += c.sliding;
  MPI_Allreduce(MPI_IN_PLACE, &nroll, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &nslide, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(&nmine, &ntotal, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  ASSERT_EQ((long long)cs.contacts.size(), ntotal);
  ASSERT_GT(ntotal, 300);
  EXPECT_GT(nroll, 0);  // the test covers non-trivial rolling moments and flags
  EXPECT_GT(nslide, 0);
  EXPECT_EQ(cs.info.contacts, ntotal);
  std::map<std::pair<GlobalId, GlobalId>, std::size_t> cat;
  for (std::size_t i = 0; i < cs.contacts.size(); ++i) {
    if (i > 0) {
      const auto& a = cs.contacts[i - 1];
      const auto& b = cs.contacts[i];
      ASSERT_TRUE(a.id1 < b.id1 || (a.id1 == b.id1 && a.id2 < b.id2));
    }
    cat[{cs.contacts[i].id1, cs.contacts[i].id2}] = i;
  }
  for (const ContactRecord& c : mine) {
    ASSERT_TRUE(cat.count({c.id1, c.id2}));
    const ContactRecord& r = cs.contacts[cat[{c.id1, c.id2}]];
    ASSERT_EQ(r.normal, c.normal);
    ASSERT_EQ(r.branch, c.branch);
    ASSERT_EQ(r.overlap, c.overlap);
    ASSERT_EQ(r.fn, c.fn);
    ASSERT_EQ(r.ft, c.ft);
    ASSERT_EQ(r.mr, c.mr);
    ASSERT_EQ(r.sliding, c.sliding);
    ASSERT_EQ(r.rolling, c.rolling);
  }

  const Series s = read_series(file, "case_a");
  ASSERT_EQ(s.rows(), 300u);
  ASSERT_EQ(s.columns, (std::vector<std::string>{"time", "p", "q", "Z"}));
  for (int r = 0; r < 300; ++r) {
    EXPECT_EQ(s.step[r], 10 * r);
    EXPECT_EQ(s.stage[r], r < 100 ? "consolidation" : "shear");
    EXPECT_EQ(s.column("time")[r], r * 1e-3);
    EXPECT_EQ(s.column("p")[r], 1e5 + r);
    EXPECT_EQ(s.column("q")[r], 2e4 / (r + 1));
    EXPECT_EQ(s.column("Z")[r], 4.5 + r * 1e-7);
  }
  const std::vector<SnapshotInfo> list = list_snapshots(file);
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].case_name, "case_a");
  EXPECT_EQ(list[0].step, sim.step_count());
  EXPECT_EQ(list[0].time, sim.time());
  const RunFileInfo info = read_run_info(file);
  EXPECT_EQ(info.scene_text, sc.text);
  EXPECT_EQ(info.scene_path, sc.path);
  EXPECT_EQ(info.ranks, size());
  EXPECT_FALSE(info.version.empty());
  EXPECT_EQ(list_series(file), std::vector<std::string>{"case_a"});

  // A second run into the same directory is refused, naming the file; with overwrite it is not.
  try {
    RunOutput again(MPI_COMM_WORLD, sc, dir, false);
    ADD_FAILURE() << "an existing run.h5 was overwritten";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file + ": the output file exists already"), std::string::npos) << e.what();
  }
  MPI_Barrier(MPI_COMM_WORLD);
  { RunOutput again(MPI_COMM_WORLD, sc, dir, true); }
  EXPECT_TRUE(list_snapshots(file).empty());
  EXPECT_THROW(read_contact_snapshot(file, "case_a", sim.step_count()), InputError);
}

// A snapshot written in many small rounds (3 records per rank and round: some 100 rounds, many
// of them empty on some rank) holds exactly the datasets of one written in a single round: the
// same rows in the same order, bit for bit (tolerance 0).
TEST(RunOutput, SnapshotInRoundsEqualsOneRound) {
  const std::string dir = fresh_dir("rounds");
  Packing k = compressed_packing();
  const std::string file = dir + "/rounds.h5";
  const SnapshotWriter one(MPI_COMM_WORLD, *k.sim, 2.0);
  const SnapshotWriter many(MPI_COMM_WORLD, *k.sim, 2.0, 3);
  ASSERT_EQ(one.rounds(), 1);
  ASSERT_GT(many.rounds(), 30);
  ASSERT_EQ(many.particles(), one.particles());
  ASSERT_EQ(many.contacts(), one.contacts());
  double bytes_one = 0, bytes_many = 0;
  {
    h5::File f = h5::File::create_parallel(file, MPI_COMM_WORLD, true);
    bytes_one = one.write(f.create_group("one"));
    bytes_many = many.write(f.create_group("many"));
    f.close();
  }
  EXPECT_EQ(bytes_one, bytes_many);
  if (rank() != 0) return;
  h5::File f = h5::File::open_read(file);
  for (const char* g : {"particles", "contacts"}) {
    const std::vector<std::string> names = f.open_group(std::string("one/") + g).children();
    ASSERT_EQ(names, f.open_group(std::string("many/") + g).children());
    ASSERT_GE(names.size(), 5u);
    for (const std::string& n : names) {
      const h5::Dataset a = f.open_dataset(std::string("one/") + g + "/" + n);
      const h5::Dataset b = f.open_dataset(std::string("many/") + g + "/" + n);
      ASSERT_EQ(a.shape(), b.shape()) << n;
      EXPECT_EQ(a.read_doubles(), b.read_doubles()) << g << "/" << n;  // ids too, exactly: < 2^53
    }
  }
  EXPECT_EQ(f.open_dataset("one/particles/id").shape()[0], hsize_t(one.particles()));
  EXPECT_GT(one.contacts(), 300);
}

void expect_input_error(const std::function<void()>& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no error; expected " << needle;
  } catch (const InputError& e) { EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what(); }
}

TEST(RunOutput, ReaderRefusesBadFiles) {
  const std::string dir = fresh_dir("badfiles");
  const std::string missing = dir + "/missing.h5", foreign = dir + "/foreign.h5", truncated = dir + "/truncated.h5",
                    other = dir + "/other.h5";
  // A good file to truncate, a text file and an HDF5 file that Fabrica did not write.
  { RunOutput out(MPI_COMM_WORLD, test_scene(), dir + "/good", false); }
  if (rank() == 0) {
    std::ifstream in(RunOutput::file_name(dir + "/good"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, 1000);
    std::ofstream(foreign) << "step,time\n1,2\n";
  }
  {
    h5::File f = h5::File::create_parallel(other, MPI_COMM_WORLD, true);
    f.create_group("data");
  }
  MPI_Barrier(MPI_COMM_WORLD);
  expect_input_error([&] { list_snapshots(missing); }, missing + ": no such file");
  expect_input_error([&] { list_snapshots(foreign); }, foreign + ": not an HDF5 file");
  expect_input_error([&] { read_series(truncated, "x"); }, truncated + ": cannot open the HDF5 file");
  expect_input_error([&] { read_run_info(other); }, other + ": not a Fabrica output file");
  const std::string good = RunOutput::file_name(dir + "/good");
  expect_input_error([&] { read_contact_snapshot(good, "nope", 5); }, "no snapshot of case 'nope' at step 5");
  expect_input_error([&] { read_series(good, "nope"); }, "no series of case 'nope'");
}

// A sheared cell (issue 42), on one rank until parallel/ handles sheared cells: the specimen of
// tests/sheared_specimen.hpp under simple shear past a flip, a snapshot and a series row (time,
// p, q) every 100 steps, into fabrica-sheared-np1 under the working directory, which the tests of
// the sheared output then read (ctest fixture sheared_run: cli.output.sheared_*,
// cli.fabric.sheared_offline, cli.fields.sheared_offline), with [fields] (width and spacing 10 mm)
// at every snapshot. Here: every snapshot's cell_matrix is the cell's matrix bit for bit (the C++
// reader), its particles lie in the slanted cell; the cell's sidecar run_cell.xmf has a grid per
// snapshot with the corners H s at full precision; the field instants' sidecar run_fields.xmf a
// 3DSMesh per instant (its nodes the dataset node_position); a restart rebuilds both
// sidecars alike; [fields] is accepted on the sheared cell, and the fields of its state
// integrate to the Love-Weber sum of its contacts and to its solid volume (1e-12).
TEST(RunOutputSheared, CellMatrixOutlineAndFields) {
  if (size() > 1) GTEST_SKIP() << "a sheared cell runs on one rank until parallel/ handles it";
  const std::string dir = fresh_dir("sheared");
  const test::ShearedStart st = test::sheared_start(400, 7);
  Simulation sim(st.particles, st.cell, st.params);
  const std::int64_t steps = 1600, every = 100;
  test::simple_shear(sim, 0.8, steps);
  Scene sc = test_scene();
  sc.fields.enabled = true;
  sc.fields.width = 0.01;
  sc.fields.spacing = 0.01;
  check_run_fields(sc, sim.particles(), sim.cell(), MPI_COMM_WORLD);  // accepted (orthorhombic at the start)
  std::vector<Mat3> cells;
  bool flipped = false;
  {
    RunOutput out(MPI_COMM_WORLD, sc, dir, false);
    for (std::int64_t k = 0; k <= steps; ++k) {
      if (k > 0) {
        const real_t tilt = sim.cell().matrix()(1, 0);
        sim.step(k % every == 0);
        flipped |= sim.cell().matrix()(1, 0) < tilt;
      }
      if (k % every) continue;
      const double v[] = {sim.time(), sim.macro().p, sim.macro().q};
      out.series_row("shear", "step,time,p,q\n", "", sim.step_count(), v);
      out.snapshot("shear", sim, Vec3::Zero());
      out.fields("shear", sim);
      cells.push_back(sim.cell().matrix());
    }
    out.close();
  }
  ASSERT_TRUE(flipped) << "the cell did not flip";
  const std::string file = RunOutput::file_name(dir);
  const std::vector<SnapshotInfo> infos = list_snapshots(file);
  ASSERT_EQ(infos.size(), cells.size());
  std::ostringstream corners;  // the last snapshot's corners as the sidecar writes them
  corners.precision(17);
  for (std::size_t i = 0; i < infos.size(); ++i) {
    const SnapshotInfo& info = infos[i];
    EXPECT_EQ(info.cell_matrix, cells[i]) << "snapshot " << i;
    EXPECT_EQ(info.cell_lengths, Vec3(cells[i].diagonal()));
    EXPECT_EQ(info.sheared(), i > 0) << "snapshot " << i;  // at step 0 the tilt is still zero
    const ParticleSnapshot ps = read_particle_snapshot(file, "shear", info.step);
    const Mat3 inv = info.cell_matrix.inverse();
    real_t lo = 1, hi = 0;  // fractional coordinates: within the drift since the last wrap
    for (const Vec3& x : ps.position) {
      const Vec3 f = inv * x;
      lo = std::min(lo, f.minCoeff()), hi = std::max(hi, f.maxCoeff());
    }
    EXPECT_GT(lo, -0.02) << "snapshot " << i;
    EXPECT_LT(hi, 1.02) << "snapshot " << i;
    if (i + 1 < infos.size()) continue;
    const Mat3& h = info.cell_matrix;
    for (int k = 0; k < 8; ++k)
      for (int r = 0; r < 3; ++r)
        corners << (k || r ? " " : "") << (k & 1) * h(r, 0) + ((k >> 1) & 1) * h(r, 1) + ((k >> 2) & 1) * h(r, 2);
  }
  std::ifstream in(fs::path(dir) / "run_cell.xmf");
  ASSERT_TRUE(in) << "no run_cell.xmf";
  std::stringstream xml;
  xml << in.rdbuf();
  const std::string x = xml.str();
  std::size_t grids = 0;
  for (std::size_t at = x.find("TopologyType=\"Polyline\" NumberOfElements=\"12\""); at != std::string::npos;
       at = x.find("TopologyType=\"Polyline\" NumberOfElements=\"12\"", at + 1))
    ++grids;
  EXPECT_EQ(grids, infos.size());
  EXPECT_NE(x.find(">" + corners.str() + "</DataItem>"), std::string::npos) << corners.str();
  const std::string fxml = read_text(fs::path(dir) / "run_fields.xmf");
  std::size_t smesh = 0;
  for (std::size_t at = fxml.find("TopologyType=\"3DSMesh\""); at != std::string::npos;
       at = fxml.find("TopologyType=\"3DSMesh\"", at + 1))
    ++smesh;
  // Every instant, the first's too (the cell, sheared from the start, is still orthorhombic at
  // step 0): a case's grids all of one type.
  EXPECT_EQ(smesh, infos.size());
  EXPECT_NE(fxml.find("/fields/shear/000000001600/node_position</DataItem>"), std::string::npos);
  // A restart rebuilds the sidecars from the snapshots' cell_matrix and the field instants (in a
  // copy: the directory is the fixture of the cli tests): the same text at the last step; from a
  // checkpoint at step 800, the grids up to it, each as before; from step 0 (no sheared snapshot
  // left), none.
  const std::string copy = fresh_dir("sheared-restart");
  fs::copy(dir, copy, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  for (const std::int64_t at : {infos.back().step, std::int64_t(800), std::int64_t(0)}) {
    {
      RunOutput out(MPI_COMM_WORLD, sc, copy, RunOutput::Restart{});
      out.resume_after(at, {"shear"}, 0);
      out.close();
    }
    if (at == 0) {
      EXPECT_FALSE(fs::exists(fs::path(copy) / "run_cell.xmf")) << "a stale run_cell.xmf";
      continue;
    }
    std::ifstream again(fs::path(copy) / "run_cell.xmf");
    std::stringstream y;
    y << again.rdbuf();
    const std::size_t cut = x.find("      <Grid Name=\"shear_cell_000000000900\""), tail = x.rfind("    </Grid>\n");
    ASSERT_NE(cut, std::string::npos);
    EXPECT_EQ(y.str(), at == 800 ? x.substr(0, cut) + x.substr(tail) : x) << "run_cell.xmf after a restart at " << at;
    if (at == infos.back().step) {
      EXPECT_EQ(read_text(fs::path(copy) / "run_fields.xmf"), fxml) << "run_fields.xmf after a restart";
    }
  }

  // [fields] on the sheared cell: accepted, and the volume integrals of the fields of its state
  // are the Love-Weber sum of its contacts (of the contact stress, and of the stress less its
  // kinetic part) and its solid volume.
  check_run_fields(sc, sim.particles(), sim.cell(), MPI_COMM_WORLD);
  ASSERT_TRUE(sim.cell().sheared());
  const FieldsResult r = run_fields(sc.fields, 1.0, sc.path, sim);
  ASSERT_TRUE(r.grid.sheared);
  const ContactSnapshot cs = read_contact_snapshot(file, "shear", infos.back().step);
  const ParticleSnapshot ps = read_particle_snapshot(file, "shear", infos.back().step);
  Mat3 lw = Mat3::Zero(), con = Mat3::Zero(), tot = Mat3::Zero();
  for (const ContactRecord& c : cs.contacts)
    if (c.id2 >= 0) lw += c.force() * c.branch.transpose();
  double solid = 0, phi = 0;
  for (real_t rad : ps.radius) solid += 4.0 / 3.0 * std::numbers::pi * rad * rad * rad;
  const Field &fc = r.field("contact_stress"), &fs = r.field("stress"), &fk = r.field("kinetic_stress"),
              &fp = r.field("solid_fraction");
  for (std::size_t g = 0; g < r.grid.nodes(); ++g) {
    for (int q = 0; q < 9; ++q) {
      con(q / 3, q % 3) += fc.values[9 * g + std::size_t(q)];
      tot(q / 3, q % 3) += fs.values[9 * g + std::size_t(q)] - fk.values[9 * g + std::size_t(q)];
    }
    phi += fp.values[g];
  }
  const double dv = r.grid.cell_volume();
  EXPECT_DOUBLE_EQ(dv * double(r.grid.nodes()), std::abs(sim.cell().matrix().determinant()));
  const double econ = (con * dv - lw).norm() / lw.norm(), etot = (tot * dv - lw).norm() / lw.norm(),
               ephi = std::abs(phi * dv - solid) / solid;
  EXPECT_LT(econ, 1e-12);
  EXPECT_LT(etot, 1e-12);
  EXPECT_LT(ephi, 1e-12);
  std::printf(
      "sheared cell at step %lld: %zu contacts; volume integrals against Love-Weber: contact stress %.2e, "
      "stress less its kinetic part %.2e; solid fraction against the solid volume %.2e (relative)\n",
      static_cast<long long>(sim.step_count()), cs.contacts.size(), econ, etot, ephi);
}

}  // namespace
}  // namespace fabrica
