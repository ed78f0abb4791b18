// The periodic triaxial test (shared/spec/reference-problem.md section 4) as three stages on a
// Simulation (apps/triaxial_stages.hpp): servo-controlled isotropic consolidation,
// re-equilibration with the shear-stage contact parameters, and conventional triaxial
// compression along axis 1 with the lateral stresses held by the servo; and the sweep over mu_r
// that branches every case from the consolidated state.
#pragma once
#include "parallel/mpi_domain.hpp"
#include "apps/fabric_files.hpp"
#include "apps/fabric_output.hpp"
#include "apps/stage_run.hpp"
#include "apps/triaxial_stages.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"

#include <memory>
#include <string>

namespace fabrica {

class RunOutput;

struct TriaxialCase {
  std::string name;         // e.g. "mur_0.05"
  real_t rolling_friction;  // mu_r of the shear stage
};

// The study's protocol on one simulation: its three stages (apps/triaxial_stages.hpp) run by
// StageRun.
class TriaxialRun : public StageRun {
 public:
  using StageRun::StageRun;
  StageResult consolidate() { return run(consolidation_stage(scene_), kConsolidation); }
  StageResult equilibrate(real_t rolling_friction) {
    return run(equilibration_stage(scene_, rolling_friction), kEquilibration);
  }
  StageResult shear(real_t rolling_friction) { return run(shear_stage(scene_, rolling_friction), kShear); }
  // Continues the stage a checkpoint was taken in (the simulation restored from it).
  StageResult resume(const StageCursor& at);
};

class MpiContext;
class Checkpoint;
struct Setup;
// The scene's MPI domain ([parallel]) on several ranks; null (serial) on one.
// The decomposition options of the scene's [parallel] table.
MpiDomainOptions domain_options(const Scene& scene);
std::unique_ptr<Domain> make_domain(const MpiContext& mpi, const Scene& scene);

// The whole test for a scene with [triaxial] (apps/triaxial_sweep.hpp): one consolidation, then
// for each case of the sweep (or the single [contact] rolling_friction) a branch of the
// consolidated state that is re-equilibrated and sheared. Writes OUT/<case>/series.csv and OUT/summary.csv (rank 0), and
// with 'output' the same series and the snapshots into run.h5 (cases "consolidation" and each
// case's name). Checkpoints ([run] checkpoint_every / checkpoint_seconds) go to OUT/checkpoint.ckpt; with
// 'restart' the test continues from one (docs/checkpoint.md).
// 'setup', when given, is make_setup(triaxial_setup_scene(scene)) made beforehand (fabrica run
// checks it before run.h5 is created); it is moved from. Without it the set-up is made here.
int run_triaxial(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output = nullptr,
                 const Checkpoint* restart = nullptr, Setup* setup = nullptr);

// The scene whose particle set-up a triaxial or stages run uses: the scene with the largest mu_r
// of its sweep or its stages and the strongest dashpots of its stages (most_damped_law), so
// that the time step suits every stage (rolling springs and damping included). The run itself
// starts from the scene's own law.
Scene triaxial_setup_scene(const Scene& scene);

}  // namespace fabrica
