#include "apps/app_checkpoint.hpp"

#include "parallel/mpi_context.hpp"

#include <fmt/core.h>

#include <chrono>
#include <filesystem>
#include <ostream>

namespace fabrica {

AppCheckpoint::AppCheckpoint(MPI_Comm comm, const Scene& scene, std::string outdir, std::string app, std::int64_t step,
                             std::function<void()> flush, std::ostream* log, std::string indent)
    : comm_(comm), fingerprint_(scene_fingerprint(scene.text)), outdir_(std::move(outdir)), app_(std::move(app)),
      schedule_(comm, scene.checkpoint_every, scene.checkpoint_seconds, step), flush_(std::move(flush)), log_(log),
      indent_(std::move(indent)) {}

std::string AppCheckpoint::write(const Sims& sims, const FieldWriter& app, bool blowup, const std::string& label) {
  if (flush_) flush_();
  const auto t = std::chrono::steady_clock::now();
  CheckpointWriter w(comm_, fingerprint_, app_, blowup);
  for (const auto& [prefix, sim] : sims) w.add_simulation(prefix, *sim);
  w.add_fields("app", app);
  const std::string path = (std::filesystem::path(outdir_) / (blowup ? "blowup.ckpt" : "checkpoint.ckpt")).string();
  const std::uint64_t bytes = w.write(path);
  const std::int64_t step = sims.front().second->step_count();
  schedule_.taken(step);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  if (log_)
    *log_ << fmt::format("{}{} step {}{}: {} ({:.1f} MB in {:.2f} s)\n", indent_,
                         blowup ? "state at the blow-up," : "checkpoint at", step, label, path, double(bytes) / 1e6,
                         secs)
          << std::flush;
  return path;
}

std::string AppCheckpoint::save(const Sims& sims, const FieldWriter& app, const std::string& label) {
  return write(sims, app, false, label);
}

void AppCheckpoint::blowup(const BlowUpError& err, const Sims& sims, const FieldWriter& app) {
  const std::string path = write(sims, app, true, "");
  throw CollectiveError(std::string(err.what()) + "; the state at detection is saved in " + path +
                        " (for post-mortem: a run cannot restart from it)");
}

}  // namespace fabrica
