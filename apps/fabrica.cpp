// fabrica: runs a scene (the built-in demo scene when none is given), continues one from a
// checkpoint, or describes an output file or a checkpoint.
//   fabrica run [scene.toml] [--output DIR] [--overwrite] [--restart CKPT]
//   fabrica info OUT/run.h5
//   fabrica fabric OUT/run.h5 [--case C] [--step S | --all] [--strong-ratio R] [--bins B] [-o DIR]
//   fabrica fields OUT/run.h5 [--case C] [--step S | --all] [--spacing H | --cells NX NY NZ]
//                  [--kernel gaussian|lucy] [--width W] [--cutoff C] [--density RHO] [-o FILE]
//   fabrica checkpoint-info CKPT
#include "apps/ensemble.hpp"
#include "apps/app_checkpoint.hpp"
#include "apps/fabric_offline.hpp"
#include "apps/fields_offline.hpp"
#include "apps/series_file.hpp"
#include "apps/stage_driver.hpp"
#include "apps/triaxial.hpp"
#include "core/simulation.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/run_output.hpp"
#include "io/mpi/run_fields.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/mpi/verify.hpp"
#include "io/serial/write_check.hpp"
#include "io/serial/scene.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "parallel/peak_memory.hpp"
#include "io/serial/setup.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <memory>
#include <string>
#include <vector>
#include <optional>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>

using namespace fabrica;

namespace {

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
std::string series_header(std::size_t walls, bool driven) {
  if (walls == 0 && !driven) return kSeriesHeader;
  std::string h(kSeriesHeader);
  h.pop_back();
  h += ",wall_contacts,energy_input,wall_work,drive_work";
  for (std::size_t w = 1; w <= walls; ++w) h += fmt::format(",wall{0}_fx,wall{0}_fy,wall{0}_fz,wall{0}_position", w);
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

void print_row(const Simulation& sim, const MacroState& m, std::ostream* csv, RunOutput* out) {
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
    out->series_row("run", series_header(sim.params().walls.size(), !sim.params().driven.empty()), "", sim.step_count(),
                    v);
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
    *csv << "\n";
  }
}

// Stops the run, on every rank, with a diagnostic if the state is no longer physical.
void check_sane(const Simulation& sim, const MacroState& m, const Scene& scene) {
  const std::string msg = diagnose(m, sim.step_count(), scene.max_overlap, scene.kinetic_runaway);
  if (!msg.empty()) throw BlowUpError(msg);
}

Vec3 log_strain(const Vec3& l0, const Vec3& l) {
  return Vec3(std::log(l0[0] / l[0]), std::log(l0[1] / l[1]), std::log(l0[2] / l[2]));
}

// Where a plain run is: phase 0 compression, 1 the [run] steps; k the last finished iteration.
struct Cursor {
  std::int32_t phase = 0;
  std::int64_t k = 0;
};

int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* out,
              const Checkpoint* ckpt, const std::string& restart, Setup* setup);

int run_scene(const MpiContext& mpi, const Scene& scene, const std::string& outdir, bool overwrite,
              const std::string& restart);

int run(const MpiContext& mpi, const std::string& scene_path, const std::string& outdir, bool overwrite,
        const std::string& restart) {
  // Every rank reads the scene (and below the data file) itself: the ranks agree on the outcome,
  // so that a read that fails on one rank ends all of them with its message (parallel/guard.hpp).
  Scene scene;
  agree(mpi.comm(), [&] { scene = scene_path.empty() ? default_scene() : load_scene(scene_path); });
  if (is_ensemble(scene)) {  // realisations, consolidation frictions (apps/ensemble.hpp)
    // --restart OUT continues the ensemble in its output directory (a checkpoint of one of its
    // runs is that run's: restarted on its own with its own scene).
    agree(mpi.comm(), [&] {
      std::error_code ec;
      if (!restart.empty() &&
          (!std::filesystem::is_directory(restart, ec) || !std::filesystem::equivalent(restart, outdir, ec)))
        throw InputError("--restart " + restart + ": " + scene.path +
                         " runs an ensemble ([triaxial] realisations, seeds or consolidation_friction_cases): "
                         "continue it with --restart OUT, its output directory (-o " +
                         outdir + ")");
    });
    return run_ensemble(mpi, scene, outdir, overwrite, !restart.empty(),
                        [&](const MpiContext& group, const Scene& one, const std::string& dir, const std::string& from,
                            bool replace) { return run_scene(group, one, dir, replace, from); });
  }
  return run_scene(mpi, scene, outdir, overwrite, restart);
}

int run_scene(const MpiContext& mpi, const Scene& scene, const std::string& outdir, bool overwrite,
              const std::string& restart) {
  const auto t0 = std::chrono::steady_clock::now();
  // A restart reads and checks the whole checkpoint before anything is written.
  std::optional<Checkpoint> ckpt;
  if (!restart.empty()) {
    Checkpoint::Expect ex;
    ex.scene_text = &scene.text;
    ex.app = scene.triaxial.enabled ? "triaxial" : !scene.stages.empty() ? "stages" : "run";
    ckpt = Checkpoint::read(mpi.comm(), restart, ex);
  }
  agree(mpi.comm(), [&] {  // rank 0 speaks for all
    if (mpi.rank() != 0 && !std::freopen("/dev/null", "w", stdout))
      throw std::runtime_error(std::string("/dev/null: cannot redirect the standard output of rank ") +
                               std::to_string(mpi.rank()) + " there: " + std::strerror(errno));
  });
  // run.h5: a new file, or on a restart the existing one, continued (docs/output.md); a damaged
  // one stops the restart here, before any file is touched.
  // Bad input in the particle set-up (a missing or malformed data file, overlapping spheres, a
  // time step above the critical one) is found before any output file is created or replaced.
  // The set-up made here is the run's (made once).
  std::optional<Setup> setup;
  if (!ckpt)
    setup = make_run_setup(scene.triaxial.enabled || !scene.stages.empty() ? triaxial_setup_scene(scene) : scene,
                           mpi.comm(), domain_options(scene));
  // [fields]: the grid and kernel against the specimen, before the run (every rank the message).
  if (setup) check_run_fields(scene, setup->particles, setup->cell, mpi.comm());
  if (ckpt && scene.fields.enabled) refuse_sheared_fields(scene.path, ckpt->cell("sim"));
  std::unique_ptr<RunOutput> out;
  if (scene.hdf5 && ckpt) {
    out = std::make_unique<RunOutput>(mpi.comm(), scene, outdir, RunOutput::Restart{});
    if (out->created_anew())
      fmt::print(
          "-- {} did not exist: a new one is written, holding only what the restarted run "
          "writes\n",
          out->path());
  } else if (scene.hdf5) {
    out = std::make_unique<RunOutput>(mpi.comm(), scene, outdir, overwrite);
  }
  int rc = 0;
  try {
    rc = scene.triaxial.enabled
        ? run_triaxial(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, setup ? &*setup : nullptr)
        : !scene.stages.empty()
        ? run_stages(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, setup ? &*setup : nullptr)
        : run_plain(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, restart, setup ? &*setup : nullptr);
  } catch (const CollectiveError&) {  // met by every rank: the file can be closed (collective)
    if (out) out->close_after_error();
    throw;
  } catch (const InputError&) {
    if (out) out->close_after_error();
    throw;
  }
  if (out) {
    out->close();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    fmt::print(
        "output: {} snapshot(s), {:.1f} MB in {} and run.xmf, {:.2f} s writing ({:.2f} % of "
        "{:.1f} s wall time)\n",
        out->snapshots(), out->bytes() / 1e6, out->path(), out->seconds(), 100 * out->seconds() / wall, wall);
    if (scene.fields.enabled)
      fmt::print(
          "fields: {} instant(s) in {} (run_fields.xmf), {:.2f} s computing and writing ({:.2f} % of {:.1f} s)\n",
          out->field_instants(), out->path(), out->fields_seconds(), 100 * out->fields_seconds() / wall, wall);
  }
  const PeakMemory mem = peak_memory(mpi.comm());
  fmt::print(
      "peak memory per rank: {:.1f} MB at most (rank {}), {:.1f} MB on average, {:.1f} MB at "
      "least, over {} rank(s)\n",
      mem.max / 1e6, mem.max_rank, mem.mean / 1e6, mem.min / 1e6, mpi.size());
  fmt::print(
      "private peak memory per rank (less {:.1f} MB of shared libraries and mapped files): "
      "{:.1f} MB at most (rank {}), {:.1f} MB on average",
      mem.shared_max / 1e6, mem.private_max / 1e6, mem.private_max_rank, mem.private_mean / 1e6);
  if (mem.ghosts_max > 0)
    fmt::print("; ghosts at most {} on a rank ({:.1f} % of its {} owned then)", mem.ghosts_max,
               100.0 * double(mem.ghosts_max) / double(std::max<std::int64_t>(mem.owned_at_ghosts_max, 1)),
               mem.owned_at_ghosts_max);
  fmt::print("\n");
  return rc;
}

int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* out,
              const Checkpoint* ckpt, const std::string& restart, Setup* setup) {
  namespace fs = std::filesystem;
  const bool root = mpi.rank() == 0;
  Cursor at;
  if (ckpt) {
    FieldReader in = ckpt->fields("app");
    at.phase = in.i32("phase");
    at.k = in.i64("k");
    in.done();
  }
  std::optional<SimulationSnapshot> saved;  // decoded (and checked) before any file is touched
  if (ckpt) saved = ckpt->simulation("sim", mpi.comm());
  // run.h5: the rows and snapshots after the checkpoint's step go (collective).
  if (out && ckpt) out->resume_after(ckpt->header().step, {"run"}, 0);
  Setup s = setup ? std::move(*setup) : make_run_setup(scene, mpi.comm(), domain_options(scene));
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  fmt::print("scene {}: {} spheres, cell {:.4f} x {:.4f} x {:.4f} m\n", scene.path,
             specimen_totals(s.particles, mpi.comm()).count, s.cell.lengths()[0], s.cell.lengths()[1],
             s.cell.lengths()[2]);
  fmt::print("critical time step {:.4e} s, time step {:.4e} s (fraction {:.3f})\n", s.critical_dt, s.params.dt,
             s.params.dt / s.critical_dt);
  fmt::print("{} MPI rank(s){}\n", mpi.size(),
             mpi.size() > 1 ? ", " + scene.parallel.decomposition + " decomposition" : "");
  const fs::path series_path = fs::path(outdir) / "series.csv";
  agree(mpi.comm(), [&] {  // the output directory exists before any rank writes to it
    if (root) make_output_directory(outdir);
  });
  SeriesFile csv(mpi.comm(), series_path.string(), series_header(scene.walls.size(), !scene.driven.empty()), 0,
                 ckpt ? ckpt->header().step : -1);

  const ContactLawParams law = scene.law;
  const auto t0 = std::chrono::steady_clock::now();
  if (scene.compress.enabled) {  // every material's and pair's law alike
    LawChanges prep;
    prep.set(&ContactLawParams::friction, scene.compress.friction);
    prep.set(&ContactLawParams::rolling_friction, 0);
    prep.set(&ContactLawParams::twisting_friction, 0);
    s.params.law = prep.applied_to(law);
    s.params.materials.apply(prep);
  }
  const Vec3 l0 = s.cell.lengths();  // the strain reference of the snapshots (also on a restart)
  std::unique_ptr<Simulation> simp = ckpt
      ? std::make_unique<Simulation>(std::move(*saved), domain.get())
      : std::make_unique<Simulation>(std::move(s.particles), s.cell, s.params, domain.get(), s.holding);
  Simulation& sim = *simp;
  const std::int64_t first_step = sim.step_count();
  // A snapshot every [run] snapshot_every steps and at the end of each stage.
  auto snapshot = [&](bool force) {
    if (out && (force || out->snapshot_due(sim.step_count())))
      out->snapshot("run", sim, log_strain(l0, sim.cell().lengths()));
  };
  if (ckpt)
    fmt::print("-- restarted from {} at step {} (written on {} rank(s))\n", restart, sim.step_count(),
               ckpt->header().ranks);
  AppCheckpoint checkpoints(
      mpi.comm(), scene, outdir, "run", sim.step_count(),
      [&] {
        csv.sync();             // on disk: a checkpoint never refers to rows that are not
        if (out) out->flush();  // nor to output that is not (collective)
      },
      root ? &std::cout : nullptr, "-- ");
  const AppCheckpoint::Sims sims{{"sim", &sim}};
  auto save = [&](std::int32_t phase, std::int64_t k) {
    FieldWriter app;
    app.i32("phase", phase).i64("k", k);
    checkpoints.save(sims, app);
  };
  try {
    print_header();
    if (scene.compress.enabled && at.phase == 0) {
      const real_t rate = scene.compress.strain_rate;
      if (!ckpt) sim.cell().set_strain_rate(Vec3::Constant(rate));
      fmt::print("-- compression at {} 1/s to p = {} Pa\n", rate, scene.compress.target_pressure);
      std::int64_t k = ckpt ? at.k + 1 : 0;
      for (; k < scene.compress.max_steps; ++k) {
        const bool measure = k % 10 == 0;
        sim.step(measure);
        if (!sim.step_guard().empty()) throw BlowUpError(sim.step_guard());  // every step
        snapshot(false);
        if (measure) {
          const MacroState m = sim.macro();
          check_sane(sim, m, scene);
          if (k % 2000 == 0) print_row(sim, m, nullptr, nullptr);
          if (m.p >= scene.compress.target_pressure) break;
        }
        if (checkpoints.due(sim)) save(0, k);
      }
      if (k == scene.compress.max_steps)
        throw std::runtime_error(fmt::format("{}: [compress] max_steps = {} reached before p = {} Pa", scene.path,
                                             scene.compress.max_steps, scene.compress.target_pressure));
      snapshot(true);
      sim.cell().set_strain_rate(Vec3::Zero());
      sim.set_laws(law, scene_materials(scene));
      const MacroState m = sim.macro();
      fmt::print("-- compressed: void ratio {:.4f}, solid fraction {:.4f}; now mu_s = {}, mu_r = {}\n", m.void_ratio,
                 1.0 / (1.0 + m.void_ratio), law.friction, law.rolling_friction);
    }
    for (std::int64_t k = at.phase == 1 ? at.k + 1 : 1; k <= scene.steps; ++k) {
      const bool measure = k % scene.output_every == 0 || k == scene.steps;
      sim.step(measure);
      if (!sim.step_guard().empty()) throw BlowUpError(sim.step_guard());  // every step
      snapshot(false);
      if (measure) {
        const MacroState m = sim.macro();
        check_sane(sim, m, scene);
        print_row(sim, m, csv.stream(), out);
        csv.check();
      }
      if (out && out->fields_due(k)) out->fields("run", sim);  // [fields]: every 'every' rows
      if (k < scene.steps && checkpoints.due(sim)) save(1, k);
    }
    snapshot(true);
  } catch (const BlowUpError& e) {  // every rank is here (the diagnosis is collective)
    FieldWriter app;
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

// Describes a run file; a missing, truncated or foreign file is an InputError naming it.
int info(const MpiContext& mpi, const std::string& path) {
  // Every rank reads the file; they agree on the outcome (a read failing on one rank ends all).
  RunFileInfo ri;
  std::vector<SnapshotInfo> snaps;
  std::vector<std::string> cases;
  std::vector<std::size_t> rows;
  VerifyReport ver;
  agree(mpi.comm(), [&] {
    if (mpi.rank() == 0) ver = verify_run_file(path);  // every dataset's checksum, first
    ri = read_run_info(path);
    snaps = list_snapshots(path);
    cases = list_series(path);
    for (const std::string& c : cases) rows.push_back(read_series(path, c).rows());
  });
  if (mpi.rank() != 0) return 0;
  fmt::print("file: {}\nfabrica version: {} (git {}), written by {} MPI rank(s)\nscene: {}\n", path, ri.version,
             ri.git_describe, ri.ranks, ri.scene_path);
  fmt::print("series ({}):\n", cases.size());
  for (std::size_t k = 0; k < cases.size(); ++k) fmt::print("  {:<16} {:>8} rows\n", cases[k], rows[k]);
  fmt::print("snapshots ({}):\n  {:<16} {:>12} {:>13} {:>10} {:>10}\n", snaps.size(), "case", "step", "time_s",
             "particles", "contacts");
  for (const SnapshotInfo& s : snaps)
    fmt::print("  {:<16} {:>12} {:>13.6e} {:>10} {:>10}\n", s.case_name, s.step, s.time, s.particles, s.contacts);
  fmt::print(
      "data: {} datasets read without error, {} of them carrying a Fletcher-32 checksum, "
      "verified ({:.2f} MB in {:.3f} s)\n",
      ver.datasets, ver.checksummed, ver.bytes / 1e6, ver.seconds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  MpiContext mpi(argc, argv);
  CLI::App app{"Fabrica: DEM for granular mechanics"};
  app.require_subcommand(1);
  std::string scene_path, outdir = "fabrica-output";
  CLI::App* runc = app.add_subcommand("run", "run a scene (default: the built-in demo scene)");
  // Not CLI::ExistingFile: load_scene says what the system said (no such file, permission denied).
  runc->add_option("scene", scene_path, "scene file (TOML)");
  runc->add_option("-o,--output", outdir, "output directory");
  bool overwrite = false;
  runc->add_flag("--overwrite", overwrite, "replace an existing OUT/run.h5");
  std::string restart;
  runc->add_option("--restart", restart,
                   "continue from this checkpoint (written by a run of the same scene); "
                   "OUT/run.h5 is continued from the checkpoint's step");
  std::string info_path;
  CLI::App* infoc = app.add_subcommand("info", "describe an output file (OUT/run.h5)");
  infoc->add_option("file", info_path, "run.h5 of a run")->required();
  FabricOfflineArgs fab;
  CLI::App* fabc = app.add_subcommand("fabric", "fabric analysis of contact snapshots in OUT/run.h5 (docs/fabric.md)");
  fabc->add_option("file", fab.file, "run.h5 of a run")->required();
  fabc->add_option("--case", fab.case_name, "case (default: every case)");
  auto* stepo = fabc->add_option("--step", fab.step, "step of the snapshot (default: the last of each case)");
  fabc->add_flag("--all", fab.all, "every snapshot")->excludes(stepo);
  fabc->add_option("--strong-ratio", fab.strong_ratio, "strong: f_n > R x mean f_n (default 1)");
  fabc->add_option("--bins", fab.bins, "rose diagram bins over [0, pi) (default 36)");
  fabc->add_option("-o,--output", fab.outdir, "output directory (default: <dir of file>/fabric)");
  FieldsOfflineArgs fld;
  std::vector<int> cells;
  CLI::App* fldc =
      app.add_subcommand("fields", "coarse-grained fields of the snapshots in OUT/run.h5 on a grid (docs/fields.md)");
  fldc->add_option("file", fld.file, "run.h5 of a run")->required();
  fldc->add_option("--case", fld.case_name, "case (default: every case)");
  auto* fsteps = fldc->add_option("--step", fld.step, "step of the snapshot (default: the last of each case)");
  fldc->add_flag("--all", fld.all, "every snapshot")->excludes(fsteps);
  auto* fspacing = fldc->add_option("--spacing", fld.spacing, "grid spacing, m (default: the mean diameter)");
  fldc->add_option("--cells", cells, "nodes along x, y, z")->expected(3)->excludes(fspacing);
  fldc->add_option("--kernel", fld.kernel, "gaussian (default) or lucy");
  fldc->add_option("--width", fld.width,
                   "kernel width, m: the Gaussian's standard deviation (default: the mean diameter), Lucy's support "
                   "radius (default: 3 mean diameters)");
  fldc->add_option("--cutoff", fld.cutoff, "the Gaussian's support radius in widths (default 3)");
  fldc->add_option("--density", fld.density, "particle density, kg/m^3 (default: the run's scene)");
  fldc->add_option("--strong-ratio", fld.strong_ratio, "strong: f_n > R x mean f_n (default 1)");
  fldc->add_option("-o,--output", fld.output, "output HDF5 file (default: <dir of file>/fields.h5)");
  std::string ckpt_path;
  CLI::App* ckptc = app.add_subcommand("checkpoint-info", "print the header of a checkpoint");
  ckptc->add_option("checkpoint", ckpt_path, "checkpoint file")->required();
  return run_guarded(mpi, [&]() -> int {
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) { return mpi.rank() == 0 ? app.exit(e) : e.get_exit_code(); }
    if (*infoc) return info(mpi, info_path);
    if (*fabc) return fabric_offline(mpi, fab);
    if (*fldc) {
      if (cells.size() == 3) fld.cells = std::array<int, 3>{cells[0], cells[1], cells[2]};
      return fields_offline(mpi, fld);
    }
    if (*ckptc) {
      Checkpoint::Expect any;
      any.allow_blowup = true;
      const Checkpoint c = Checkpoint::read(mpi.comm(), ckpt_path, any);
      if (mpi.rank() == 0) fmt::print("{}", describe(c.header(), ckpt_path));
      return 0;
    }
    return run(mpi, scene_path, outdir, overwrite, restart);
  });
}
