#include "apps/stage_cursor.hpp"

#include "io/mpi/state_fields.hpp"

namespace fabrica {

void write_result(FieldWriter& w, const StageResult& r) {
  w.i64("result.steps", r.steps);
  write_macro(w, r.state);
  w.vec3("result.strain", r.strain).f64("result.peak_q_p", r.peak_q_p);
  w.f64("result.peak_eps1", r.peak_eps1).f64("result.max_lateral_error", r.max_lateral_error);
  w.f64("result.max_energy_error", r.max_energy_error);
}

StageResult read_result(FieldReader& r) {
  StageResult s;
  s.steps = r.i64("result.steps");
  s.state = read_macro(r);
  s.strain = r.vec3("result.strain");
  s.peak_q_p = r.f64("result.peak_q_p");
  s.peak_eps1 = r.f64("result.peak_eps1");
  s.max_lateral_error = r.f64("result.max_lateral_error");
  s.max_energy_error = r.f64("result.max_energy_error");
  return s;
}

void write_cursor(FieldWriter& w, const StageCursor& c) {
  w.i32("cursor.stage", c.stage).i64("cursor.k", c.k);
  w.vec3("cursor.servo_integral", c.control.servo_integral);
  w.i32("cursor.direction", c.control.direction).i64("cursor.reversals", c.control.reversals);
  w.f64("cursor.last_servo", c.last_servo);
  write_result(w, c.result);
  w.vec3("cursor.l0", c.l0).vec3("cursor.stage_l0", c.stage_l0);
  w.f64("cursor.input_positive", c.input_positive).f64("cursor.input_seen", c.input_seen);
  // A run whose cell has been sheared: its strain references and the shear servo (absent from
  // every other checkpoint, so that those keep their bytes and older ones read as before).
  if (c.sheared_lengths.isZero()) return;
  w.vec3("cursor.sheared_lengths", c.sheared_lengths).mat3("cursor.e0", c.e0).mat3("cursor.stage_e0", c.stage_e0);
  w.vec3("cursor.shear_integral", c.control.shear_integral).vec3("cursor.result_gamma", c.result.gamma);
}

StageCursor read_cursor(FieldReader& r) {
  StageCursor c;
  c.stage = r.i32("cursor.stage");
  c.k = r.i64("cursor.k");
  c.control.servo_integral = r.vec3("cursor.servo_integral");
  c.control.direction = r.i32("cursor.direction");
  c.control.reversals = r.i64("cursor.reversals");
  c.last_servo = r.f64("cursor.last_servo");
  c.result = read_result(r);
  c.l0 = r.vec3("cursor.l0");
  c.stage_l0 = r.vec3("cursor.stage_l0");
  c.input_positive = r.f64("cursor.input_positive");
  c.input_seen = r.f64("cursor.input_seen");
  if (!r.next_is("cursor.sheared_lengths")) return c;
  c.sheared_lengths = r.vec3("cursor.sheared_lengths");
  c.e0 = r.mat3("cursor.e0");
  c.stage_e0 = r.mat3("cursor.stage_e0");
  c.control.shear_integral = r.vec3("cursor.shear_integral");
  c.result.gamma = r.vec3("cursor.result_gamma");
  return c;
}

}  // namespace fabrica
