#include "apps/plain_run.hpp"

#include "apps/app_checkpoint.hpp"
#include "apps/series_file.hpp"
#include "apps/stage_run.hpp"
#include "apps/triaxial.hpp"
#include "core/simulation.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "io/mpi/run_output.hpp"
#include "io/serial/setup.hpp"
#include "io/serial/write_check.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"

#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <stdexcept>

namespace fabrica {

namespace {

const char* const kCase = "run";  // the case of run.h5
const char* const kCompress = "[compress]";

void print_header() {
  fmt::print("{:>9} {:>11} {:>11} {:>11} {:>7} {:>7} {:>9} {:>11} {:>11}\n", "step", "time_s", "p_Pa", "q_Pa", "Z",
             "Z_m", "contacts", "Ekin_J", "unbal");
}

constexpr const char* kSeriesHeader =
    "step,time,s11,s22,s33,s12,s23,s13,p,q,Z,contacts,sliding,rolling,kinetic,e_normal,"
    "e_shear,e_rolling,diss_friction,diss_rolling,diss_viscous,diss_local,void_ratio\n";

// With walls ([[wall]]) or driven particles ([[driven]]), the series has more columns: the wall
// contacts (counted apart from the particle contacts), the energy input, the walls' and the
// drive's work, and each wall's force and position (the coordinate of its plane along its axis:
// a moving or servo wall's travel).
// With [fields] keeping the strain increment, the column localisation ends the row (the field
// instant's localisation index, NaN at other rows).
std::string series_header(std::size_t walls, bool driven, bool localisation) {
  if (walls == 0 && !driven && !localisation) return kSeriesHeader;
  std::string h(kSeriesHeader);
  h.pop_back();
  if (walls > 0 || driven) h += ",wall_contacts,energy_input,wall_work,drive_work";
  for (std::size_t w = 1; w <= walls; ++w) h += fmt::format(",wall{0}_fx,wall{0}_fy,wall{0}_fz,wall{0}_position", w);
  if (localisation) h += ",localisation";
  return h + "\n";
}
std::vector<double> wall_columns(const Simulation& sim, const MacroState& m) {
  std::vector<double> v;
  if (sim.params().walls.empty() && sim.params().driven.empty()) return v;
  v = {double(m.wall_contacts), m.energy_input, m.wall_work, m.drive_work};
  const std::vector<Wall>& walls = sim.params().walls;
  for (std::size_t k = 0; k < walls.size(); ++k) {  // the plane's coordinate along its axis
    const Vec3 f = k < m.wall_force.size() ? m.wall_force[k] : Vec3::Zero();
    v.insert(v.end(), {f[0], f[1], f[2], walls[k].point.dot(walls[k].normal.cwiseAbs())});
  }
  return v;
}

// 'localisation': the row's value of that column (std::nullopt: the run has none).
void print_row(const Simulation& sim, const MacroState& m, std::ostream* csv, RunOutput* out,
               std::optional<double> localisation) {
  const std::vector<double> walls = wall_columns(sim, m);
  if (out) {
    std::vector<double> v = {sim.time(),
                             m.stress(0, 0),
                             m.stress(1, 1),
                             m.stress(2, 2),
                             m.stress(0, 1),
                             m.stress(1, 2),
                             m.stress(0, 2),
                             m.p,
                             m.q,
                             m.coordination,
                             double(m.contacts),
                             double(m.sliding),
                             double(m.rolling),
                             m.kinetic,
                             m.e_normal,
                             m.e_shear,
                             m.e_rolling,
                             m.dissipated.friction,
                             m.dissipated.rolling,
                             m.dissipated.viscous,
                             m.dissipated.local,
                             m.void_ratio};
    v.insert(v.end(), walls.begin(), walls.end());
    if (localisation) v.push_back(*localisation);
    out->series_row(kCase,
                    series_header(sim.params().walls.size(), !sim.params().driven.empty(), localisation.has_value()),
                    "", sim.step_count(), v);
  }
  fmt::print("{:>9} {:>11.5e} {:>11.5e} {:>11.5e} {:>7.3f} {:>7.3f} {:>9} {:>11.4e} {:>11.4e}\n", sim.step_count(),
             sim.time(), m.p, m.q, m.coordination, m.mech_coordination, m.contacts, m.kinetic, m.unbalanced);
  if (csv) {
    *csv << fmt::format(
        "{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},"
        "{:.10e},{},{},{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},"
        "{:.10e},{:.10e}",
        sim.step_count(), sim.time(), m.stress(0, 0), m.stress(1, 1), m.stress(2, 2), m.stress(0, 1), m.stress(1, 2),
        m.stress(0, 2), m.p, m.q, m.coordination, m.contacts, m.sliding, m.rolling, m.kinetic, m.e_normal, m.e_shear,
        m.e_rolling, m.dissipated.friction, m.dissipated.rolling, m.dissipated.viscous, m.dissipated.local,
        m.void_ratio);
    for (std::size_t k = 0; k < walls.size(); ++k)
      *csv << (k == 0 ? fmt::format(",{}", std::int64_t(walls[k])) : fmt::format(",{:.10e}", walls[k]));
    if (localisation) *csv << fmt::format(",{:.10e}", *localisation);
    *csv << "\n";
  }
}

Vec3 log_strain(const Vec3& l0, const Vec3& l) {
  return Vec3(std::log(l0[0] / l[0]), std::log(l0[1] / l[1]), std::log(l0[2] / l[2]));
}

bool compressing(const StageSpec& st) { return st.where == kCompress; }

// The stage loop with the plain run's measurements and rows: the compression measured every 10
// steps from its first (its end, p reaching the target, is seen there) with a line on the
// standard output every 2000; the [run] steps measured at their rows, every output_every steps
// and at the last, each a line of OUT/series.csv, of run.h5 and of the standard output.
class PlainRun : public StageRun {
 public:
  PlainRun(const Scene& scene, Simulation& sim, const SpecimenTotals& tot, SeriesFile& csv, RunOutput* out)
      : StageRun(scene, sim, tot.diameter_sum / real_t(tot.count), tot.mass / tot.volume, nullptr, nullptr), csv_(csv),
        out_(out) {
    set_output(out, kCase);
  }

 protected:
  bool row_due(const StageSpec& st, std::int64_t k) const override {
    return compressing(st) ? (k - 1) % 2000 == 0 : k % scene_.output_every == 0;
  }
  bool measures(const StageSpec& st, std::int64_t k, bool at_row) const override {
    return compressing(st) ? (k - 1) % 10 == 0 : at_row || k == *st.end.steps;
  }
  void rows(const StageSpec& st, std::int64_t k, const MacroState& m, const Vec3&, const Vec3&) override {
    if (compressing(st)) {  // the standard output only
      print_row(sim_, m, nullptr, nullptr, std::nullopt);
      return;
    }
    // [fields] every 'every' rows, before the row: it carries the instant's localisation index.
    series_row(m, out_ && out_->fields_due(k) ? out_->fields(kCase, sim_) : kNoLocalisation);
  }
  void end_rows(const StageSpec& st, std::int64_t, const MacroState& m, const Vec3&, const Vec3&,
                bool at_row) override {
    if (!compressing(st) && !at_row) series_row(m, kNoLocalisation);
  }
  [[noreturn]] void unended(const StageSpec& st, const StageResult& res, const StageControl& c) const override {
    if (!compressing(st)) StageRun::unended(st, res, c);
    throw std::runtime_error(fmt::format("{}: [compress] max_steps = {} reached before p = {} Pa", scene_.path,
                                         st.max_steps, *st.end.pressure));
  }

 private:
  void series_row(const MacroState& m, double localisation) {
    print_row(sim_, m, csv_.stream(), out_,
              scene_.fields.localisation() ? std::optional<double>(localisation) : std::nullopt);
    csv_.check();
  }
  SeriesFile& csv_;
  RunOutput* out_;
};

// Where a plain run is, in its checkpoints' fields (those of the builds before the stage loop, so
// that either restarts the other): 'phase' 0 in the compression, 1 in the [run] steps, and 'k'
// the stage's steps done, less one in the compression (whose loop counted from 0).
FieldWriter plain_fields(const StageSpec& st, std::int64_t k) {
  FieldWriter w;
  w.i32("phase", compressing(st) ? 0 : 1).i64("k", compressing(st) ? k - 1 : k);
  return w;
}

// The stage of 'stages' and its steps done that a checkpoint's fields name.
StageCursor read_plain_cursor(const Checkpoint& ckpt, const std::vector<StageSpec>& stages) {
  FieldReader in = ckpt.fields("app");
  const std::int32_t phase = in.i32("phase");
  const std::int64_t k = in.i64("k");
  in.done();
  StageCursor at;
  for (at.stage = 0; at.stage < std::int32_t(stages.size()); ++at.stage)
    if (compressing(stages[at.stage]) == (phase == 0)) break;
  if ((phase != 0 && phase != 1) || at.stage == std::int32_t(stages.size()))
    throw InputError(ckpt.path() + ": section app: phase " + std::to_string(phase) +
                     ": not a state of this scene's run");
  at.k = phase == 0 ? k + 1 : k;
  return at;
}

void print_scene(const MpiContext& mpi, const Scene& scene, const Setup& s, std::int64_t count) {
  fmt::print("scene {}: {} spheres, cell {:.4f} x {:.4f} x {:.4f} m\n", scene.path, count, s.cell.lengths()[0],
             s.cell.lengths()[1], s.cell.lengths()[2]);
  fmt::print("critical time step {:.4e} s, time step {:.4e} s (fraction {:.3f})\n", s.critical_dt, s.params.dt,
             s.params.dt / s.critical_dt);
  fmt::print("{} MPI rank(s){}\n", mpi.size(),
             mpi.size() > 1 ? ", " + scene.parallel.decomposition + " decomposition" : "");
}

}  // namespace

StageSpec compress_stage(const Scene& scene) {
  const CompressSpec& cp = scene.compress;
  StageSpec st;
  st.name = "compress";
  st.where = kCompress;
  st.mode = {AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};
  st.rate = Vec3::Constant(cp.strain_rate);
  st.law.set(&ContactLawParams::friction, cp.friction);  // every material's and pair's alike
  st.law.set(&ContactLawParams::rolling_friction, 0);
  st.law.set(&ContactLawParams::twisting_friction, 0);
  st.end.pressure = cp.target_pressure;
  st.servo.mode = ServoMode::Gains;  // no stress axis: the servo asks nothing of the specimen
  st.max_steps = cp.max_steps;
  return st;
}

StageSpec steps_stage(const Scene& scene) {
  StageSpec st;
  st.name = "run";
  st.where = "[run]";
  st.mode = {AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};  // at rest
  st.own_law = scene.compress.enabled;  // the scene's law back after the compression
  st.end.steps = scene.steps;
  st.servo.mode = ServoMode::Gains;
  st.max_steps = scene.steps;
  return st;
}

std::vector<StageSpec> plain_stages(const Scene& scene) {
  std::vector<StageSpec> stages;
  if (scene.compress.enabled) stages.push_back(compress_stage(scene));
  if (scene.steps > 0) stages.push_back(steps_stage(scene));
  return stages;
}

int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* out,
              const Checkpoint* ckpt, Setup* setup) {
  namespace fs = std::filesystem;
  const bool root = mpi.rank() == 0;
  const std::vector<StageSpec> stages = plain_stages(scene);
  StageCursor at;
  if (ckpt) at = read_plain_cursor(*ckpt, stages);
  std::optional<SimulationSnapshot> saved;  // decoded (and checked) before any file is touched
  if (ckpt) saved = ckpt->simulation("sim", mpi.comm());
  // run.h5: the rows and snapshots after the checkpoint's step go (collective).
  if (out && ckpt) out->resume_after(ckpt->header().step, {kCase}, 0);
  Setup s = setup ? std::move(*setup) : make_run_setup(scene, mpi.comm(), domain_options(scene));
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  const SpecimenTotals tot = specimen_totals(s.particles, mpi.comm());
  print_scene(mpi, scene, s, tot.count);
  const fs::path series_path = fs::path(outdir) / "series.csv";
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes to it
    if (root) make_output_directory(outdir);
  });
  SeriesFile csv(mpi.comm(), series_path.string(),
                 series_header(scene.walls.size(), !scene.driven.empty(), scene.fields.localisation()), 0,
                 ckpt ? ckpt->header().step : -1);
  const auto t0 = std::chrono::steady_clock::now();
  if (scene.compress.enabled) {  // the simulation starts in the compression's law (its initial forces)
    s.params.law = stage_law(scene.law, stages.front());
    s.params.materials.apply(stages.front().law);
  }
  const Vec3 l0 = s.cell.lengths();  // the strain reference of the snapshots (also on a restart)
  std::unique_ptr<Simulation> simp = ckpt
      ? std::make_unique<Simulation>(std::move(*saved), domain.get())
      : std::make_unique<Simulation>(std::move(s.particles), s.cell, s.params, domain.get(), s.holding);
  Simulation& sim = *simp;
  const std::int64_t first_step = sim.step_count();
  if (ckpt)
    fmt::print("-- restarted from {} at step {} (written on {} rank(s))\n", ckpt->path(), sim.step_count(),
               ckpt->header().ranks);
  AppCheckpoint checkpoints(
      mpi.comm(), scene, outdir, "run", sim.step_count(),
      [&] {
        csv.sync();             // on disk: a checkpoint never refers to rows that are not
        if (out) out->flush();  // nor to output that is not (collective)
      },
      out ? &out->field_history() : nullptr, root ? &std::cout : nullptr, "-- ");
  const AppCheckpoint::Sims sims{{"sim", &sim}};
  PlainRun run(scene, sim, tot, csv, out);
  StageCursor account = run.account();
  account.l0 = l0;
  run.set_account(account);
  run.on_step([&](const StageCursor& c) {
    if (checkpoints.due(sim)) checkpoints.save(sims, plain_fields(stages[c.stage], c.k));
  });
  try {
    print_header();
    for (std::int32_t i = ckpt ? at.stage : 0; i < std::int32_t(stages.size()); ++i) {
      const StageSpec& st = stages[i];
      if (compressing(st))
        fmt::print("-- compression at {} 1/s to p = {} Pa\n", scene.compress.strain_rate,
                   scene.compress.target_pressure);
      if (ckpt && i == at.stage) {  // its strain reference: that of the end conditions of neither stage
        at.stage_l0 = sim.cell().lengths();
        at.last_servo = sim.time();
        run.run(st, i, &at);
      } else {
        run.run(st, i);
      }
      if (!compressing(st)) continue;
      const MacroState& m = sim.macro();
      fmt::print("-- compressed: void ratio {:.4f}, solid fraction {:.4f}; now mu_s = {}, mu_r = {}\n", m.void_ratio,
                 1.0 / (1.0 + m.void_ratio), scene.law.friction, scene.law.rolling_friction);
    }
    if (out) out->snapshot(kCase, sim, log_strain(l0, sim.cell().lengths()));  // none twice at a step
  } catch (const BlowUpError& e) {  // every rank is here (the diagnosis is collective)
    FieldWriter app;                // a post-mortem state, no place to continue from: the start's fields
    app.i32("phase", 0).i64("k", 0);
    checkpoints.blowup(e, sims, app);
  }
  std::fflush(stdout);
  csv.close();
  const std::int64_t steps_done = sim.step_count() - first_step;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double n_total = double(sim.macro().particles);
  fmt::print("{} steps in {:.2f} s: {:.4f} us per particle-step on {} rank(s), {} neighbour rebuilds\n", steps_done,
             secs, secs * 1e6 / (double(steps_done) * n_total), mpi.size(), sim.rebuild_count());
  fmt::print("series written to {}\n", series_path.string());
  return 0;
}

}  // namespace fabrica
