#include "apps/stage_driver.hpp"

#include "apps/app_checkpoint.hpp"
#include "apps/series_file.hpp"
#include "apps/stage_cursor.hpp"
#include "apps/stage_run.hpp"
#include "apps/triaxial.hpp"
#include "core/principal.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "io/mpi/run_output.hpp"
#include "io/serial/setup.hpp"
#include "io/serial/write_check.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"

#include <fmt/core.h>

#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

namespace fabrica {

namespace {

const char* const kCase = "stages";  // the case of run.h5
const char* const kSummaryHeader =
    "stage,name,steps,end_step,p,q,q_p,eps1,eps2,eps3,epsv,void_ratio,Z,peak_q_p,"
    "max_stress_error,max_energy_error\n";
// A run that shears the cell: the shear stresses and strains, the principal stresses and the
// major direction's angle follow (docs/output.md).
const char* const kSummaryShear = ",s12,s13,s23,gamma_12,gamma_13,gamma_23,sigma_1,sigma_2,sigma_3,theta_12";

std::string summary_header(bool shear) {
  std::string h = kSummaryHeader;
  if (shear) h.insert(h.size() - 1, kSummaryShear);
  return h;
}

std::string series_header(bool shear, bool localisation) {
  std::ostringstream h;
  write_series_header(h, shear, localisation);
  return h.str();
}

FieldWriter app_fields(const StageCursor& at, const std::string& summary) {
  FieldWriter w;
  write_cursor(w, at);
  w.text("summary_rows", summary);
  return w;
}

std::string summary_row(int index, const StageSpec& st, const StageResult& r, std::int64_t step, bool shear) {
  const MacroState& m = r.state;
  std::string row = fmt::format(
      "{},{},{},{},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},"
      "{:.10g},{:.10g},{:.10g},{:.10g}",
      index + 1, st.name, r.steps, step, m.p, m.q, m.p > 0 ? m.q / m.p : 0.0, r.strain[0], r.strain[1], r.strain[2],
      r.strain.sum(), m.void_ratio, m.coordination, r.peak_q_p, r.max_lateral_error, r.max_energy_error);
  if (shear) {
    const Principal pr = principal(m.stress);
    for (real_t x : {m.stress(0, 1), m.stress(0, 2), m.stress(1, 2), r.gamma[0], r.gamma[1], r.gamma[2], pr.values[0],
                     pr.values[1], pr.values[2], pr.angle_12})
      row += fmt::format(",{:.10g}", x);
  }
  return row + '\n';
}

}  // namespace

int run_stages(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output,
               const Checkpoint* restart, Setup* setup) {
  namespace fs = std::filesystem;
  const bool root = mpi.rank() == 0;
  std::ostream* log = root ? &std::cout : nullptr;
  const std::int32_t n = std::int32_t(scene.stages.size());
  // On a restart: the stage and step the checkpoint was taken in, and the finished stages' rows.
  StageCursor at;
  std::string summary;
  if (restart) {
    FieldReader in = restart->fields("app");
    at = read_cursor(in);
    summary = in.text("summary_rows");
    in.done();
    if (at.stage < 0 || at.stage >= n)
      throw InputError(restart->path() + ": section app: stage " + std::to_string(at.stage + 1) + " of a list of " +
                       std::to_string(n) + ": not a state of this scene's stages");
  }
  std::optional<SimulationSnapshot> saved;  // decoded (and checked) before any file is touched
  if (restart) saved = restart->simulation("sim", mpi.comm());
  Setup s = setup ? std::move(*setup) : make_run_setup(scene, mpi.comm(), domain_options(scene));
  const SpecimenTotals tot = specimen_totals(s.particles, mpi.comm());
  const real_t d_mean = tot.diameter_sum / real_t(tot.count), density = tot.mass / tot.volume;
  if (log)
    *log << fmt::format(
        "stages: {} spheres, mean diameter {:.2f} mm, {} rank(s), time step {:.3e} s "
        "({:.3f} of the critical estimate), {} stage(s)\n",
        tot.count, d_mean * 1e3, mpi.size(), s.params.dt, s.params.dt / s.critical_dt, n);
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  s.params.law = scene.law;  // the set-up's is sized for the largest mu_r of the stages
  s.params.materials = scene_materials(scene);
  std::unique_ptr<Simulation> simp = restart
      ? std::make_unique<Simulation>(std::move(*saved), domain.get())
      : std::make_unique<Simulation>(std::move(s.particles), s.cell, s.params, domain.get(), s.holding);
  Simulation& sim = *simp;
  const std::int64_t resume_step = restart ? restart->header().step : -1;
  if (output && restart) output->resume_after(resume_step, {kCase}, 0);
  const fs::path out(outdir);
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes a checkpoint
    if (root) make_output_directory(out.string());
  });
  const bool shear = any_shears(scene.stages) || sim.cell().sheared();
  SeriesFile series(mpi.comm(), (out / "series.csv").string(), series_header(shear, scene.fields.localisation()), 1,
                    resume_step);
  std::optional<FabricFiles> fabric;
  agree(mpi.comm(), [&] {
    fabric.emplace(root && scene.fabric.enabled, out, "", int(scene.fabric.rose_bins), resume_step, shear);
  });
  AppCheckpoint ckpt(
      mpi.comm(), scene, outdir, "stages", sim.step_count(),
      [&] {
        series.sync();
        agree(mpi.comm(), [&] { fabric->flush(); });
        if (output) output->flush();  // collective
      },
      output ? &output->field_history() : nullptr, log, "  ");
  const std::string summary_path = (out / "stages.csv").string();
  auto write_summary = [&] {
    agree(mpi.comm(), [&] {
      if (root) write_file_atomic(summary_path, summary_header(shear) + summary);
    });
  };
  StageRun run(scene, sim, d_mean, density, series.stream(), log);
  run.set_output(output, kCase);
  run.set_fabric_output(fabric->streams());
  run.on_row([&] {
    series.check();
    agree(mpi.comm(), [&] { fabric->check(); });
  });
  const AppCheckpoint::Sims sims{{"sim", &sim}};
  run.on_step([&](const StageCursor& c) {
    if (ckpt.due(sim))
      ckpt.save(sims, app_fields(c, summary), fmt::format(" (stage {}, {})", c.stage + 1, scene.stages[c.stage].name));
  });
  if (restart && log)
    *log << fmt::format("-- restarted from {} at step {}, in stage {} ({})\n", restart->path(), sim.step_count(),
                        at.stage + 1, scene.stages[at.stage].name);
  write_summary();
  try {
    for (std::int32_t i = restart ? at.stage : 0; i < n; ++i) {
      const StageSpec& st = scene.stages[i];
      const bool resuming = restart && i == at.stage;
      if (resuming) run.set_account(at);
      if (log && !resuming) *log << fmt::format("stage {} ({}): {}\n", i + 1, st.name, st.where);
      const StageResult r = resuming ? run.run(st, i, &at) : run.run(st, i);
      if (log)
        *log << fmt::format(
            "stage {} ({}) ended after {} steps at step {}: p {:.1f} kPa, q/p {:.4f}, "
            "eps ({:.5f}, {:.5f}, {:.5f}), void ratio {:.4f}, energy balance error <= "
            "{:.3f} %\n",
            i + 1, st.name, r.steps, sim.step_count(), r.state.p / 1e3, r.state.p > 0 ? r.state.q / r.state.p : 0,
            r.strain[0], r.strain[1], r.strain[2], r.state.void_ratio, 100 * r.max_energy_error);
      summary += summary_row(i, st, r, sim.step_count(), shear);
      write_summary();
    }
  } catch (const BlowUpError& err) {  // every rank is here (the diagnosis is collective)
    ckpt.blowup(err, sims, app_fields(StageCursor{}, summary));
  }
  series.close();
  agree(mpi.comm(), [&] { fabric->close(); });
  if (log) *log << fmt::format("series and stage summary written to {}\n", outdir);
  if (log && shear)  // docs/shear.md
    *log << fmt::format("the figures (shear.png, the series'): bash scripts/plot.sh {}\n", outdir);
  return 0;
}

}  // namespace fabrica
