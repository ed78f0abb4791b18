// A scene's [[stage]] list (docs/scene.md) run in order on one simulation: the series of every
// stage in OUT/series.csv (and case "stages" of run.h5), the fabric rows ([fabric]) in
// OUT/fabric.csv, sff.csv, rose.csv, one row per finished stage in OUT/stages.csv, and
// checkpoints ([run] checkpoint_every / checkpoint_seconds) that a restart continues from
// inside any stage bit for bit.
#pragma once
#include "io/serial/scene.hpp"

#include <string>

namespace fabrica {

class MpiContext;
class Checkpoint;
class RunOutput;
struct Setup;

// 'setup', when given, is the scene's make_run_setup made beforehand (moved from).
int run_stages(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output = nullptr,
               const Checkpoint* restart = nullptr, Setup* setup = nullptr);

}  // namespace fabrica
