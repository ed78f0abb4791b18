#include "apps/app_checkpoint.hpp"

#include "core/errors.hpp"
#include "io/mpi/snapshot.hpp"
#include "parallel/mpi_context.hpp"

#include <fmt/core.h>

#include <bit>
#include <chrono>
#include <filesystem>
#include <ostream>

namespace fabrica {

namespace {
constexpr const char* kInstant = "fields.instant";
constexpr const char* kPositions = "fields.positions";
constexpr const char* kPositionRecord = "id:i64;x:f64[3]";
constexpr std::uint32_t kPositionBytes = 32;
}  // namespace

AppCheckpoint::AppCheckpoint(MPI_Comm comm, const Scene& scene, std::string outdir, std::string app, std::int64_t step,
                             std::function<void()> flush, const FieldHistory* fields, std::ostream* log,
                             std::string indent)
    : comm_(comm), fingerprint_(scene_fingerprint(scene.text)), outdir_(std::move(outdir)), app_(std::move(app)),
      schedule_(comm, scene.checkpoint_every, scene.checkpoint_seconds, step), flush_(std::move(flush)),
      fields_(fields), log_(log), indent_(std::move(indent)) {}

void add_field_history(CheckpointWriter& w, const FieldHistory& h) {
  if (!h.instant()) return;
  const FieldHistory::Instant& at = *h.instant();
  FieldWriter f;
  f.text("record", kPositionRecord).text("case", at.case_name).i64("step", at.step).vec3("lengths", at.lengths);
  // A sheared cell's matrix (after the fields of an orthorhombic one, which are as before it).
  if (matrix_sheared(at.cell_matrix())) f.mat3("matrix", at.cell_matrix());
  w.add_fields(kInstant, f);
  std::string records;
  records.reserve(h.ids().size() * kPositionBytes);
  for (std::size_t k = 0; k < h.ids().size(); ++k) {
    put_le(records, std::uint64_t(h.ids()[k]), 8);
    for (int a = 0; a < 3; ++a) put_le(records, std::bit_cast<std::uint64_t>(double(h.positions()[k][a])), 8);
  }
  w.add_records(kPositions, kPositionBytes, std::move(records));
}

void restore_field_history(const Checkpoint& c, FieldHistory& h, MPI_Comm comm) {
  h.clear();
  if (!c.has(kInstant)) return;  // the same answer on every rank
  FieldReader f = c.fields(kInstant);
  if (const std::string record = f.text("record"); record != kPositionRecord)
    throw InputError(c.path() + ": section " + kInstant + ": records '" + record + "', this build reads '" +
                     kPositionRecord + "'");
  FieldHistory::Instant at;
  at.case_name = f.text("case");
  at.step = f.i64("step");
  at.lengths = f.vec3("lengths");
  if (f.next_is("matrix")) at.matrix = f.mat3("matrix");
  f.done();
  const std::string& b = c.records(kPositions, kPositionBytes);
  const std::size_t n = b.size() / kPositionBytes;
  std::vector<GlobalId> ids(n);
  std::vector<Vec3> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    const char* r = b.data() + k * kPositionBytes;
    ids[k] = GlobalId(get_le(r, 8));
    for (int a = 0; a < 3; ++a) x[k][a] = std::bit_cast<double>(get_le(r + 8 + 8 * a, 8));
  }
  h.adopt(comm, at, ids, x);
}

std::string AppCheckpoint::write(const Sims& sims, const FieldWriter& app, bool blowup, const std::string& label) {
  if (flush_) flush_();
  const auto t = std::chrono::steady_clock::now();
  CheckpointWriter w(comm_, fingerprint_, app_, blowup);
  for (const auto& [prefix, sim] : sims) w.add_simulation(prefix, *sim);
  w.add_fields("app", app);
  if (fields_) add_field_history(w, *fields_);
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
