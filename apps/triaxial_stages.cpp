#include "apps/triaxial_stages.hpp"

namespace fabrica {

namespace {
StageSpec isotropic(const Scene& scene, const char* name) {
  const TriaxialSpec& tx = scene.triaxial;
  StageSpec st;
  st.name = name;
  st.where = "[triaxial]";
  st.stress = Vec3::Constant(tx.confining_pressure);
  st.end.at_rest = true;
  st.local_damping = tx.preparation_damping;
  st.servo = tx.servo_settings();
  st.max_steps = tx.max_stage_steps;
  return st;
}
}  // namespace

StageSpec consolidation_stage(const Scene& scene) {
  StageSpec st = isotropic(scene, "consolidation");
  st.law.set(&ContactLawParams::friction, scene.triaxial.consolidation_friction);
  st.law.set(&ContactLawParams::rolling_friction, 0);
  st.law.set(&ContactLawParams::twisting_friction, 0);  // no rotational resistance, as for rolling
  st.fabric = StageFabric::AtEnd;
  return st;
}

StageSpec equilibration_stage(const Scene& scene, real_t rolling_friction) {
  StageSpec st = isotropic(scene, "equilibration");
  st.own_law = true;  // each material's friction
  st.law.set(&ContactLawParams::rolling_friction, rolling_friction);
  // Twisting resistance as rolling resistance: the case's from the equilibration of a case (the
  // scene's own), else from the shear.
  if (scene.triaxial.equilibration != TriaxialSpec::Equilibration::Case)
    st.law.set(&ContactLawParams::twisting_friction, 0.0);
  return st;
}

real_t equilibration_rolling_friction(const Scene& scene, real_t case_rolling_friction) {
  return scene.triaxial.equilibration == TriaxialSpec::Equilibration::Case ? case_rolling_friction : 0;
}

StageSpec shear_stage(const Scene& scene, real_t rolling_friction) {
  const TriaxialSpec& tx = scene.triaxial;
  StageSpec st;
  if (tx.equilibration != TriaxialSpec::Equilibration::Case) {  // switched here, not before
    st.own_law = true;                                          // each material's friction and twisting friction
    st.law.set(&ContactLawParams::rolling_friction, rolling_friction);
  }
  st.name = "shear";
  st.where = "[triaxial]";
  st.mode = {AxisMode::StrainRate, AxisMode::Stress, AxisMode::Stress};
  st.rate = Vec3(-tx.axial_strain_rate, 0, 0);
  st.stress = Vec3(0, tx.confining_pressure, tx.confining_pressure);
  st.pressure = tx.confining_pressure;
  st.end.strain = tx.axial_strain;
  st.local_damping = tx.shear_damping;
  st.reset_strain = true;
  st.fabric = StageFabric::AtRows;
  st.track_peak = true;
  st.servo = tx.servo_settings();
  st.max_steps = tx.max_stage_steps;
  return st;
}

}  // namespace fabrica
