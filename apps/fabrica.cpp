// fabrica: runs a scene (the built-in demo scene when none is given), continues one from a
// checkpoint, or describes an output file or a checkpoint.
//   fabrica run [scene.toml] [--output DIR] [--overwrite] [--restart CKPT]
//   fabrica info OUT/run.h5
//   fabrica fabric OUT/run.h5 [--case C] [--step S | --all] [--strong-ratio R] [--bins B] [-o DIR]
//   fabrica fields OUT/run.h5 [--case C] [--step S | --all] [--spacing H | --cells NX NY NZ]
//                  [--kernel gaussian|lucy] [--width W] [--cutoff C] [--density RHO] [-o FILE]
//   fabrica checkpoint-info CKPT
#include "apps/app_checkpoint.hpp"
#include "apps/ensemble.hpp"
#include "apps/fabric_offline.hpp"
#include "apps/fields_offline.hpp"
#include "apps/plain_run.hpp"
#include "apps/stage_driver.hpp"
#include "apps/triaxial.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/run_output.hpp"
#include "io/mpi/run_fields.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/mpi/verify.hpp"
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
#include <filesystem>

using namespace fabrica;

namespace {

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
  std::unique_ptr<RunOutput> out;
  if (scene.hdf5 && ckpt) {
    out = std::make_unique<RunOutput>(mpi.comm(), scene, outdir, RunOutput::Restart{});
    if (out->created_anew())
      fmt::print(
          "-- {} did not exist: a new one is written, holding only what the restarted run "
          "writes\n",
          out->path());
    // [fields]: the previous field instant's positions, for the next instant's displacement fields.
    if (scene.fields.enabled && scene.fields.displacement())
      restore_field_history(*ckpt, out->field_history(), mpi.comm());
  } else if (scene.hdf5) {
    out = std::make_unique<RunOutput>(mpi.comm(), scene, outdir, overwrite);
  }
  int rc = 0;
  try {
    rc = scene.triaxial.enabled
        ? run_triaxial(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, setup ? &*setup : nullptr)
        : !scene.stages.empty()
        ? run_stages(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, setup ? &*setup : nullptr)
        : run_plain(mpi, scene, outdir, out.get(), ckpt ? &*ckpt : nullptr, setup ? &*setup : nullptr);
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
