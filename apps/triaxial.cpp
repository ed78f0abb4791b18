#include "apps/triaxial.hpp"

#include "apps/app_checkpoint.hpp"
#include "apps/series_file.hpp"
#include "apps/stage_cursor.hpp"

#include "io/distributed_setup.hpp"

#include "core/contact_snapshot.hpp"
#include "core/fabric.hpp"

#include "io/checkpoint.hpp"
#include "io/run_output.hpp"
#include "io/setup.hpp"
#include "io/write_check.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/mpi_domain.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>

namespace fabrica {

namespace {
const char* const kStageNames[] = {"consolidation", "equilibration", "shear"};
}  // namespace

StageResult TriaxialRun::resume(const StageCursor& at) {
  set_account(at);  // the contact law and damping are the simulation's, restored with it
  if (at.stage == kShear) return run(shear_stage(scene_), kShear, &at);
  const StageSpec st = at.stage == kConsolidation ? consolidation_stage(scene_)
                                                   : equilibration_stage(scene_, sim_.params().law.rolling_friction);
  return run(st, at.stage, &at);
}

// The fabric files of one directory (rank 0 only; 'open' false: no files, null streams).
FabricFiles::FabricFiles(bool open, const std::filesystem::path& dir, const std::string& prefix,
                         int rose_bins, std::int64_t resume_step) {
  if (!open) return;
  make_output_directory(dir.string());
  const std::filesystem::path f = dir / (prefix + "fabric.csv"), s = dir / (prefix + "sff.csv"),
                              r = dir / (prefix + "rose.csv");
  // On a restart, the rows after the checkpoint's step go (column 1 is the step), as in the
  // series; if any of the three files is missing, all three start again.
  bool kept = false;
  if (resume_step >= 0) {
    kept = true;
    for (const auto& p : {f, s, r})
      if (!keep_series_through(p.string(), 1, resume_step)) kept = false;
  }
  const auto mode = kept ? std::ios::app : std::ios::trunc;
  paths_ = {f.string(), s.string(), r.string()};
  open_checked(fabric_, paths_[0], mode);
  open_checked(sff_, paths_[1], mode);
  open_checked(rose_, paths_[2], mode);
  streams_ = {&fabric_, &sff_, &rose_};
  if (!kept) write_fabric_headers(streams_, rose_bins);
  check();
}

void FabricFiles::check() {
  if (!streams_.fabric) return;
  check_stream(fabric_, paths_[0]), check_stream(sff_, paths_[1]), check_stream(rose_, paths_[2]);
}

void FabricFiles::flush() {
  if (!streams_.fabric) return;
  sync_stream(fabric_, paths_[0]), sync_stream(sff_, paths_[1]), sync_stream(rose_, paths_[2]);
}

void FabricFiles::close() {
  if (!streams_.fabric) return;
  close_checked(fabric_, paths_[0]), close_checked(sff_, paths_[1]), close_checked(rose_, paths_[2]);
  streams_ = {};
}

MpiDomainOptions domain_options(const Scene& scene) {
  MpiDomainOptions o;
  o.kind = scene.parallel.decomposition == "metis" ? DecompositionKind::Metis
                                                   : DecompositionKind::Cartesian;
  o.rebalance_threshold = scene.parallel.rebalance_threshold;
  o.rebalance_interval = int(scene.parallel.rebalance_interval);
  return o;
}

std::unique_ptr<Domain> make_domain(const MpiContext& mpi, const Scene& scene) {
  if (mpi.size() == 1) return nullptr;
  return std::make_unique<MpiDomain>(mpi.comm(), domain_options(scene));
}

Scene triaxial_setup_scene(const Scene& scene) {
  Scene sized = scene;
  for (real_t mur : scene.triaxial.rolling_friction_cases)
    sized.law.rolling_friction = std::max(sized.law.rolling_friction, mur);
  for (const StageSpec& st : scene.stages)
    if (st.rolling_friction) sized.law.rolling_friction = std::max(sized.law.rolling_friction, *st.rolling_friction);
  return sized;
}

int run_triaxial(const MpiContext& mpi, const Scene& scene, const std::string& outdir,
                 RunOutput* output, const Checkpoint* restart, Setup* setup) {
  namespace fs = std::filesystem;
  using clock = std::chrono::steady_clock;
  const bool root = mpi.rank() == 0;
  std::ostream* log = root ? &std::cout : nullptr;
  const TriaxialSpec& tx = scene.triaxial;
  std::vector<TriaxialCase> cases;
  if (tx.rolling_friction_cases.empty()) {
    cases.push_back({fmt::format("mur_{}", scene.law.rolling_friction), scene.law.rolling_friction});
  } else {
    for (real_t mur : tx.rolling_friction_cases) cases.push_back({fmt::format("mur_{}", mur), mur});
  }
  // The time step must suit the stiffest stage: rolling springs of the largest mu_r included.
  Setup s = setup ? std::move(*setup)
                  : make_run_setup(triaxial_setup_scene(scene), mpi.comm(), domain_options(scene));
  s.params.law = scene.law;
  const SpecimenTotals tot = specimen_totals(s.particles, mpi.comm());  // of every rank's share
  const real_t d_mean = tot.diameter_sum / real_t(tot.count), density = tot.mass / tot.volume;
  if (log)
    *log << fmt::format("triaxial test: {} spheres, mean diameter {:.2f} mm, {} rank(s), time step "
                        "{:.3e} s ({:.3f} of the critical estimate), {} case(s)\n",
                        tot.count, d_mean * 1e3, mpi.size(), s.params.dt,
                        s.params.dt / s.critical_dt, cases.size());
  // The servo holds the lateral stresses by lateral strain rates of about half the axial rate
  // (more while the specimen dilates); a cap below the axial rate may not suffice.
  if (log && tx.max_strain_rate < tx.axial_strain_rate)
    *log << fmt::format("warning: {}: [triaxial] max_strain_rate = {} 1/s is below axial_strain_rate = "
                        "{} 1/s: the servo may not hold the lateral stresses at {} Pa during the shear "
                        "(it needs lateral rates of about half the axial rate, more while the specimen "
                        "dilates); raise max_strain_rate\n",
                        scene.path, tx.max_strain_rate, tx.axial_strain_rate, tx.confining_pressure);
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  const auto t0 = clock::now();
  // On a restart: the case (-1: consolidation) and stage the checkpoint was taken in, the
  // consolidated state's account, the results so far and the summary rows of finished cases.
  std::int32_t current_case = -1;
  StageCursor at, prep_account;
  StageResult c, e_saved;
  double t_cons = 0;
  std::string summary_rows;
  if (restart) {
    FieldReader in = restart->fields("app");
    current_case = in.i32("case");
    at = read_cursor(in);
    prep_account = read_cursor(in);
    c = read_result(in);
    e_saved = read_result(in);
    t_cons = in.f64("consolidation_seconds");
    summary_rows = in.text("summary_rows");
    in.done();
    if (current_case < -1 || current_case >= std::int32_t(cases.size()))
      throw InputError(restart->path() + ": section app: case " + std::to_string(current_case) +
                       " of a sweep of " + std::to_string(cases.size()) +
                       ": not the state of this build's triaxial application");
  }
  const std::int32_t start_case = current_case;
  std::optional<SimulationSnapshot> case_snapshot;  // decoded before any file is touched
  if (restart && start_case >= 0) case_snapshot = restart->simulation("sim", mpi.comm());
  std::unique_ptr<Simulation> prepared =
      !restart ? std::make_unique<Simulation>(std::move(s.particles), s.cell, s.params, domain.get(),
                                              s.holding)
               : std::make_unique<Simulation>(
                     restart->simulation(start_case < 0 ? "sim" : "prep", mpi.comm()), domain.get());
  const std::int64_t restart_step = restart ? restart->header().step : 0;
  if (output && restart) {  // run.h5: what the run wrote after the checkpoint goes
    std::vector<std::string> names{"consolidation"};
    for (const TriaxialCase& tc : cases) names.push_back(tc.name);
    output->resume_after(restart_step, names, std::size_t(start_case + 1));
  }
  const fs::path out(outdir);
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes a checkpoint
    if (root) make_output_directory(out.string());
  });
  const std::string header = [] {
    std::ostringstream h;
    write_series_header(h);
    return h.str();
  }();
  // The consolidation's series and fabric files; on a restart in it, rows after its step go.
  std::optional<SeriesFile> cons_series;
  std::optional<FabricFiles> cons_fabric;
  if (start_case < 0) {
    cons_series.emplace(mpi.comm(), (out / "consolidation.csv").string(), header, 1,
                        restart ? restart_step : -1);
    agree(mpi.comm(), [&] {
      cons_fabric.emplace(root && scene.fabric.enabled, out, "consolidation_",
                          int(scene.fabric.rose_bins), restart ? restart_step : -1);
    });
  }
  // Where the protocol is: the current simulation and its files (the consolidation's, then
  // each case's).
  Simulation* current = prepared.get();
  SeriesFile* current_series = cons_series ? &*cons_series : nullptr;
  FabricFiles* current_fabric = cons_fabric ? &*cons_fabric : nullptr;
  // After every series row, on every rank: the rows so far are written (rank 0's check, agreed).
  auto row_check = [&] {
    if (current_series) current_series->check();
    agree(mpi.comm(), [&] {
      if (root && current_fabric) current_fabric->check();
    });
  };
  // Checkpoints: the current simulation, the consolidated one (inside a case) and the state of
  // the protocol, at rebuild steps (StageRun::on_step).
  StageCursor prep_acc;
  StageResult e_res;
  AppCheckpoint ckpt(mpi.comm(), scene, outdir, "triaxial", prepared->step_count(), [&] {
    if (current_series) current_series->sync();
    agree(mpi.comm(), [&] {
      if (root && current_fabric) current_fabric->flush();
    });
    if (output) output->flush();  // collective
  }, log, "  ");
  auto sims = [&] {
    AppCheckpoint::Sims v{{"sim", current}};
    if (current_case >= 0) v.push_back({"prep", prepared.get()});
    return v;
  };
  auto app_fields = [&](const StageCursor& cur) {
    FieldWriter app;
    app.i32("case", current_case);
    write_cursor(app, cur);
    write_cursor(app, prep_acc);
    write_result(app, c);
    write_result(app, e_res);
    app.f64("consolidation_seconds", t_cons).text("summary_rows", summary_rows);
    return app;
  };
  // A blow-up: the state at detection goes to OUT/blowup.ckpt. Called where the simulation that
  // blew up is still alive (inside a case, its simulation and files are the case's locals).
  auto blowup = [&](const BlowUpError& err) { ckpt.blowup(err, sims(), app_fields(StageCursor{})); };
  auto hook = [&](const StageCursor& cur) {
    if (ckpt.due(*current))
      ckpt.save(sims(), app_fields(cur),
                fmt::format(" ({}, {})", current_case < 0 ? std::string("consolidation") : cases[current_case].name,
                            kStageNames[cur.stage]));
  };
  try {
    TriaxialRun prep(scene, *prepared, d_mean, density, cons_series ? cons_series->stream() : nullptr, log);
    if (cons_fabric) prep.set_fabric_output(cons_fabric->streams());
    prep.set_output(output, "consolidation");
    prep.on_row(row_check);
    if (start_case < 0) {
      prep.on_step(hook);
      c = restart ? prep.resume(at) : prep.consolidate();
      prep.on_step(nullptr);
      // Every case branches from here. A rebuild of the lists makes this state one that a
      // checkpoint restores exactly (docs/checkpoint.md), for the cases after a restart.
      prepared->rebuild();
      t_cons = std::chrono::duration<double>(clock::now() - t0).count();
      cons_series->close();  // complete on disk before any checkpoint of a case
      agree(mpi.comm(), [&] {
        if (cons_fabric) cons_fabric->close();
      });
      current_series = nullptr;
      current_fabric = nullptr;
      cons_fabric.reset();
    } else {
      prep.set_account(prep_account);
    }
    prep_acc = prep.account();
    if (log)
      *log << fmt::format("consolidated to p = {:.1f} kPa in {} steps ({:.1f} s): void ratio {:.4f}, "
                          "Z {:.3f}, mean overlap {:.3f} % of the mean diameter\n",
                          c.state.p / 1e3, c.steps, t_cons, c.state.void_ratio, c.state.coordination,
                          100 * c.state.mean_overlap / d_mean);
    // summary.csv is written whole after every case (path.tmp, checked, synced, renamed).
    const std::string summary_path = (out / "summary.csv").string();
    auto write_summary = [&] {
      agree(mpi.comm(), [&] {
        if (root)
          write_file_atomic(summary_path,
                            "case,rolling_friction,void_ratio_consolidated,peak_q_p,eps1_at_peak,"
                            "eps_v_end,q_p_end,max_lateral_error,max_energy_error,"
                            "max_inertial_number,wall_seconds\n" + summary_rows);
      });
    };
    write_summary();
    for (std::size_t i = std::size_t(std::max(0, start_case)); i < cases.size(); ++i) {
      const TriaxialCase& tc = cases[i];
      const bool resuming = restart && std::int32_t(i) == start_case;
      const auto t1 = clock::now();
      std::unique_ptr<Domain> d2 = domain ? domain->clone() : nullptr;
      std::unique_ptr<Simulation> simp =
          resuming ? std::make_unique<Simulation>(std::move(*case_snapshot), d2.get())
                   : std::make_unique<Simulation>(*prepared, d2.get());
      Simulation& sim = *simp;
      SeriesFile series(mpi.comm(), (out / tc.name / "series.csv").string(), header, 1,
                        resuming ? restart_step : -1);
      std::optional<FabricFiles> fabric;
      agree(mpi.comm(), [&] {
        fabric.emplace(root && scene.fabric.enabled, out / tc.name, "", int(scene.fabric.rose_bins),
                       resuming ? restart_step : -1);
      });
      current = &sim;
      current_series = &series;
      current_fabric = &*fabric;
      current_case = std::int32_t(i);
      ckpt.rebase(sim.step_count());
      TriaxialRun run(scene, sim, d_mean, density, series.stream(), log, &prep);
      run.on_step(hook);
      run.set_fabric_output(fabric->streams());
      run.on_row(row_check);
      run.set_output(output, tc.name);
      if (log) *log << fmt::format("case {}: mu_s = {}, mu_r = {}{}\n", tc.name, scene.law.friction,
                                   tc.rolling_friction,
                                   resuming ? fmt::format(" (resumed at step {})", sim.step_count()) : "");
      StageResult e, sh;
      e_res = StageResult{};
      try {
        if (resuming && at.stage == kShear) {
          e = e_res = e_saved;
          sh = run.resume(at);
        } else {
          e = e_res = resuming ? run.resume(at) : run.equilibrate(tc.rolling_friction);
          sh = run.shear();
        }
      } catch (const BlowUpError& err) {  // every rank is here (the diagnosis is collective)
        blowup(err);
      }
      const double secs = std::chrono::duration<double>(clock::now() - t1).count();
      const real_t p_end = sh.state.p;
      const real_t inertial = tx.axial_strain_rate * d_mean * std::sqrt(density / std::max(p_end, 1.0));
      const real_t qp_end = p_end > 0 ? sh.state.q / p_end : 0;
      if (log)
        *log << fmt::format("case {}: equilibrated in {} steps; sheared to eps1 = {:.3f} in {} steps "
                            "({:.1f} s): peak q/p {:.4f} at eps1 = {:.4f}, end q/p {:.4f}, eps_v {:.4f}, "
                            "lateral stress error <= {:.2f} %, energy balance error <= {:.3f} %, "
                            "inertial number {:.2e}\n",
                            tc.name, e.steps, sh.strain[0], sh.steps, secs, sh.peak_q_p, sh.peak_eps1,
                            qp_end, sh.strain.sum(), 100 * sh.max_lateral_error,
                            100 * std::max(e.max_energy_error, sh.max_energy_error), inertial);
      if (log && scene.fabric.enabled)
        *log << fmt::format("case {}: fabric analysis {:.2f} s ({:.2f} % of the case's {:.1f} s)\n",
                            tc.name, run.fabric_seconds(), 100 * run.fabric_seconds() / secs, secs);
      const std::string row =
          fmt::format("{},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.3e},{:.1f}\n",
                      tc.name, tc.rolling_friction, c.state.void_ratio, sh.peak_q_p, sh.peak_eps1,
                      sh.strain.sum(), qp_end, sh.max_lateral_error,
                      std::max(e.max_energy_error, sh.max_energy_error), inertial, secs);
      summary_rows += row;
      series.close();
      agree(mpi.comm(), [&] { fabric->close(); });
      write_summary();
      current = prepared.get();  // the case's simulation and series end here
      current_series = nullptr;
      current_fabric = nullptr;
    }
  } catch (const BlowUpError& err) {  // in the consolidation: every rank is here
    blowup(err);
  }
  if (log) *log << fmt::format("series and summary written to {}\n", outdir);
  return 0;
}

}  // namespace fabrica
