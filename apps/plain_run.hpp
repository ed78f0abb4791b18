// A plain run (a scene without [triaxial] and [[stage]], docs/scene.md): the optional [compress]
// (the cell compressed isotropically at its strain rate until p reaches its target, with its
// friction and no rolling or twisting resistance) and the [run] steps (the cell at rest, the
// scene's law), as two stages run by the stage loop (StageRun, apps/stage_run.hpp) with the plain
// run's own measurements and rows: a line on the standard output every 2000 steps of the
// compression (measured every 10), and OUT/series.csv (case "run" of run.h5) a row every [run]
// output_every steps and at the last; checkpoints ([run] checkpoint_every / checkpoint_seconds)
// that a restart continues from in either stage, bit for bit.
#pragma once
#include "io/serial/scene.hpp"
#include "io/serial/stage_spec.hpp"

#include <string>
#include <vector>

namespace fabrica {

class MpiContext;
class Checkpoint;
class RunOutput;
struct Setup;

// The stages of a plain run: the compression (with [compress]), then the [run] steps (with steps > 0).
StageSpec compress_stage(const Scene& scene);
StageSpec steps_stage(const Scene& scene);
std::vector<StageSpec> plain_stages(const Scene& scene);

// 'setup', when given, is the scene's make_run_setup made beforehand (moved from).
int run_plain(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output = nullptr,
              const Checkpoint* restart = nullptr, Setup* setup = nullptr);

}  // namespace fabrica
