// The checkpoints of an application (docs/checkpoint.md): OUT/checkpoint.ckpt when the
// schedule ([run] checkpoint_every / checkpoint_seconds) falls due, and OUT/blowup.ckpt with the
// state at a numerical blow-up (for post-mortem). Before each, the application's files are put
// on disk ('flush': a checkpoint never refers to rows or output that are not). Collective.
#pragma once
#include "core/simulation.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/field_history.hpp"
#include "io/mpi/fields.hpp"
#include "io/serial/scene.hpp"

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace fabrica {

class BlowUpError;

class AppCheckpoint {
 public:
  // 'app': "run", "triaxial" or "stages" (the header's application); 'step': the step the
  // schedule counts from; log lines start with 'indent' (rank 0's 'log', or null). 'fields':
  // the run's previous field instant (RunOutput::field_history), saved with every checkpoint
  // that it holds one (null: none).
  AppCheckpoint(MPI_Comm comm, const Scene& scene, std::string outdir, std::string app, std::int64_t step,
                std::function<void()> flush, const FieldHistory* fields, std::ostream* log, std::string indent);
  using Sims = std::vector<std::pair<std::string, const Simulation*>>;  // prefix, simulation
  // Whether one is due at the end of this step (collective: the ranks agree).
  bool due(const Simulation& sim) { return schedule_.due(sim); }
  void rebase(std::int64_t step) { schedule_.rebase(step); }
  // Writes the simulations (the first one's step and time head the file) and the
  // application's fields; the log line says 'label' (e.g. " (mur_0.2, shear)"). The path.
  std::string save(const Sims& sims, const FieldWriter& app, const std::string& label = "");
  // The state at a blow-up to OUT/blowup.ckpt; throws the error with where it is saved.
  [[noreturn]] void blowup(const BlowUpError& err, const Sims& sims, const FieldWriter& app);

 private:
  std::string write(const Sims& sims, const FieldWriter& app, bool blowup, const std::string& label);
  MPI_Comm comm_;
  std::uint64_t fingerprint_;
  std::string outdir_, app_;
  CheckpointSchedule schedule_;
  std::function<void()> flush_;
  const FieldHistory* fields_;
  std::ostream* log_;
  std::string indent_;
};

// The previous field instant of a run whose [fields] keeps a displacement field (docs/checkpoint.md):
// section "fields.instant" (fields: the record layout, the instant's case, step and cell lengths)
// and section "fields.positions" (distributed records id:i64;x:f64[3], each home rank its own),
// when 'h' keeps an instant (the same on every rank). Collective.
void add_field_history(CheckpointWriter& w, const FieldHistory& h);
// The instant those sections hold into 'h', each position to its home rank on this run's ranks
// (any rank count); a checkpoint without them (taken before the first instant, or by a build
// before the displacement fields in the run) leaves 'h' empty: the next field instant is then
// the first of its sequence. Collective.
void restore_field_history(const Checkpoint& c, FieldHistory& h, MPI_Comm comm);

}  // namespace fabrica
