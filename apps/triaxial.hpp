// The periodic triaxial test (shared/spec/reference-problem.md section 4) as three stages on a
// Simulation: servo-controlled isotropic consolidation, re-equilibration with the shear-stage
// contact parameters, and conventional triaxial compression along axis 1 with the lateral
// stresses held by the servo. Every rank runs the same control flow; every decision is taken
// from reduced (identical) values.
#pragma once
#include "parallel/mpi_domain.hpp"
#include "apps/fabric_output.hpp"
#include "apps/servo.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>

namespace fabrica {

class RunOutput;

struct TriaxialCase {
  std::string name;        // e.g. "mur_0.05"
  real_t rolling_friction; // mu_r of the shear stage
};

struct StageResult {
  std::int64_t steps = 0;
  MacroState state;
  Vec3 strain = Vec3::Zero();  // eps_i = ln(l_i0 / l_i), compression positive
  // Shear only, over every row of the series (the output instants and the stage's last row):
  // the largest q/p and eps_1 there, and the largest relative error of the lateral stresses,
  // max |sigma_ii - target| / target, i = 2, 3.
  real_t peak_q_p = 0;
  real_t peak_eps1 = 0;
  real_t max_lateral_error = 0;
  real_t max_energy_error = 0;   // over the stage, relative to the energy put in (energy_in)
};

enum class TriaxialStage : std::int32_t { Consolidation, Equilibration, Shear };

// Where a run is inside a stage, with the run's own account: what a checkpoint saves to resume
// the stage bit for bit (plain values only: it is stored as bytes).
struct StageCursor {
  TriaxialStage stage = TriaxialStage::Consolidation;
  std::int64_t k = 0;            // steps of the stage done
  Vec3 servo_integral = Vec3::Zero();
  real_t last_servo = 0;         // s, time of the last servo update
  StageResult result;            // so far
  Vec3 l0 = Vec3::Zero();        // the run's strain reference
  real_t input_positive = 0;     // J, energy_in() less the initial energy
  real_t input_seen = 0;         // J, boundary + gravity work at the last measurement
};

// One run of the protocol: the series rows go to 'series' (rank 0's stream; others pass null).
class TriaxialRun {
 public:
  // With a parent (the run 'sim' was copied from), strains and the energy account continue.
  TriaxialRun(const Scene& scene, Simulation& sim, real_t mean_diameter, real_t density,
              std::ostream* series, std::ostream* log, const TriaxialRun* parent = nullptr);

  StageResult consolidate();
  StageResult equilibrate(real_t rolling_friction);
  StageResult shear();
  // Continues the stage a checkpoint was taken in (the simulation restored from it).
  StageResult resume(const StageCursor& at);
  // Called at the end of every step of a stage that does not end there (to take checkpoints).
  void on_step(std::function<void(const StageCursor&)> hook) { hook_ = std::move(hook); }
  // Called on every rank after every series row (to check and agree that it was written).
  void on_row(std::function<void()> check) { row_check_ = std::move(check); }

  real_t boundary_work() const { return sim_.boundary_work(); }
  // The total energy put in [J]: the simulation's initial energy plus every positive increment
  // of the boundary and gravity work between two measurements. It never decreases, so it can
  // normalise the energy error of a specimen that unloads (the net work may pass through zero).
  real_t energy_in() const { return sim_.energy_account().e0 + in_pos_; }
  // The run's account (strain reference, energy put in) in the fields of a cursor, and its
  // restoration (the parent of the cases, on a restart).
  StageCursor account() const;
  void set_account(const StageCursor& a);

  // Fabric analysis ([fabric] enabled): at the output rows of the shear stage and at the end of
  // consolidation, on every rank (collective); rows go to 'out' (rank 0's streams; others pass
  // null or nothing). Wall seconds spent in it (records, analysis, output) so far:
  void set_fabric_output(const FabricStreams* out) { fabric_out_ = out; }
  double fabric_seconds() const { return fabric_seconds_; }
  // Optional HDF5 output (io/run_output.hpp): the series rows and the snapshots (every
  // [run] snapshot_every steps and at the end of each stage) go to case 'case_name' of 'out'.
  void set_output(RunOutput* out, std::string case_name) {
    output_ = out;
    case_ = std::move(case_name);
  }

 private:
  using Stage = TriaxialStage;
  // Steps until the stage is done (checked at servo steps); the servo updates the rates.
  StageResult run_stage(Stage stage, const StageCursor* resume = nullptr);
  void row(Stage stage, const MacroState& m, const Vec3& eps);
  void fabric_row(Stage stage, const Vec3& eps);
  Servo make_servo(std::array<bool, 3> axes, Vec3 fixed) const;
  // The servo's rates for measurement 'm' (collective: the specimen's stiffness is reduced).
  Vec3 update_servo(Servo& servo, Stage stage, const MacroState& m, real_t elapsed);
  // (energy put in - stored - dissipated) / energy_in(), from the simulation's one account.
  real_t energy_error(const MacroState& m) const;
  void track_input(const MacroState& m);  // at every measurement: energy_in() grows

  const Scene& scene_;
  const TriaxialSpec& tx_;
  Simulation& sim_;
  real_t d_mean_, density_;
  std::ostream* series_;
  std::ostream* log_;
  Vec3 l0_;          // cell lengths at the start of the current strain reference
  real_t in_pos_ = 0;      // J, sum of the positive increments of input_seen_
  real_t input_seen_ = 0;  // J, boundary + gravity work at the last measurement
  std::function<void(const StageCursor&)> hook_;
  std::function<void()> row_check_;
  const FabricStreams* fabric_out_ = nullptr;
  double fabric_seconds_ = 0;
  RunOutput* output_ = nullptr;
  std::string case_;
};

void write_series_header(std::ostream& out);

// DIR/<prefix>fabric.csv, sff.csv, rose.csv with their headers (when 'open'; rank 0). With
// 'resume_step' >= 0 (a restart in the stage that writes them) the existing files keep their
// rows up to that step (the others are written again) and are appended to.
class FabricFiles {
 public:
  FabricFiles(bool open, const std::filesystem::path& dir, const std::string& prefix, int rose_bins,
              std::int64_t resume_step = -1);
  const FabricStreams* streams() const { return streams_.fabric ? &streams_ : nullptr; }
  // Each throws a WriteError naming the file if a write so far failed (io/write_check.hpp).
  void check();  // the rows so far written
  void flush();  // the rows so far on disk (before a checkpoint)
  void close();  // synced and closed

 private:
  std::array<std::string, 3> paths_;
  std::ofstream fabric_, sff_, rose_;
  FabricStreams streams_;
};

class MpiContext;
class Checkpoint;
struct Setup;
// The scene's MPI domain ([parallel]) on several ranks; null (serial) on one.
// The decomposition options of the scene's [parallel] table.
MpiDomainOptions domain_options(const Scene& scene);
std::unique_ptr<Domain> make_domain(const MpiContext& mpi, const Scene& scene);

// The whole test for a scene with [triaxial]: one consolidation, then for each case of the sweep
// (or the single [contact] rolling_friction) a branch of the consolidated state that is
// re-equilibrated and sheared. Writes OUT/<case>/series.csv and OUT/summary.csv (rank 0), and
// with 'output' the same series and the snapshots into run.h5 (cases "consolidation" and each
// case's name). Checkpoints ([run] checkpoint_every / checkpoint_seconds) go to OUT/checkpoint.ckpt; with
// 'restart' the test continues from one (docs/checkpoint.md).
// 'setup', when given, is make_setup(triaxial_setup_scene(scene)) made beforehand (fabrica run
// checks it before run.h5 is created); it is moved from. Without it the set-up is made here.
int run_triaxial(const MpiContext& mpi, const Scene& scene, const std::string& outdir,
                 RunOutput* output = nullptr, const Checkpoint* restart = nullptr,
                 Setup* setup = nullptr);

// The scene whose particle set-up a triaxial run uses: the scene with the largest mu_r of its
// sweep, so that the time step suits the stiffest stage (rolling springs included).
Scene triaxial_setup_scene(const Scene& scene);

}  // namespace fabrica
