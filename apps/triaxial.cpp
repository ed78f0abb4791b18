#include "apps/triaxial.hpp"

#include "apps/triaxial_sweep.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/mpi_domain.hpp"

#include <algorithm>

namespace fabrica {

StageResult TriaxialRun::resume(const StageCursor& at) {
  set_account(at);  // the contact law and damping are the simulation's, restored with it
  if (at.stage == kShear) return run(shear_stage(scene_, sim_.params().law.rolling_friction), kShear, &at);
  const StageSpec st = at.stage == kConsolidation ? consolidation_stage(scene_)
                                                  : equilibration_stage(scene_, sim_.params().law.rolling_friction);
  return run(st, at.stage, &at);
}

MpiDomainOptions domain_options(const Scene& scene) {
  MpiDomainOptions o;
  o.kind = scene.parallel.decomposition == "metis" ? DecompositionKind::Metis : DecompositionKind::Cartesian;
  o.rebalance_threshold = scene.parallel.rebalance_threshold;
  o.rebalance_interval = int(scene.parallel.rebalance_interval);
  o.balance_work = scene.parallel.cut == "work";
  o.balance = scene.parallel.balance;
  return o;
}

std::unique_ptr<Domain> make_domain(const MpiContext& mpi, const Scene& scene) {
  if (mpi.size() == 1) return nullptr;
  return std::make_unique<MpiDomain>(mpi.comm(), domain_options(scene));
}

Scene triaxial_setup_scene(const Scene& scene) {
  Scene sized = scene;
  for (real_t mur : scene.triaxial.rolling_friction_cases)
    sized.law.rolling_friction = std::max(sized.law.rolling_friction, mur);
  for (const StageSpec& st : scene.stages)
    if (const auto mur = st.law.get(&ContactLawParams::rolling_friction))
      sized.law.rolling_friction = std::max(sized.law.rolling_friction, *mur);
  // Damping shortens the critical time step: the estimate takes the strongest dashpots any
  // stage sets (a stage's damping_ratio_normal / _shear).
  sized.law = most_damped_law(sized.law, scene.stages);
  // Every material alike (a case's or stage's mu_r is every pair's).
  for (MaterialSpec& m : sized.materials) {
    m.law.rolling_friction = std::max(m.law.rolling_friction, sized.law.rolling_friction);
    m.law = most_damped_law(m.law, scene.stages);
  }
  for (Materials::Given& g : sized.material_pairs)
    if (const auto r = g.numbers.get(&ContactLawParams::rolling_friction))
      g.numbers.set(&ContactLawParams::rolling_friction, std::max(*r, sized.law.rolling_friction));
  return sized;
}

int run_triaxial(const MpiContext& mpi, const Scene& scene, const std::string& outdir, RunOutput* output,
                 const Checkpoint* restart, Setup* setup) {
  return TriaxialSweep(mpi, scene, outdir, output, restart, setup).run();
}

}  // namespace fabrica
