// Realisations of a triaxial test ([triaxial] realisations / seeds, docs/triaxial.md
// "Realisations"): the scene's whole test on each generated specimen, each into OUT/seed_<s>/
// as a run of its own (its series, fabric files, summary.csv, run.h5 and checkpoints), and
// OUT/summary.csv with every realisation's cases; each run finished is marked by the file
// OUT/<run>/finished, so that --restart OUT continues the ensemble; with consolidation_friction_cases, for each
// realisation also a consolidation at each of those mu_s (OUT/seed_<s>_consolidation_<mu>/),
// and OUT/consolidations.csv: the void ratio and Z of every consolidation. [parallel] groups splits the ranks into groups
// that run different realisations at once (MPI_Comm_split): a realisation's results are bit for
// bit those of running the scene with its seed alone on a group's number of ranks.
#pragma once
#include "io/serial/scene.hpp"
#include "parallel/mpi_context.hpp"

#include <functional>
#include <string>

namespace fabrica {

// One run of a scene on the ranks of 'mpi' into 'outdir' (apps/fabrica.cpp run_scene), from the
// checkpoint 'restart' if not empty, replacing an existing run.h5 if 'overwrite'.
using RunScene = std::function<int(const MpiContext& mpi, const Scene& scene, const std::string& outdir,
                                   const std::string& restart, bool overwrite)>;

// Whether the scene is an ensemble (several realisations, or consolidation frictions).
bool is_ensemble(const Scene& scene);

// The groups 'groups' ([parallel] groups; 0: "auto") makes of 'ranks' ranks for 'realisations'
// realisations; throws InputError naming the key and value if they cannot be made.
int ensemble_groups(const Scene& scene, int ranks);

// 'resume': continue the ensemble in 'outdir' (fabrica run --restart OUT): the runs marked
// finished there are kept, a run with a checkpoint continues from it (bit for bit, as any
// restart), the others start anew.
int run_ensemble(const MpiContext& mpi, const Scene& scene, const std::string& outdir, bool overwrite, bool resume,
                 const RunScene& run_scene);

}  // namespace fabrica
