// Checkpoint and restart (io/mpi/checkpoint.hpp) on the dense packing, with the cell deforming and
// rolling springs on. The reference is an uninterrupted serial run on every rank (the
// trajectory does not depend on the rank count); the restarted run must match it bit for bit:
// positions, velocities, spins and every shear and rolling spring.
//   Checkpoint.BitwiseContinuation   - save at N/2 (first rebuild step from there), restore
//                                      into a fresh Simulation, continue to N (np 1 and 2); on
//                                      2 ranks the saved Cartesian runs (placed by the work,
//                                      not the even split) are the restarted domain's;
//   Checkpoint.KeepSeriesThrough     - the series rows kept on a restart;
//   Checkpoint.SmallBlocksWriteTheSameFile - records made and written 1,000 at a time (some 14
//                                      blocks of particles and 16 of contacts over the ranks)
//                                      give the same file, byte for byte, as one block;
//   CheckpointFiles.Write / .ReadAndContinue - written by one rank count, read by another
//                                      (ctest: written on 2 ranks, read on 1, 4, 8, 16), via the
//                                      file named in FABRICA_CHECKPOINT_FILE;
//   ShearedCheckpoint.ContinuesThroughAFlip - a sheared cell (format 11: H, G and the strain
//                                      integral) under simple shear past a flip, saved before and
//                                      after the flip: the restart continues bit for bit, the
//                                      cell matrix included (ctest mpi.checkpoint.sheared.npN,
//                                      on the rank counts tests/mpi/CMakeLists.txt lists).
#include "core/simulation.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"
#include "parallel/mpi_domain.hpp"

#include "core/timestep.hpp"
#include "tests/sheared_specimen.hpp"
#include "tests/mpi/two_materials.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <filesystem>
#include <map>
#include <unordered_map>

using namespace fabrica;

namespace {

constexpr int kSteps = 240;

int comm_size() {
  int s;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}
int comm_rank() {
  int r;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

std::string dense_text() {
  std::ifstream in(std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Setup dense_setup() { return make_setup(load_scene(std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml")); }

// The cell deforms (shear-like: axis 1 shortens, 2 and 3 lengthen) so that the saved strain
// rates and the rebuild criterion's reference lengths matter.
void deform(Simulation& sim) { sim.cell().set_strain_rate(Vec3(-2.0, 1.0, 1.0)); }

// Steps until at least 'to' and a rebuild step: where a checkpoint can be taken.
void run_to_rebuild(Simulation& sim, std::int64_t to) {
  while (sim.step_count() < to || !sim.rebuilt_last_step()) sim.step(sim.step_count() % 20 == 0);
}
void run_to(Simulation& sim, std::int64_t to) {
  while (sim.step_count() < to) sim.step(sim.step_count() % 20 == 0);
}

// 'par' against the serial reference, over all ranks: every position, velocity, spin and
// contact spring equal bit for bit, and the same particles and contacts (more than
// 'min_contacts' of them).
void expect_same_trajectory(const Simulation& par, const Simulation& ref, std::size_t min_contacts = 1000) {
  const Particles& P = par.particles();
  const Particles& S = ref.particles();
  std::unordered_map<GlobalId, std::size_t> at;
  for (std::size_t a = 0; a < S.n_owned(); ++a) at[S.id[a]] = a;
  std::array<long long, 4> bad{0, 0, 0, 0};
  long long owned = 0;
  for (std::size_t a = 0; a < P.n_owned(); ++a, ++owned) {
    const std::size_t b = at.at(P.id[a]);
    bad[0] += P.x[a] != S.x[b];
    bad[1] += P.v[a] != S.v[b];
    bad[2] += P.w[a] != S.w[b];
  }
  std::map<std::pair<GlobalId, GlobalId>, ContactHistory> springs;
  ref.for_each_contact([&](GlobalId a, GlobalId b, const ContactHistory& h) { springs[{a, b}] = h; });
  long long mine = 0;
  par.for_each_contact([&](GlobalId a, GlobalId b, const ContactHistory& h) {
    ++mine;
    auto it = springs.find({a, b});
    bad[3] += it == springs.end() || it->second.fs != h.fs || it->second.mr != h.mr;
  });
  MPI_Allreduce(MPI_IN_PLACE, bad.data(), 4, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &owned, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &mine, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(owned, (long long)S.n_owned());
  EXPECT_EQ(mine, (long long)springs.size()) << "contacts after the restart";
  EXPECT_GT(springs.size(), min_contacts);
  EXPECT_EQ(bad[0], 0) << "positions differ";
  EXPECT_EQ(bad[1], 0) << "velocities differ";
  EXPECT_EQ(bad[2], 0) << "spins differ";
  EXPECT_EQ(bad[3], 0) << "springs differ";
}

// Under the working directory (ctest's is this build's tests/mpi), not the shared /tmp, where
// another build's run of the same test on the same machine would write the same file.
std::string checkpoint_path(const std::string& tag) {
  return (std::filesystem::current_path() / ("fabrica-test-" + tag + "-np" + std::to_string(comm_size()) + ".ckpt"))
      .string();
}

// The state a restarted run and the uninterrupted one share, bit for bit.
void expect_same_state(const MacroState& a, const MacroState& b) {
  EXPECT_EQ(a.stress, b.stress);
  EXPECT_EQ(a.kinetic, b.kinetic);
  EXPECT_EQ(a.e_shear, b.e_shear);
  EXPECT_EQ(a.e_rolling, b.e_rolling);
  EXPECT_EQ(a.dissipated.friction, b.dissipated.friction);
  EXPECT_EQ(a.dissipated.rolling, b.dissipated.rolling);
  EXPECT_EQ(a.contacts, b.contacts);
}

}  // namespace

TEST(Checkpoint, BitwiseContinuation) {
  fabrica::Setup s = dense_setup();
  const std::string text = dense_text();
  Simulation ref(s.particles, s.cell, s.params);
  deform(ref);
  run_to(ref, kSteps);

  const std::string path = checkpoint_path("continuation");
  std::int64_t saved_at = 0;
  DecompositionRecord saved_dec;
  std::vector<int> saved_owner;
  {
    MpiDomain domain(MPI_COMM_WORLD);
    Simulation first(s.particles, s.cell, s.params, &domain);
    deform(first);
    run_to_rebuild(first, kSteps / 2);
    saved_at = first.step_count();
    saved_dec = domain.decomposition_record();
    for (int b = 0; b < domain.decomposition().bins(); ++b) saved_owner.push_back(domain.decomposition().owner(b));
    if (comm_size() > 1) {  // the runs have followed the work: not those of the even split
      EXPECT_GE(domain.stats().cuts_moved, 1);
      const Decomposition even = Decomposition::cartesian(comm_size(), saved_dec.lengths, first.cutoff());
      std::vector<std::int32_t> even_cuts;
      for (const std::vector<int>& axis : even.cuts()) even_cuts.insert(even_cuts.end(), axis.begin(), axis.end());
      EXPECT_NE(saved_dec.cuts, even_cuts);
      EXPECT_GE(saved_dec.since_check, 0);
    }
    CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(text), "run");
    w.add_simulation("sim", first);
    w.add_global("app", Bytes().put(std::int64_t(42)).str());
    EXPECT_GT(w.write(path), 13584u * 100);
  }
  ASSERT_LT(saved_at, kSteps);
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  ex.app = "run";
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, path, ex);
  EXPECT_EQ(c.header().step, saved_at);
  EXPECT_EQ(c.header().ranks, comm_size());
  EXPECT_EQ(BytesIn(c.section("app"), "app").get<std::int64_t>(), 42);
  {
    // Each rank has read its own range of the records only: 1/P of the particles and contacts.
    const SimulationSnapshot part = c.simulation("sim", MPI_COMM_WORLD);
    const auto n = std::size_t(13584), P = std::size_t(comm_size()), r = std::size_t(comm_rank());
    EXPECT_EQ(part.particles.n_owned(), n * (r + 1) / P - n * r / P);
    std::uint64_t contacts = 0;
    for (const auto& sec : c.header().sections)
      if (sec.name == "sim.contacts") contacts = sec.records;
    EXPECT_GT(contacts, n);
    EXPECT_EQ(part.history.size(), contacts * (r + 1) / P - contacts * r / P);
    EXPECT_EQ(part.holding, Holding::Share);
  }
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation restarted(c.simulation("sim", MPI_COMM_WORLD), &domain);
  EXPECT_EQ(restarted.step_count(), saved_at);
  {  // the saved decomposition, remade: the same runs, bins, owners and check schedule
    const DecompositionRecord again = domain.decomposition_record();
    EXPECT_EQ(again.lengths, saved_dec.lengths);
    EXPECT_EQ(again.cuts, saved_dec.cuts);
    EXPECT_EQ(again.since_check, saved_dec.since_check);
    std::vector<int> owner;
    for (int b = 0; b < domain.decomposition().bins(); ++b) owner.push_back(domain.decomposition().owner(b));
    EXPECT_EQ(owner, saved_owner);
  }
  run_to(restarted, kSteps);
  expect_same_trajectory(restarted, ref);
  EXPECT_EQ(restarted.time(), ref.time());
  EXPECT_EQ(restarted.rebuild_count(), ref.rebuild_count());
  EXPECT_EQ(restarted.cell().lengths(), ref.cell().lengths());
  EXPECT_GT(ref.macro().dissipated.rolling, 0.0);
  // The measures too, bitwise, against an uninterrupted run on this rank count: the same owners
  // and accumulators per rank, so the same sums in the same order.
  MpiDomain domain_full(MPI_COMM_WORLD);
  Simulation full(s.particles, s.cell, s.params, &domain_full);
  deform(full);
  run_to(full, kSteps);
  const MacroState& a = restarted.macro();
  const MacroState& b = full.macro();
  expect_same_state(a, b);
  EXPECT_EQ(a.dissipated.viscous, b.dissipated.viscous);
  // and the same decomposition at the end as the uninterrupted run
  EXPECT_EQ(domain.decomposition_record().cuts, domain_full.decomposition_record().cuts);
  EXPECT_EQ(domain.decomposition_record().since_check, domain_full.decomposition_record().since_check);
  MPI_Barrier(MPI_COMM_WORLD);
  if (domain.rank() == 0) std::filesystem::remove(path);
}

// The same continuation with another law: the law, its model and the springs come back from the
// file, and the restarted run is the uninterrupted one bit for bit.
void continues_bitwise(const ContactLawParams& law, const std::string& name, bool materials = false) {
  fabrica::Setup s = dense_setup();
  s.params.law = law;
  s.params.dt = 0.25 * critical_time_step(s.particles, law, false);
  if (materials) test::two_materials(s);
  const std::string text = dense_text();
  Simulation ref(s.particles, s.cell, s.params);
  deform(ref);
  run_to(ref, kSteps);
  const std::string path = checkpoint_path(name);
  {
    MpiDomain domain(MPI_COMM_WORLD);
    Simulation first(s.particles, s.cell, s.params, &domain);
    deform(first);
    run_to_rebuild(first, kSteps / 2);
    CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(text), "run");
    w.add_simulation("sim", first);
    w.write(path);
  }
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  ex.app = "run";
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, path, ex);
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation restarted(c.simulation("sim", MPI_COMM_WORLD), &domain);
  EXPECT_EQ(restarted.params().law.model, law.model);
  EXPECT_EQ(restarted.params().law.poisson_ratio, law.poisson_ratio);
  EXPECT_EQ(restarted.params().law.twisting_friction, law.twisting_friction);
  EXPECT_EQ(restarted.params().materials.size(), materials ? 2u : 0u);
  if (materials) {
    const ContactLawParams &a = restarted.params().materials.pair(0, 1), &b = s.params.materials.pair(0, 1);
    EXPECT_EQ(a.youngs_modulus, b.youngs_modulus);
    EXPECT_EQ(a.pair_estar, b.pair_estar);
    EXPECT_EQ(a.friction, b.friction);
  }
  run_to(restarted, kSteps);
  expect_same_trajectory(restarted, ref);
  EXPECT_GT(ref.macro().dissipated.rolling, 0.0);
  MPI_Barrier(MPI_COMM_WORLD);
  if (domain.rank() == 0) std::filesystem::remove(path);
}

// Hertz-Mindlin contacts (their springs scaled as the contacts unload) with rolling resistance.
TEST(Checkpoint, HertzMindlinBitwiseContinuation) {
  ContactLawParams law = dense_setup().params.law;
  law.model = ContactModel::HertzMindlin;
  law.youngs_modulus = 1e9;
  law.poisson_ratio = 0.2;
  law.damping_rate_n = law.damping_rate_s = 0;
  law.damping_ratio_n = 0.1;
  continues_bitwise(law, "hertz");
}

// Two materials (format 10: the material in the particle records, the pairs' laws in the
// global fields), with each model.
TEST(Checkpoint, MaterialsBitwiseContinuation) {
  ContactLawParams law = dense_setup().params.law;
  continues_bitwise(law, "materials_linear", true);
  law.model = ContactModel::HertzMindlin;
  law.poisson_ratio = 0.25;
  law.damping_rate_n = law.damping_rate_s = 0;
  law.damping_ratio_n = 0.1;
  continues_bitwise(law, "materials_hertz", true);
}

// Twisting resistance, whose springs the contact records then carry (format 9), with each
// model (without rolling resistance for Hertz-Mindlin: the twisting springs alone).
TEST(Checkpoint, TwistingBitwiseContinuation) {
  ContactLawParams law = dense_setup().params.law;
  law.twisting_friction = 0.05;
  continues_bitwise(law, "twisting_linear");
  law.model = ContactModel::HertzMindlin;
  law.youngs_modulus = 1e9;
  law.poisson_ratio = 0.2;
  law.stiffness_mode = NormalStiffnessMode::Deformability;
  law.damping_rate_n = law.damping_rate_s = 0;
  law.damping_ratio_n = 0.1;
  law.rolling_friction = 0;
  continues_bitwise(law, "twisting_hertz");
}

TEST(Checkpoint, SmallBlocksWriteTheSameFile) {
  fabrica::Setup s = dense_setup();
  const std::string text = dense_text();
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation sim(s.particles, s.cell, s.params, &domain);
  deform(sim);
  run_to_rebuild(sim, 20);
  const std::string one = checkpoint_path("one_block"), many = checkpoint_path("many_blocks");
  for (const std::string& path : {one, many}) {
    CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(text), "run");
    if (path == many) w.set_block_records(1000);
    else w.set_block_records(std::uint64_t(1) << 40);
    w.add_simulation("sim", sim);
    w.write(path);
  }
  if (comm_rank() == 0) {
    auto bytes = [](const std::string& p) {
      std::ifstream in(p, std::ios::binary);
      return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string a = bytes(one), b = bytes(many);
    EXPECT_GT(a.size(), 13584u * 144);
    EXPECT_TRUE(a == b) << "files of " << a.size() << " and " << b.size() << " bytes differ";
  }
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, many, ex);  // the checksum holds
  EXPECT_EQ(c.header().step, sim.step_count());
  MPI_Barrier(MPI_COMM_WORLD);
  if (comm_rank() == 0) {
    std::filesystem::remove(one);
    std::filesystem::remove(many);
  }
}

// Simulation::for_each_contact_in, as the checkpoint's contact blocks use it: ranges taken in
// order with one cursor give for_each_contact's sequence; a range before the cursor starts over.
TEST(Checkpoint, ContactRangesFollowTheWholeOrder) {
  fabrica::Setup s = dense_setup();
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation sim(s.particles, s.cell, s.params, &domain);
  deform(sim);
  run_to_rebuild(sim, 20);
  using Pair = std::pair<fabrica::GlobalId, fabrica::GlobalId>;
  std::vector<Pair> whole, ranged, again;
  sim.for_each_contact(
      [&](fabrica::GlobalId a, fabrica::GlobalId b, const fabrica::ContactHistory&) { whole.emplace_back(a, b); });
  ASSERT_GT(whole.size(), 1000u);
  Simulation::ContactCursor at;
  const std::uint64_t n = 7;
  for (std::uint64_t first = 0; first < whole.size(); first += n)
    sim.for_each_contact_in(
        first, n, at,
        [&](fabrica::GlobalId a, fabrica::GlobalId b, const fabrica::ContactHistory&) { ranged.emplace_back(a, b); });
  EXPECT_TRUE(ranged == whole) << ranged.size() << " contacts by ranges, " << whole.size() << " in all";
  sim.for_each_contact_in(3, 5, at, [&](fabrica::GlobalId a, fabrica::GlobalId b, const fabrica::ContactHistory&) {
    again.emplace_back(a, b);
  });
  EXPECT_TRUE(again == std::vector<Pair>(whole.begin() + 3, whole.begin() + 8));
}

// Written here for CheckpointFiles.ReadAndContinue at another rank count.
TEST(CheckpointFiles, Write) {
  const char* path = std::getenv("FABRICA_CHECKPOINT_FILE");
  if (!path) GTEST_SKIP() << "FABRICA_CHECKPOINT_FILE not set";
  fabrica::Setup s = dense_setup();
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation sim(s.particles, s.cell, s.params, &domain);
  deform(sim);
  run_to_rebuild(sim, kSteps / 2);
  CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(dense_text()), "run");
  w.add_simulation("sim", sim);
  w.write(path);
}

TEST(CheckpointFiles, ReadAndContinue) {
  const char* path = std::getenv("FABRICA_CHECKPOINT_FILE");
  if (!path) GTEST_SKIP() << "FABRICA_CHECKPOINT_FILE not set";
  fabrica::Setup s = dense_setup();
  Simulation ref(s.particles, s.cell, s.params);
  deform(ref);
  run_to(ref, kSteps);
  const std::string text = dense_text();
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, path, ex);
  EXPECT_NE(c.header().ranks, comm_size()) << "meant to be read on another rank count";
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation restarted(c.simulation("sim", MPI_COMM_WORLD), &domain);
  run_to(restarted, kSteps);
  // The trajectory is rank-count independent, so bitwise here too.
  expect_same_trajectory(restarted, ref);
  // Measures: sums over ranks in another order, equal to rounding.
  EXPECT_NEAR(restarted.macro().p, ref.macro().p, 1e-12 * std::abs(ref.macro().p));
  EXPECT_NEAR(restarted.macro().dissipated.friction, ref.macro().dissipated.friction,
              1e-12 * ref.macro().dissipated.friction);
}

// On a restart the series keep their header and the complete rows up to the checkpoint's step.
TEST(Checkpoint, KeepSeriesThrough) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  const std::string path = checkpoint_path("series-rank" + std::to_string(rank));
  {
    std::ofstream out(path, std::ios::binary);
    out << "stage,step,value\n"
           "consolidation,100,1.5\n"
           "consolidation,200,2.5\n"
           "shear,300,3.5\n"
           "shear,30";  // cut short by a kill
  }
  ASSERT_TRUE(keep_series_through(path, 1, 200));
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  EXPECT_EQ(s.str(), "stage,step,value\nconsolidation,100,1.5\nconsolidation,200,2.5\n");
  EXPECT_FALSE(keep_series_through(path + ".none", 1, 200));  // no file: a new series
  std::filesystem::remove(path);
}

// ---------------------------------------------------------------- a sheared cell (issue 42)

namespace {

using test::sheared_start;
using test::ShearedStart;

constexpr std::int64_t kShearSteps = 1600;
constexpr real_t kShearStrain = 0.8;  // the tilt passes kFlipRatio = 0.6 of the edge at ~1200

void simple_shear(Simulation& sim) { test::simple_shear(sim, kShearStrain, kShearSteps); }

// Steps as run_to / run_to_rebuild; 'flipped' becomes true at a flip of the cell (its edge 1
// made upright again: the tilt H21 falls).
void run_sheared(Simulation& sim, std::int64_t to, bool to_rebuild, bool* flipped = nullptr) {
  while (sim.step_count() < to || (to_rebuild && !sim.rebuilt_last_step())) {
    const real_t tilt = sim.cell().matrix()(1, 0);
    sim.step(sim.step_count() % 20 == 0);
    if (flipped && sim.cell().matrix()(1, 0) < tilt) *flipped = true;
  }
}

// Saved at the first rebuild after step 'save' of the shear, restored into a fresh Simulation and
// continued to kShearSteps: the trajectory, the cell (matrix, velocity gradient, strain integral),
// the time and the rebuild count bit for bit those of the uninterrupted serial run, and the
// measures those of the uninterrupted run on this rank count. 'after_flip': the cell has flipped
// before the checkpoint (its H is the flipped one), else it flips after the restart.
void sheared_continues_bitwise(const ShearedStart& s, const Simulation& ref, std::int64_t save, bool after_flip) {
  const std::string text = "sheared cell test";
  const std::string path = checkpoint_path(after_flip ? "sheared_after_flip" : "sheared_before_flip");
  {
    MpiDomain domain(MPI_COMM_WORLD);
    Simulation first(s.particles, s.cell, s.params, &domain);
    simple_shear(first);
    bool flipped = false;
    run_sheared(first, save, true, &flipped);
    EXPECT_EQ(flipped, after_flip) << "saved at step " << first.step_count();
    CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(text), "run");
    w.add_simulation("sim", first);
    w.write(path);
  }
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, path, ex);
  EXPECT_EQ(c.header().format, kCheckpointFormat);
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation restarted(c.simulation("sim", MPI_COMM_WORLD), &domain);
  ASSERT_TRUE(restarted.cell().sheared());
  bool flipped = false;
  run_sheared(restarted, kShearSteps, false, &flipped);
  EXPECT_EQ(flipped, !after_flip) << "a flip after the restart";
  expect_same_trajectory(restarted, ref, 300);
  EXPECT_EQ(restarted.cell().matrix(), ref.cell().matrix());
  EXPECT_EQ(restarted.cell().velocity_gradient(), ref.cell().velocity_gradient());
  EXPECT_EQ(restarted.cell().strain(), ref.cell().strain());
  EXPECT_EQ(restarted.time(), ref.time());
  EXPECT_EQ(restarted.rebuild_count(), ref.rebuild_count());
  // The measures against an uninterrupted run on this rank count, bitwise.
  MpiDomain domain_full(MPI_COMM_WORLD);
  Simulation full(s.particles, s.cell, s.params, &domain_full);
  simple_shear(full);
  run_sheared(full, kShearSteps, false);
  const MacroState& a = restarted.macro();
  const MacroState& b = full.macro();
  expect_same_state(a, b);
  EXPECT_EQ(a.energy_input, b.energy_input);
  MPI_Barrier(MPI_COMM_WORLD);
  if (comm_rank() == 0) std::filesystem::remove(path);
}

}  // namespace

TEST(ShearedCheckpoint, ContinuesThroughAFlip) {
  const ShearedStart s = sheared_start();
  Simulation ref(s.particles, s.cell, s.params);
  simple_shear(ref);
  bool flipped = false;
  std::int64_t flip_step = -1;
  while (ref.step_count() < kShearSteps) {
    run_sheared(ref, ref.step_count() + 1, false, &flipped);
    if (flipped && flip_step < 0) flip_step = ref.step_count();
  }
  ASSERT_GT(flip_step, 0) << "the cell did not flip";
  ASSERT_LT(flip_step + 100, kShearSteps);
  EXPECT_LE(ref.cell().matrix()(1, 0), PeriodicCell::kFlipRatio * ref.cell().matrix()(1, 1));
  EXPECT_GT(ref.macro().dissipated.rolling, 0.0);
  sheared_continues_bitwise(s, ref, kShearSteps / 2, false);  // the flip comes after the restart
  sheared_continues_bitwise(s, ref, flip_step + 50, true);    // saved with the flipped cell
}

// A sheared cell saved on 2 ranks after its flip (ShearedCheckpointFiles.Write, the fixture of
// ReadAndContinue) and continued on 1, 4 and 16 ranks: the trajectory and the cell bit for bit
// those of the uninterrupted serial run.
TEST(ShearedCheckpointFiles, Write) {
  const char* path = std::getenv("FABRICA_SHEARED_CHECKPOINT_FILE");
  if (!path) GTEST_SKIP() << "FABRICA_SHEARED_CHECKPOINT_FILE not set";
  const ShearedStart s = sheared_start();
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation sim(s.particles, s.cell, s.params, &domain);
  simple_shear(sim);
  bool flipped = false;
  run_sheared(sim, kShearSteps * 7 / 8, true, &flipped);
  ASSERT_TRUE(flipped) << "saved before the flip";
  const std::string text = "sheared cell test";
  CheckpointWriter w(MPI_COMM_WORLD, scene_fingerprint(text), "run");
  w.add_simulation("sim", sim);
  w.write(path);
}

TEST(ShearedCheckpointFiles, ReadAndContinue) {
  const char* path = std::getenv("FABRICA_SHEARED_CHECKPOINT_FILE");
  if (!path) GTEST_SKIP() << "FABRICA_SHEARED_CHECKPOINT_FILE not set";
  const ShearedStart s = sheared_start();
  Simulation ref(s.particles, s.cell, s.params);
  simple_shear(ref);
  run_sheared(ref, kShearSteps, false);
  const std::string text = "sheared cell test";
  Checkpoint::Expect ex;
  ex.scene_text = &text;
  const Checkpoint c = Checkpoint::read(MPI_COMM_WORLD, path, ex);
  EXPECT_NE(c.header().ranks, comm_size()) << "meant to be read on another rank count";
  MpiDomain domain(MPI_COMM_WORLD);
  Simulation restarted(c.simulation("sim", MPI_COMM_WORLD), &domain);
  run_sheared(restarted, kShearSteps, false);
  expect_same_trajectory(restarted, ref, 300);
  EXPECT_EQ(restarted.cell().matrix(), ref.cell().matrix());
  EXPECT_EQ(restarted.cell().strain(), ref.cell().strain());
  EXPECT_EQ(restarted.rebuild_count(), ref.rebuild_count());
}
