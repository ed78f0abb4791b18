#include "apps/triaxial_sweep.hpp"

#include "apps/stage_cursor.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "io/mpi/run_output.hpp"
#include "io/serial/write_check.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

namespace fabrica {

namespace {
using clock = std::chrono::steady_clock;
const char* const kStageNames[] = {"consolidation", "equilibration", "shear"};
const char* const kSummaryHeader =
    "case,rolling_friction,void_ratio_consolidated,peak_q_p,eps1_at_peak,eps_v_end,q_p_end,"
    "max_lateral_error,max_energy_error,max_inertial_number,wall_seconds\n";

std::vector<TriaxialCase> sweep_cases(const Scene& scene) {
  std::vector<TriaxialCase> cases;
  if (scene.triaxial.rolling_friction_cases.empty())
    cases.push_back({fmt::format("mur_{}", scene.law.rolling_friction), scene.law.rolling_friction});
  for (real_t mur : scene.triaxial.rolling_friction_cases) cases.push_back({fmt::format("mur_{}", mur), mur});
  return cases;
}
}  // namespace

TriaxialSweep::TriaxialSweep(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output,
                             const Checkpoint* restart, Setup* setup)
    : mpi_(mpi), scene_(scene), out_(outdir), output_(output), restart_(restart), root_(mpi.rank() == 0),
      log_(root_ ? &std::cout : nullptr), cases_(sweep_cases(scene)) {
  const TriaxialSpec& tx = scene.triaxial;
  // The time step must suit the stiffest stage: rolling springs of the largest mu_r included.
  Setup s = setup ? std::move(*setup) : make_run_setup(triaxial_setup_scene(scene), mpi.comm(), domain_options(scene));
  s.params.law = scene.law;
  s.params.materials = scene_materials(scene);
  const SpecimenTotals tot = specimen_totals(s.particles, mpi.comm());  // of every rank's share
  d_mean_ = tot.diameter_sum / real_t(tot.count);
  density_ = tot.mass / tot.volume;
  if (log_)
    *log_ << fmt::format(
        "triaxial test: {} spheres, mean diameter {:.2f} mm, {} rank(s), time step "
        "{:.3e} s ({:.3f} of the critical estimate), {} case(s)\n",
        tot.count, d_mean_ * 1e3, mpi.size(), s.params.dt, s.params.dt / s.critical_dt, cases_.size());
  // The servo holds the lateral stresses by lateral strain rates of about half the axial rate
  // (more while the specimen dilates); a cap below the axial rate may not suffice.
  if (log_ && tx.max_strain_rate < tx.axial_strain_rate)
    *log_ << fmt::format(
        "warning: {}: [triaxial] max_strain_rate = {} 1/s is below axial_strain_rate = "
        "{} 1/s: the servo may not hold the lateral stresses at {} Pa during the shear "
        "(it needs lateral rates of about half the axial rate, more while the specimen "
        "dilates); raise max_strain_rate\n",
        scene.path, tx.max_strain_rate, tx.axial_strain_rate, tx.confining_pressure);
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  t0_ = clock::now();
  if (restart_) read_restart();
  start_case_ = current_case_;
  // A checkpoint inside a case holds the case ("sim") and the consolidated state ("prep"),
  // except in the last case, which took the consolidated state over: then "sim" alone, read
  // into prepared_, which that case takes over again (run_case).
  const bool with_prep = restart_ && start_case_ >= 0 && restart_->has("prep.global");
  if (with_prep) case_snapshot_ = restart_->simulation("sim", mpi.comm());
  std::unique_ptr<Simulation> sim = !restart_
      ? std::make_unique<Simulation>(std::move(s.particles), s.cell, s.params, domain.get(), s.holding)
      : std::make_unique<Simulation>(restart_->simulation(with_prep ? "prep" : "sim", mpi.comm()), domain.get());
  prepared_ = BranchPoint({std::move(domain), std::move(sim)});
  current_ = &prepared_.state();
  restart_step_ = restart_ ? restart_->header().step : 0;
  if (output_ && restart_) {  // run.h5: what the run wrote after the checkpoint goes
    std::vector<std::string> names{"consolidation"};
    for (const TriaxialCase& tc : cases_) names.push_back(tc.name);
    output_->resume_after(restart_step_, names, std::size_t(start_case_ + 1));
  }
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes a checkpoint
    if (root_) make_output_directory(out_.string());
  });
  std::ostringstream h;
  write_series_header(h, false, scene.fields.localisation());
  header_ = h.str();
  // The consolidation's series and fabric files; on a restart in it, rows after its step go.
  if (start_case_ < 0) {
    cons_series_.emplace(mpi.comm(), (out_ / "consolidation.csv").string(), header_, 1, restart_ ? restart_step_ : -1);
    agree(mpi.comm(), [&] {
      cons_fabric_.emplace(root_ && scene.fabric.enabled, out_, "consolidation_", int(scene.fabric.rose_bins),
                           restart_ ? restart_step_ : -1);
    });
    current_series_ = &*cons_series_;
    current_fabric_ = &*cons_fabric_;
  }
  ckpt_.emplace(
      mpi.comm(), scene, out_.string(), "triaxial", prepared_.state().step_count(), [this] { flush_files(); },
      output_ ? &output_->field_history() : nullptr, log_, "  ");
}

void TriaxialSweep::read_restart() {
  FieldReader in = restart_->fields("app");
  current_case_ = in.i32("case");
  at_ = read_cursor(in);
  prep_account_ = read_cursor(in);
  cons_ = read_result(in);
  equil_ = read_result(in);
  t_cons_ = in.f64("consolidation_seconds");
  summary_rows_ = in.text("summary_rows");
  in.done();
  if (current_case_ < -1 || current_case_ >= std::int32_t(cases_.size()))
    throw InputError(restart_->path() + ": section app: case " + std::to_string(current_case_) + " of a sweep of " +
                     std::to_string(cases_.size()) + ": not the state of this build's triaxial application");
}

// After every series row, on every rank: the rows so far are written (rank 0's check, agreed).
void TriaxialSweep::check_rows() {
  if (current_series_) current_series_->check();
  agree(mpi_.comm(), [&] {
    if (root_ && current_fabric_) current_fabric_->check();
  });
}

// On disk before a checkpoint: it never refers to rows or output that are not.
void TriaxialSweep::flush_files() {
  if (current_series_) current_series_->sync();
  agree(mpi_.comm(), [&] {
    if (root_ && current_fabric_) current_fabric_->flush();
  });
  if (output_) output_->flush();  // collective
}

// The current simulation, and inside a case the consolidated one every later case branches from.
AppCheckpoint::Sims TriaxialSweep::sims() const {
  AppCheckpoint::Sims v{{"sim", current_}};
  if (current_case_ >= 0 && prepared_.alive()) v.push_back({"prep", &prepared_.state()});
  return v;
}

FieldWriter TriaxialSweep::app_fields(const StageCursor& cur) const {
  FieldWriter app;
  app.i32("case", current_case_);
  write_cursor(app, cur);
  write_cursor(app, prep_account_);
  write_result(app, cons_);
  write_result(app, equil_);
  app.f64("consolidation_seconds", t_cons_).text("summary_rows", summary_rows_);
  return app;
}

void TriaxialSweep::on_step(const StageCursor& cur) {
  if (!ckpt_->due(*current_)) return;
  const std::string where = current_case_ < 0 ? "consolidation" : cases_[current_case_].name;
  ckpt_->save(sims(), app_fields(cur), fmt::format(" ({}, {})", where, kStageNames[cur.stage]));
}

// The state at detection goes to OUT/blowup.ckpt. Called where the simulation that blew up is
// still alive (inside a case, its simulation and files are run_case's locals).
void TriaxialSweep::blowup(const BlowUpError& err) { ckpt_->blowup(err, sims(), app_fields(StageCursor{})); }

// summary.csv is written whole after every case (path.tmp, checked, synced, renamed).
void TriaxialSweep::write_summary() {
  const std::string path = (out_ / "summary.csv").string();
  agree(mpi_.comm(), [&] {
    if (root_) write_file_atomic(path, kSummaryHeader + summary_rows_);
  });
}

void TriaxialSweep::consolidate(TriaxialRun& prep) {
  prep.on_step([this](const StageCursor& c) { on_step(c); });
  cons_ = restart_ ? prep.resume(at_) : prep.consolidate();
  prep.on_step(nullptr);
  // Every case branches from here. A rebuild of the lists makes this state one that a
  // checkpoint restores exactly (docs/checkpoint.md), for the cases after a restart.
  prepared_.state().rebuild();
  t_cons_ = std::chrono::duration<double>(clock::now() - t0_).count();
  cons_series_->close();  // complete on disk before any checkpoint of a case
  agree(mpi_.comm(), [&] { cons_fabric_->close(); });
  current_series_ = nullptr;
  current_fabric_ = nullptr;
  cons_fabric_.reset();
}

BranchPoint::State TriaxialSweep::case_state(std::size_t i, bool resuming, bool replay) {
  const bool last = i + 1 == cases_.size();
  if (resuming && case_snapshot_) {  // its own state, read apart: the consolidated one lives on
    BranchPoint::State own;
    own.domain = prepared_.domain() ? prepared_.domain()->clone() : nullptr;
    own.sim = std::make_unique<Simulation>(std::move(*case_snapshot_), own.domain.get());
    return own;
  }
  if (!replay) return prepared_.branch(last);  // resumed without "prep": prepared_ holds the case
  if (last) prepared_.release();
  return shared_->state.branch(last);
}

void TriaxialSweep::run_case(std::size_t i, const TriaxialRun& prep) {
  const TriaxialCase& tc = cases_[i];
  const bool resuming = restart_ && std::int32_t(i) == start_case_;
  const bool equilibrate = !resuming && scene_.triaxial.equilibration != TriaxialSpec::Equilibration::None;
  // "common": every case's re-equilibration is the same; the first one is kept for the others.
  const bool replay = equilibrate && shared_;
  const bool keep = equilibrate && !shared_ && i + 1 < cases_.size() &&
      scene_.triaxial.equilibration == TriaxialSpec::Equilibration::Common;
  const auto t1 = clock::now();
  const BranchPoint::State state = case_state(i, resuming, replay);
  const std::unique_ptr<Domain>& d2 = state.domain;
  Simulation& sim = *state.sim;
  SeriesFile series(mpi_.comm(), (out_ / tc.name / "series.csv").string(), header_, 1, resuming ? restart_step_ : -1);
  std::optional<FabricFiles> fabric;
  agree(mpi_.comm(), [&] {
    fabric.emplace(root_ && scene_.fabric.enabled, out_ / tc.name, "", int(scene_.fabric.rose_bins),
                   resuming ? restart_step_ : -1);
  });
  current_ = &sim;
  current_series_ = &series;
  current_fabric_ = &*fabric;
  current_case_ = std::int32_t(i);
  ckpt_->rebase(sim.step_count());
  TriaxialRun run(scene_, sim, d_mean_, density_, series.stream(), log_, &prep);
  run.on_step([this](const StageCursor& c) { on_step(c); });
  run.set_fabric_output(fabric->streams());
  run.on_row([this] { check_rows(); });
  run.set_output(output_, tc.name);
  if (log_)
    *log_ << fmt::format("case {}: mu_s = {}, mu_r = {}{}\n", tc.name, scene_.law.friction, tc.rolling_friction,
                         resuming ? fmt::format(" (resumed at step {})", sim.step_count()) : "");
  StageResult sh;
  const StageResult saved = equil_;
  equil_ = StageResult{};
  std::string shared_from;  // the case whose re-equilibration this one shares
  if (replay) {             // what the re-equilibration wrote, and its end state's account
    shared_from = shared_->source_case;
    run.set_account(shared_->account);
    equil_ = shared_->result;
    shared_->record.replay(series.stream(), fabric->streams(), output_, header_, shared_->source_case, tc.name);
    if (output_) {  // the next field instant's displacement starts from the re-equilibration's last one
      FieldHistory& h = output_->field_history();
      h = shared_->fields;
      if (h.instant() && h.instant()->case_name == shared_->source_case) h.rename(tc.name);
    }
    check_rows();
    if (i + 1 == cases_.size()) shared_.reset();  // the last case: it took the state over
  }
  try {
    if (resuming && at_.stage == kShear) {
      equil_ = saved;
      sh = run.resume(at_);
    } else {
      if (resuming) equil_ = run.resume(at_);
      else if (equilibrate && !replay) {
        auto kept = keep ? std::make_unique<SharedEquilibration>() : nullptr;
        if (kept) run.record(&kept->record), kept->record.first_step = sim.step_count();
        equil_ = run.equilibrate(equilibration_rolling_friction(scene_, tc.rolling_friction));
        run.record(nullptr);
        if (kept) {
          kept->source_case = tc.name;
          kept->record.last_step = sim.step_count();
          kept->state = BranchPoint(sim, d2.get());
          kept->account = run.account();
          kept->result = equil_;
          if (output_) kept->fields = output_->field_history();
          shared_ = std::move(kept);
        }
      }
      sh = run.shear(tc.rolling_friction);
    }
  } catch (const BlowUpError& err) {  // every rank is here (the diagnosis is collective)
    blowup(err);
  }
  const StageResult& e = equil_;
  const double secs = std::chrono::duration<double>(clock::now() - t1).count();
  const real_t p_end = sh.state.p;
  const real_t inertial = scene_.triaxial.axial_strain_rate * d_mean_ * std::sqrt(density_ / std::max(p_end, 1.0));
  const real_t qp_end = p_end > 0 ? sh.state.q / p_end : 0;
  const real_t energy_error = std::max(e.max_energy_error, sh.max_energy_error);
  if (log_)
    *log_ << fmt::format(
        "case {}: {}; sheared to eps1 = {:.3f} in {} steps "
        "({:.1f} s): peak q/p {:.4f} at eps1 = {:.4f}, end q/p {:.4f}, eps_v {:.4f}, "
        "lateral stress error <= {:.2f} %, energy balance error <= {:.3f} %, "
        "inertial number {:.2e}\n",
        tc.name,
        scene_.triaxial.equilibration == TriaxialSpec::Equilibration::None
            ? fmt::format("not re-equilibrated (void ratio {:.4f})", cons_.state.void_ratio)
            : fmt::format(
                  "equilibrated in {} steps (mu_r = {}, void ratio {:.4f}){}", e.steps,
                  equilibration_rolling_friction(scene_, tc.rolling_friction), e.state.void_ratio,
                  shared_from.empty() ? std::string() : fmt::format(", the re-equilibration of case {}", shared_from)),
        sh.strain[0], sh.steps, secs, sh.peak_q_p, sh.peak_eps1, qp_end, sh.strain.sum(), 100 * sh.max_lateral_error,
        100 * energy_error, inertial);
  if (log_ && scene_.fabric.enabled)
    *log_ << fmt::format("case {}: fabric analysis {:.2f} s ({:.2f} % of the case's {:.1f} s)\n", tc.name,
                         run.fabric_seconds(), 100 * run.fabric_seconds() / secs, secs);
  summary_rows_ += fmt::format("{},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.3e},{:.1f}\n", tc.name,
                               tc.rolling_friction, cons_.state.void_ratio, sh.peak_q_p, sh.peak_eps1, sh.strain.sum(),
                               qp_end, sh.max_lateral_error, energy_error, inertial, secs);
  series.close();
  agree(mpi_.comm(), [&] { fabric->close(); });
  write_summary();
  current_ = &prepared_.state();  // the case's simulation and files end here
  current_series_ = nullptr;
  current_fabric_ = nullptr;
}

int TriaxialSweep::run() {
  try {
    TriaxialRun prep(scene_, prepared_.state(), d_mean_, density_, cons_series_ ? cons_series_->stream() : nullptr,
                     log_);
    if (cons_fabric_) prep.set_fabric_output(cons_fabric_->streams());
    prep.set_output(output_, "consolidation");
    prep.on_row([this] { check_rows(); });
    if (start_case_ < 0) consolidate(prep);
    else prep.set_account(prep_account_);
    prep_account_ = prep.account();
    if (log_)
      *log_ << fmt::format(
          "consolidated to p = {:.1f} kPa in {} steps ({:.1f} s): void ratio {:.4f}, "
          "Z {:.3f}, mean overlap {:.3f} % of the mean diameter\n",
          cons_.state.p / 1e3, cons_.steps, t_cons_, cons_.state.void_ratio, cons_.state.coordination,
          100 * cons_.state.mean_overlap / d_mean_);
    write_summary();
    if (!scene_.triaxial.consolidation_only)
      for (std::size_t i = std::size_t(std::max(0, start_case_)); i < cases_.size(); ++i) run_case(i, prep);
  } catch (const BlowUpError& err) {  // in the consolidation: every rank is here
    blowup(err);
  }
  if (log_) *log_ << fmt::format("series and summary written to {}\n", out_.string());
  return 0;
}

}  // namespace fabrica
