// The whole triaxial test of a scene with [triaxial] (docs/triaxial.md): one consolidation,
// then for each case of the sweep (or the single [contact] rolling_friction) a branch of the
// consolidated state that is re-equilibrated and sheared (apps/triaxial_stages.hpp, run by
// StageRun); under equilibration = "common" the re-equilibration runs once and the cases branch
// off its end state. Writes OUT/consolidation.csv, OUT/<case>/series.csv, the fabric files and
// OUT/summary.csv (rank 0), with 'output' the same series and the snapshots into run.h5 (cases
// "consolidation" and each case's name), and checkpoints ([run] checkpoint_every /
// checkpoint_seconds) that a restart continues from in any stage of any case.
//
// The states the cases branch from form a tree with explicit lifetimes (apps/branch_point.hpp):
// the consolidated state is the root, alive until the last case starts (a restart inside a
// case re-equilibrates the next one from it); under equilibration = "common" the first case's
// re-equilibrated state is a second one, alive until the last case. The last case takes the
// state it branches from over, and lets the consolidated state go if it branches from the
// re-equilibration.
#pragma once
#include "apps/app_checkpoint.hpp"
#include "apps/branch_point.hpp"
#include "apps/fabric_files.hpp"
#include "apps/series_file.hpp"
#include "apps/stage_record.hpp"
#include "apps/triaxial.hpp"
#include "io/serial/setup.hpp"

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace fabrica {

class TriaxialSweep {
 public:
  // 'setup', when given, is make_run_setup(triaxial_setup_scene(scene)) made beforehand (moved
  // from); without it the set-up is made here.
  TriaxialSweep(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output,
                const Checkpoint* restart, Setup* setup);
  int run();

 private:
  void read_restart();  // the case, cursor, accounts and results a checkpoint holds
  void consolidate(TriaxialRun& prep);
  void run_case(std::size_t i, const TriaxialRun& prep);
  // Case i's simulation and domain: its own state on a restart inside it, else a branch of the
  // common re-equilibration ('replay') or of the consolidated state.
  BranchPoint::State case_state(std::size_t i, bool resuming, bool replay);
  void write_summary();
  // The checkpoint's content: the simulations and the application's fields at 'cur'.
  AppCheckpoint::Sims sims() const;
  FieldWriter app_fields(const StageCursor& cur) const;
  void on_step(const StageCursor& cur);
  void check_rows();   // after every series row (collective)
  void flush_files();  // before every checkpoint (collective)
  [[noreturn]] void blowup(const BlowUpError& err);

  const MpiContext& mpi_;
  const Scene& scene_;
  std::filesystem::path out_;
  RunOutput* output_;
  const Checkpoint* restart_;
  bool root_;
  std::ostream* log_;
  std::vector<TriaxialCase> cases_;
  real_t d_mean_ = 0, density_ = 0;
  std::chrono::steady_clock::time_point t0_;
  // Where the protocol is (and, on a restart, was): the case (-1: consolidation), the cursor of
  // the stage, the consolidated state's account, the results so far, the finished cases' rows.
  std::int32_t current_case_ = -1, start_case_ = -1;
  std::int64_t restart_step_ = 0;
  StageCursor at_, prep_account_;
  StageResult cons_, equil_;
  double t_cons_ = 0;
  std::string summary_rows_;
  std::optional<SimulationSnapshot> case_snapshot_;
  // The consolidation's simulation, which the cases branch from; checkpoints inside a case hold
  // it ("prep") while it is alive.
  BranchPoint prepared_;
  // Under equilibration = "common", the re-equilibrated state every case shears from: the first
  // case that runs the re-equilibration from its start keeps its end state, its account and
  // what it wrote, and every later case starts from a copy (the same trajectory, bit for bit,
  // as a repeated re-equilibration; not kept for the last case, nor across a restart, after
  // which the next case re-equilibrates and keeps it again).
  struct SharedEquilibration {
    std::string source_case;  // whose snapshots the later cases link to
    BranchPoint state;
    StageCursor account;  // the run's strain reference and energy put in, at its end
    StageResult result;
    StageRecord record;
    FieldHistory fields;  // [fields]: the previous field instant at its end (displacement fields)
  };
  std::unique_ptr<SharedEquilibration> shared_;
  std::string header_;
  std::optional<SeriesFile> cons_series_;
  std::optional<FabricFiles> cons_fabric_;
  // The current simulation and its files (the consolidation's, then each case's).
  Simulation* current_ = nullptr;
  SeriesFile* current_series_ = nullptr;
  FabricFiles* current_fabric_ = nullptr;
  std::optional<AppCheckpoint> ckpt_;
};

}  // namespace fabrica
