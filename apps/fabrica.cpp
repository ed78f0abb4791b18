// fabrica: runs a scene (the built-in demo scene when none is given), or describes an output file.
//   fabrica run [scene.toml] [--output DIR] [--overwrite]
//   fabrica info OUT/run.h5
//   fabrica fabric OUT/run.h5 [--case C] [--step S | --all] [--strong-ratio R] [--bins B] [-o DIR]
#include "apps/fabric_offline.hpp"
#include "apps/triaxial.hpp"
#include "core/simulation.hpp"
#include "io/run_output.hpp"
#include "io/snapshot.hpp"
#include "io/scene.hpp"
#include "io/setup.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_context.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <memory>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

using namespace fabrica;

namespace {

void print_header() {
  fmt::print("{:>9} {:>11} {:>11} {:>11} {:>7} {:>7} {:>9} {:>11} {:>11}\n", "step", "time_s",
             "p_Pa", "q_Pa", "Z", "Z_m", "contacts", "Ekin_J", "unbal");
}

constexpr const char* kSeriesHeader =
    "step,time,s11,s22,s33,s12,s23,s13,p,q,Z,contacts,sliding,rolling,kinetic,e_normal,"
    "e_shear,e_rolling,diss_friction,diss_rolling,diss_viscous,diss_local,void_ratio\n";

void print_row(const Simulation& sim, const MacroState& m, std::ofstream* csv, RunOutput* out) {
  if (out) {
    const double v[] = {sim.time(), m.stress(0, 0), m.stress(1, 1), m.stress(2, 2), m.stress(0, 1),
                        m.stress(1, 2), m.stress(0, 2), m.p, m.q, m.coordination, double(m.contacts),
                        double(m.sliding), double(m.rolling), m.kinetic, m.e_normal, m.e_shear,
                        m.e_rolling, m.dissipated.friction, m.dissipated.rolling,
                        m.dissipated.viscous, m.dissipated.local, m.void_ratio};
    out->series_row("run", kSeriesHeader, "", sim.step_count(), v);
  }
  fmt::print("{:>9} {:>11.5e} {:>11.5e} {:>11.5e} {:>7.3f} {:>7.3f} {:>9} {:>11.4e} {:>11.4e}\n",
             sim.step_count(), sim.time(), m.p, m.q, m.coordination, m.mech_coordination,
             m.contacts, m.kinetic, m.unbalanced);
  if (csv) {
    *csv << fmt::format("{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},"
                        "{:.10e},{},{},{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},"
                        "{:.10e},{:.10e}\n",
                        sim.step_count(), sim.time(), m.stress(0, 0), m.stress(1, 1), m.stress(2, 2),
                        m.stress(0, 1), m.stress(1, 2), m.stress(0, 2), m.p, m.q, m.coordination,
                        m.contacts, m.sliding, m.rolling, m.kinetic, m.e_normal, m.e_shear,
                        m.e_rolling, m.dissipated.friction, m.dissipated.rolling,
                        m.dissipated.viscous, m.dissipated.local, m.void_ratio);
  }
}

// Stops the run, on every rank, with a diagnostic if the state is no longer physical.
void check_sane(const Simulation& sim, const MacroState& m, const Scene& scene) {
  const std::string msg = diagnose(m, sim.step_count(), scene.max_overlap, scene.kinetic_runaway);
  if (!msg.empty()) throw CollectiveError(msg);
}

Vec3 log_strain(const Vec3& l0, const Vec3& l) {
  return Vec3(std::log(l0[0] / l[0]), std::log(l0[1] / l[1]), std::log(l0[2] / l[2]));
}

int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* out);

int run(const MpiContext& mpi, const std::string& scene_path, const std::string& outdir,
        bool overwrite) {
  const auto t0 = std::chrono::steady_clock::now();
  const Scene scene = scene_path.empty() ? default_scene() : load_scene(scene_path);
  if (mpi.rank() != 0 && !std::freopen("/dev/null", "w", stdout)) return 1;  // rank 0 speaks for all
  std::unique_ptr<RunOutput> out;
  if (scene.hdf5) out = std::make_unique<RunOutput>(mpi.comm(), scene, outdir, overwrite);
  int rc = 0;
  try {
    rc = scene.triaxial.enabled ? run_triaxial(mpi, scene, outdir, out.get())
                                : run_plain(mpi, scene, outdir, out.get());
  } catch (const CollectiveError&) {  // met by every rank: the file can be closed (collective)
    if (out) out->close();
    throw;
  } catch (const InputError&) {
    if (out) out->close();
    throw;
  }
  if (out) {
    out->close();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    fmt::print("output: {} snapshot(s), {:.1f} MB in {} and run.xmf, {:.2f} s writing ({:.2f} % of "
               "{:.1f} s wall time)\n",
               out->snapshots(), out->bytes() / 1e6, out->path(), out->seconds(),
               100 * out->seconds() / wall, wall);
  }
  return rc;
}

int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* out) {
  const bool root = mpi.rank() == 0;
  Setup s = make_setup(scene);
  std::unique_ptr<Domain> domain = make_domain(mpi, scene);
  fmt::print("scene {}: {} spheres, cell {:.4f} x {:.4f} x {:.4f} m\n", scene.path,
             s.particles.n_owned(), s.cell.lengths()[0], s.cell.lengths()[1], s.cell.lengths()[2]);
  fmt::print("critical time step {:.4e} s, time step {:.4e} s (fraction {:.3f})\n", s.critical_dt,
             s.params.dt, s.params.dt / s.critical_dt);
  fmt::print("{} MPI rank(s){}\n", mpi.size(),
             mpi.size() > 1 ? ", " + scene.parallel.decomposition + " decomposition" : "");
  std::ofstream csv;
  if (root) {
    std::filesystem::create_directories(outdir);
    csv.open(std::filesystem::path(outdir) / "series.csv");
  }
  csv << kSeriesHeader;

  const ContactLawParams law = scene.law;
  const auto t0 = std::chrono::steady_clock::now();
  std::int64_t steps_done = 0;
  if (scene.compress.enabled) {
    ContactLawParams prep = law;
    prep.friction = scene.compress.friction;
    prep.rolling_friction = 0;
    s.params.law = prep;
  }
  Simulation sim(std::move(s.particles), s.cell, s.params, domain.get());
  const Vec3 l0 = sim.cell().lengths();
  // A snapshot every [run] snapshot_every steps and at the end of each stage.
  auto snapshot = [&](bool force) {
    if (out && (force || out->snapshot_due(sim.step_count())))
      out->snapshot("run", sim, log_strain(l0, sim.cell().lengths()));
  };
  print_header();
  if (scene.compress.enabled) {
    const real_t rate = scene.compress.strain_rate;
    sim.cell().set_strain_rate(Vec3::Constant(rate));
    fmt::print("-- compression at {} 1/s to p = {} Pa\n", rate, scene.compress.target_pressure);
    std::int64_t k = 0;
    for (; k < scene.compress.max_steps; ++k) {
      const bool measure = k % 10 == 0;
      sim.step(measure);
      snapshot(false);
      if (!measure) continue;
      const MacroState m = sim.macro();
      check_sane(sim, m, scene);
      if (k % 2000 == 0) print_row(sim, m, nullptr, nullptr);
      if (m.p >= scene.compress.target_pressure) break;
    }
    steps_done += k;
    if (k == scene.compress.max_steps)
      throw std::runtime_error(fmt::format("{}: [compress] max_steps = {} reached before p = {} Pa",
                                           scene.path, scene.compress.max_steps,
                                           scene.compress.target_pressure));
    snapshot(true);
    sim.cell().set_strain_rate(Vec3::Zero());
    sim.set_law(law);
    const MacroState m = sim.macro();
    fmt::print("-- compressed: void ratio {:.4f}, solid fraction {:.4f}; now mu_s = {}, mu_r = {}\n",
               m.void_ratio, 1.0 / (1.0 + m.void_ratio), law.friction, law.rolling_friction);
  }
  for (std::int64_t k = 1; k <= scene.steps; ++k) {
    const bool measure = k % scene.output_every == 0 || k == scene.steps;
    sim.step(measure);
    snapshot(false);
    if (!measure) continue;
    const MacroState m = sim.macro();
    check_sane(sim, m, scene);
    print_row(sim, m, root ? &csv : nullptr, out);
  }
  snapshot(true);
  steps_done += scene.steps;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double n_total = double(sim.macro().particles);
  fmt::print("{} steps in {:.2f} s: {:.4f} us per particle-step on {} rank(s), {} neighbour rebuilds\n",
             steps_done, secs, secs * 1e6 / (double(steps_done) * n_total), mpi.size(),
             sim.rebuild_count());
  fmt::print("series written to {}\n", (std::filesystem::path(outdir) / "series.csv").string());
  return 0;
}

// Describes a run file; a missing, truncated or foreign file is an InputError naming it.
int info(const MpiContext& mpi, const std::string& path) {
  const RunFileInfo ri = read_run_info(path);
  const std::vector<SnapshotInfo> snaps = list_snapshots(path);
  const std::vector<std::string> cases = list_series(path);
  std::vector<std::size_t> rows;
  for (const std::string& c : cases) rows.push_back(read_series(path, c).rows());
  if (mpi.rank() != 0) return 0;
  fmt::print("file: {}\nfabrica version: {} (git {}), written by {} MPI rank(s)\nscene: {}\n", path,
             ri.version, ri.git_describe, ri.ranks, ri.scene_path);
  fmt::print("series ({}):\n", cases.size());
  for (std::size_t k = 0; k < cases.size(); ++k) fmt::print("  {:<16} {:>8} rows\n", cases[k], rows[k]);
  fmt::print("snapshots ({}):\n  {:<16} {:>12} {:>13} {:>10} {:>10}\n", snaps.size(), "case", "step",
             "time_s", "particles", "contacts");
  for (const SnapshotInfo& s : snaps)
    fmt::print("  {:<16} {:>12} {:>13.6e} {:>10} {:>10}\n", s.case_name, s.step, s.time, s.particles,
               s.contacts);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  MpiContext mpi(argc, argv);
  CLI::App app{"Fabrica: DEM for granular mechanics"};
  app.require_subcommand(1);
  std::string scene_path, outdir = "fabrica-output";
  CLI::App* runc = app.add_subcommand("run", "run a scene (default: the built-in demo scene)");
  runc->add_option("scene", scene_path, "scene file (TOML)")->check(CLI::ExistingFile);
  runc->add_option("-o,--output", outdir, "output directory");
  bool overwrite = false;
  runc->add_flag("--overwrite", overwrite, "replace an existing OUT/run.h5");
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
  return run_guarded(mpi, [&]() -> int {
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      return mpi.rank() == 0 ? app.exit(e) : e.get_exit_code();
    }
    if (*infoc) return info(mpi, info_path);
    if (*fabc) return fabric_offline(mpi, fab);
    return run(mpi, scene_path, outdir, overwrite);
  });
}
