#include "apps/triaxial.hpp"

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

void write_series_header(std::ostream& out) {
  out << "stage,step,time,eps1,eps2,eps3,epsv,s11,s22,s33,s12,s23,s13,p,q,q_p,void_ratio,Z,Z_m,"
         "sliding_fraction,rolling_fraction,inertial_number,unbalanced,kinetic,e_normal,e_shear,"
         "e_rolling,diss_friction,diss_rolling,diss_viscous,diss_local,boundary_work,"
         "energy_error,mean_overlap_d,max_overlap_r\n";
}

TriaxialRun::TriaxialRun(const Scene& scene, Simulation& sim, real_t mean_diameter,
                         real_t density, std::ostream* series, std::ostream* log,
                         const TriaxialRun* parent)
    : scene_(scene), tx_(scene.triaxial), sim_(sim), d_mean_(mean_diameter), density_(density),
      series_(series), log_(log), l0_(sim.cell().lengths()) {
  if (parent) {  // a branch of the parent's simulation: the account continues
    in_pos_ = parent->in_pos_;
    input_seen_ = parent->input_seen_;
    l0_ = parent->l0_;
  } else {
    input_seen_ = sim_.macro().energy_input - sim_.energy_account().e0;
  }
}

void TriaxialRun::track_input(const MacroState& m) {
  const real_t input = m.energy_input - sim_.energy_account().e0;  // boundary + gravity work
  in_pos_ += std::max<real_t>(0, input - input_seen_);
  input_seen_ = input;
}

real_t TriaxialRun::energy_error(const MacroState& m) const {
  const real_t in = energy_in();
  return in > 0 ? (m.energy_input - energy_books(m)) / in : 0.0;
}

void TriaxialRun::row(Stage stage, const MacroState& m, const Vec3& eps) {
  if (!series_ && !output_) return;
  static const char* names[] = {"consolidation", "equilibration", "shear"};
  const real_t nc = std::max<real_t>(1.0, real_t(m.contacts));
  const real_t inertial =
      m.p > 0 ? std::abs(sim_.cell().strain_rate()[0]) * d_mean_ * std::sqrt(density_ / m.p) : 0;
  const Dissipation& d = m.dissipated;
  const real_t values[] = {sim_.time(), eps[0], eps[1], eps[2], eps.sum(),
                           m.stress(0, 0), m.stress(1, 1), m.stress(2, 2), m.stress(0, 1),
                           m.stress(1, 2), m.stress(0, 2), m.p, m.q, m.p > 0 ? m.q / m.p : 0.0,
                           m.void_ratio, m.coordination, m.mech_coordination,
                           real_t(m.sliding) / nc, real_t(m.rolling) / nc, inertial, m.unbalanced,
                           m.kinetic, m.e_normal, m.e_shear, m.e_rolling, d.friction, d.rolling,
                           d.viscous, d.local, sim_.boundary_work(), energy_error(m), m.mean_overlap / d_mean_,
                           m.max_overlap_ratio};
  if (output_) {
    static const std::string header = [] {
      std::ostringstream h;
      write_series_header(h);
      return h.str();
    }();
    output_->series_row(case_, header, names[int(stage)], sim_.step_count(), values);
  }
  if (!series_) return;
  *series_ << names[int(stage)] << ',' << sim_.step_count();
  for (real_t v : values) *series_ << fmt::format(",{:.10g}", v);
  *series_ << '\n';
}

void TriaxialRun::fabric_row(Stage stage, const Vec3& eps) {
  if (!scene_.fabric.enabled) return;
  const auto t0 = std::chrono::steady_clock::now();
  const auto records = contact_records(sim_.particles(), sim_.cell(), sim_.params().law, sim_.pairs());
  const FabricOptions opt{scene_.fabric.strong_ratio, int(scene_.fabric.rose_bins)};
  const FabricResult r = analyse_fabric(records, sim_.cell().volume(), opt, sim_.domain());
  if (fabric_out_) write_fabric_rows(*fabric_out_, kStageNames[int(stage)], sim_.step_count(), eps[0], r);
  fabric_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

StageResult TriaxialRun::run_stage(Stage stage, const StageCursor* resume) {
  using clock = std::chrono::steady_clock;
  static const char* names[] = {"consolidation", "equilibration", "shear"};
  const real_t target = tx_.confining_pressure;
  Servo servo = stage == Stage::Shear
                    ? make_servo({false, true, true}, Vec3(-tx_.axial_strain_rate, 0, 0))
                    : make_servo({true, true, true}, Vec3::Zero());
  auto done = [&](const MacroState& m, const Vec3& eps) {
    if (stage == Stage::Shear) return eps[0] >= tx_.axial_strain;
    for (int k = 0; k < 3; ++k)
      if (std::abs(m.stress(k, k) - target) > tx_.stress_tolerance * target) return false;
    return m.unbalanced < tx_.unbalanced_tolerance;
  };
  auto strain = [&] {
    Vec3 e;
    for (int k = 0; k < 3; ++k) e[k] = std::log(l0_[k] / sim_.cell().lengths()[k]);
    return e;
  };
  StageResult res;
  bool servo_warned = false;
  real_t last_servo = sim_.time();
  std::int64_t k = 1;
  if (resume) {  // the rates are the checkpoint's
    res = resume->result;
    servo.set_integral(resume->servo_integral);
    last_servo = resume->last_servo;
    k = resume->k + 1;
  } else {
    sim_.cell().set_strain_rate(update_servo(servo, stage, sim_.macro(), 0.0));
  }
  const std::int64_t k0 = k - 1;
  const auto t0 = clock::now();
  auto last_print = t0;
  for (;; ++k) {
    if (k > tx_.max_stage_steps)
      throw CollectiveError(fmt::format(
          "{}: [triaxial] max_stage_steps = {}: the {} stage did not converge (last p = {:.6g} Pa, "
          "target {:.6g} Pa, s11 {:.6g}, s22 {:.6g}, s33 {:.6g} Pa, unbalanced-force ratio {:.3g}; "
          "servo {}); raise max_stage_steps or the damping",
          scene_.path, tx_.max_stage_steps, names[int(stage)], res.state.p, target,
          res.state.stress(0, 0), res.state.stress(1, 1), res.state.stress(2, 2),
          res.state.unbalanced, servo.describe()));
    const bool out = k % scene_.output_every == 0;
    const bool measure = out || k % tx_.servo_interval == 0;
    sim_.step(measure);  // the boundary work is the simulation's (Simulation::boundary_work)
    if (!sim_.step_guard().empty()) throw BlowUpError(sim_.step_guard());  // every step
    if (output_ && output_->snapshot_due(sim_.step_count())) output_->snapshot(case_, sim_, strain());
    if (measure) {
      const MacroState& m = sim_.macro();
      track_input(m);
      res.state = m;
      const std::string bad = diagnose(m, sim_.step_count(), scene_.max_overlap, scene_.kinetic_runaway);
      if (!bad.empty()) throw BlowUpError(bad);
      const Vec3 eps = strain();
      res.max_energy_error = std::max(res.max_energy_error, std::abs(energy_error(m)));
      const bool finished = done(m, eps);
      // Over every row of the series: the output instants and the stage's last row (a stage
      // shorter than output_every has only that one).
      if (stage == Stage::Shear && (out || finished)) {
        const real_t qp = m.p > 0 ? m.q / m.p : 0;
        if (qp > res.peak_q_p) res.peak_q_p = qp, res.peak_eps1 = eps[0];
        for (int a = 1; a < 3; ++a)
          res.max_lateral_error =
              std::max(res.max_lateral_error, std::abs(m.stress(a, a) - target) / target);
      }
      if (out) row(stage, m, eps);
      if (out && stage == Stage::Shear) fabric_row(stage, eps);
      if (out && row_check_) row_check_();
      const Vec3 rates = update_servo(servo, stage, m, sim_.time() - last_servo);
      sim_.cell().set_strain_rate(rates);
      last_servo = sim_.time();
      // A servo that cannot follow the loading: a lateral axis at the rate cap while its stress
      // is far from the target (10 x the stage's tolerance). Said once per stage.
      if (stage == Stage::Shear && !servo_warned && log_)
        for (int a = 1; a < 3; ++a)
          if (std::abs(rates[a]) >= tx_.max_strain_rate &&
              std::abs(m.stress(a, a) - target) > 10 * tx_.stress_tolerance * target) {
            servo_warned = true;
            *log_ << fmt::format("  warning: step {}: the servo is at its rate cap ([triaxial] "
                                 "max_strain_rate = {} 1/s) on axis {} and s{}{} = {:.4g} Pa is {:.1f} % "
                                 "from the target {:.4g} Pa: it cannot follow the axial loading "
                                 "({} 1/s); raise max_strain_rate or lower axial_strain_rate\n",
                                 sim_.step_count(), tx_.max_strain_rate, a + 1, a + 1, a + 1,
                                 m.stress(a, a), 100 * std::abs(m.stress(a, a) - target) / target,
                                 target, tx_.axial_strain_rate);
            log_->flush();
            break;
          }
      const auto now = clock::now();
      if (log_ && std::chrono::duration<double>(now - last_print).count() > tx_.progress_seconds) {
        last_print = now;
        const double secs = std::chrono::duration<double>(now - t0).count();
        std::string eta;
        if (stage == Stage::Shear && eps[0] > 0)
          eta = fmt::format(", {:.0f} s left", secs * (tx_.axial_strain - eps[0]) / eps[0]);
        *log_ << fmt::format("  [{}] step {}: eps1 {:.4f}, p {:.1f} kPa, q/p {:.4f}, e {:.4f}, "
                             "unbalanced {:.2e}, {:.0f} steps/s{}\n",
                             names[int(stage)], sim_.step_count(), eps[0], m.p / 1e3,
                             m.p > 0 ? m.q / m.p : 0, m.void_ratio, m.unbalanced,
                             double(k - k0) / secs, eta);
        log_->flush();
      }
      if (finished) {
        res.steps = k;
        res.strain = eps;
        if (!out) row(stage, m, eps);
        if ((!out && stage == Stage::Shear) || stage == Stage::Consolidation) fabric_row(stage, eps);
        if (row_check_) row_check_();
        if (output_) output_->snapshot(case_, sim_, eps);  // always one at the end of a stage
        return res;
      }
    }
    if (hook_)
      hook_(StageCursor{stage, k, servo.integral(), last_servo, res, l0_, in_pos_, input_seen_});
  }
}

Servo TriaxialRun::make_servo(std::array<bool, 3> axes, Vec3 fixed) const {
  return Servo(tx_, real_t(tx_.servo_interval) * sim_.params().dt, axes, fixed);
}

Vec3 TriaxialRun::update_servo(Servo& servo, Stage stage, const MacroState& m, real_t elapsed) {
  // Collective when needed: every rank takes the same decision from the reduced stress.
  const Mat3 M = servo.needs_stiffness(m.stress) ? specimen_stiffness(sim_) : Mat3::Zero();
  try {
    return servo.update(m.stress, elapsed, M);
  } catch (const ServoDivergence& e) {  // the same on every rank (reduced values only)
    throw CollectiveError(fmt::format("{}: [triaxial] the {} stage stopped at step {}: {} (p = "
                                      "{:.6g} Pa, target {:.6g} Pa; servo {})",
                                      scene_.path, kStageNames[int(stage)], sim_.step_count(),
                                      e.what(), m.p, tx_.confining_pressure, servo.describe()));
  }
}

StageResult TriaxialRun::consolidate() {
  ContactLawParams law = sim_.params().law;
  law.friction = tx_.consolidation_friction;
  law.rolling_friction = 0;
  sim_.set_law(law);
  sim_.set_local_damping(tx_.preparation_damping);
  return run_stage(Stage::Consolidation);
}

StageResult TriaxialRun::equilibrate(real_t rolling_friction) {
  ContactLawParams law = scene_.law;
  law.rolling_friction = rolling_friction;
  sim_.set_law(law);
  sim_.set_local_damping(tx_.preparation_damping);
  return run_stage(Stage::Equilibration);
}

StageResult TriaxialRun::shear() {
  sim_.set_local_damping(tx_.shear_damping);
  l0_ = sim_.cell().lengths();  // strains of the shear stage are measured from here
  return run_stage(Stage::Shear);
}

StageCursor TriaxialRun::account() const {
  StageCursor a;
  a.l0 = l0_;
  a.input_positive = in_pos_;
  a.input_seen = input_seen_;
  return a;
}

void TriaxialRun::set_account(const StageCursor& a) {
  l0_ = a.l0;
  in_pos_ = a.input_positive;
  input_seen_ = a.input_seen;
}

StageResult TriaxialRun::resume(const StageCursor& at) {
  set_account(at);  // the contact law and damping are the simulation's, restored with it
  return run_stage(at.stage, &at);
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
    BytesIn in(restart->section("app"), restart->path() + ": section app");
    current_case = in.get<std::int32_t>();
    at = in.get<StageCursor>();
    prep_account = in.get<StageCursor>();
    c = in.get<StageResult>();
    e_saved = in.get<StageResult>();
    t_cons = in.get<double>();
    summary_rows = in.get_string();
    if (!in.done() || current_case < -1 || current_case >= std::int32_t(cases.size()))
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
  // A series file; on a restart in its stage, its rows after the checkpoint's step are dropped.
  // Rank 0 writes the CSV files; every write is checked (io/write_check.hpp) and the ranks agree
  // on the outcome (parallel/guard.hpp), so that a failed write ends every rank.
  auto open_series = [&](const fs::path& p, std::ofstream& f, bool resuming) {
    agree(mpi.comm(), [&] {
      if (!root) return;
      make_output_directory(p.parent_path().string());
      if (resuming && keep_series_through(p.string(), 1, restart_step)) {
        open_checked(f, p.string(), std::ios::app);
      } else {
        open_checked(f, p.string());
        write_series_header(f);
      }
      check_stream(f, p.string());
    });
  };
  std::ofstream cons_series;
  const std::string cons_series_path = (out / "consolidation.csv").string();
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes a checkpoint
    if (root) make_output_directory(out.string());
  });
  if (start_case < 0) open_series(cons_series_path, cons_series, restart != nullptr);
  std::optional<FabricFiles> cons_fabric;
  if (start_case < 0)
    agree(mpi.comm(), [&] {
      cons_fabric.emplace(root && scene.fabric.enabled, out, "consolidation_",
                          int(scene.fabric.rose_bins), restart ? restart_step : -1);
    });

  // Checkpoints: the current simulation, the consolidated one (inside a case) and the state of
  // the protocol, at rebuild steps (TriaxialRun::on_step).
  Simulation* current = prepared.get();
  std::ofstream* current_series = &cons_series;
  std::string current_series_path = cons_series_path;
  FabricFiles* current_fabric = cons_fabric ? &*cons_fabric : nullptr;
  // After every series row, on every rank: the rows so far are written (rank 0's check, agreed).
  auto row_check = [&] {
    agree(mpi.comm(), [&] {
      if (!root) return;
      if (current_series) check_stream(*current_series, current_series_path);
      if (current_fabric) current_fabric->check();
    });
  };
  StageCursor prep_acc;
  StageResult e_res;
  CheckpointSchedule schedule(mpi.comm(), scene.checkpoint_every, scene.checkpoint_seconds,
                              prepared->step_count());
  auto save = [&](const StageCursor& cur, bool blowup) {
    agree(mpi.comm(), [&] {  // on disk: a checkpoint never refers to rows that are not
      if (root && current_series) sync_stream(*current_series, current_series_path);
      if (root && current_fabric) current_fabric->flush();
    });
    // run.h5 on disk up to here: a checkpoint never refers to output that is not (collective).
    if (output) output->flush();
    const auto t = clock::now();
    CheckpointWriter w(mpi.comm(), scene_fingerprint(scene.text), "triaxial", blowup);
    w.add_simulation("sim", *current);
    if (current_case >= 0) w.add_simulation("prep", *prepared);
    w.add_global("app", Bytes().put(current_case).put(cur).put(prep_acc).put(c).put(e_res)
                            .put(t_cons).put_string(summary_rows).str());
    const std::string path = (out / (blowup ? "blowup.ckpt" : "checkpoint.ckpt")).string();
    const std::uint64_t bytes = w.write(path);
    schedule.taken(current->step_count());
    const double secs = std::chrono::duration<double>(clock::now() - t).count();
    if (log && blowup)
      *log << fmt::format("  state at the blow-up, step {}: {} ({:.1f} MB in {:.2f} s)\n",
                          current->step_count(), path, double(bytes) / 1e6, secs);
    else if (log)
      *log << fmt::format("  checkpoint at step {} ({}, {}): {} ({:.1f} MB in {:.2f} s)\n",
                          current->step_count(),
                          current_case < 0 ? std::string("consolidation") : cases[current_case].name,
                          kStageNames[int(cur.stage)], path, double(bytes) / 1e6, secs)
           << std::flush;
    return path;
  };
  // A blow-up: the state at detection goes to OUT/blowup.ckpt. Called where the simulation that
  // blew up is still alive (inside a case, its simulation and streams are the case's locals).
  auto blowup = [&](const BlowUpError& err) {
    const std::string path = save(StageCursor{}, true);
    throw CollectiveError(std::string(err.what()) + "; the state at detection is saved in " +
                          path + " (for post-mortem: a run cannot restart from it)");
  };
  auto hook = [&](const StageCursor& cur) {
    if (schedule.due(*current)) save(cur, false);
  };
  try {
    TriaxialRun prep(scene, *prepared, d_mean, density, root ? &cons_series : nullptr, log);
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
      agree(mpi.comm(), [&] {  // complete on disk before any checkpoint of a case
        if (root) close_checked(cons_series, cons_series_path);
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
      std::ofstream series;
      const std::string series_path = (out / tc.name / "series.csv").string();
      open_series(series_path, series, resuming);
      std::optional<FabricFiles> fabric;
      agree(mpi.comm(), [&] {
        fabric.emplace(root && scene.fabric.enabled, out / tc.name, "", int(scene.fabric.rose_bins),
                       resuming ? restart_step : -1);
      });
      current = &sim;
      current_series = &series;
      current_series_path = series_path;
      current_fabric = &*fabric;
      current_case = std::int32_t(i);
      schedule.rebase(sim.step_count());
      TriaxialRun run(scene, sim, d_mean, density, root ? &series : nullptr, log, &prep);
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
        if (resuming && at.stage == TriaxialStage::Shear) {
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
      agree(mpi.comm(), [&] {
        if (root) close_checked(series, series_path);
        fabric->close();
      });
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
