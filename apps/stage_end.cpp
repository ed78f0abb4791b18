#include "apps/stage_end.hpp"

#include <cmath>

namespace fabrica {

bool at_rest(const StageSpec& st, const EndProbe& at) {
  for (int k = 0; k < 3; ++k) {
    if (st.mode[k] != AxisMode::Stress) continue;
    const real_t target = at.targets[k];
    if (std::abs(at.m->stress(k, k) - target) > st.servo.stress_tolerance * target) return false;
  }
  for (int c = 0; c < 3; ++c) {
    if (st.shear_mode[c] != AxisMode::Stress) continue;
    const int i = kShearPairs[c][0], j = kShearPairs[c][1];
    const real_t s = 0.5 * (at.m->stress(i, j) + at.m->stress(j, i));
    if (std::abs(s - at.shear_targets[c]) > st.servo.stress_tolerance * at.shear_scale) return false;
  }
  return at.m->unbalanced < st.servo.unbalanced_tolerance;
}

bool stage_done(const StageSpec& st, const EndProbe& at) {
  const StageEnd& e = st.end;
  if (e.steps && at.steps >= *e.steps) return true;
  if (e.strain) {
    const real_t eps = at.eps[e.strain_axis];
    if (*e.strain > 0 ? eps >= *e.strain : eps <= *e.strain) return true;
  }
  if (e.q_p && at.m->p > 0 && at.m->q / at.m->p >= *e.q_p) return true;
  if (e.pressure && at.m->p >= *e.pressure) return true;
  if (e.cycles && at.cycles_done) return true;
  if (e.shear_strain) {
    const real_t g = at.gamma[e.shear_component];
    // Cyclic simple shear: either way (a single amplitude, the liquefaction criterion of
    // laboratory practice); otherwise the value's sign is the way.
    if (st.cyclic_shear() ? std::abs(g) >= std::abs(*e.shear_strain)
                          : (*e.shear_strain > 0 ? g >= *e.shear_strain : g <= *e.shear_strain))
      return true;
  }
  if (e.angle && at.angle_done) return true;
  return e.at_rest && at_rest(st, at);
}

}  // namespace fabrica
