#include "io/serial/stage_parse.hpp"

#include "core/errors.hpp"

#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <tuple>
#include <sstream>

namespace fabrica {
namespace {

std::string text(const toml::node& n) {
  if (n.is_floating_point() || n.is_integer()) return number_text(*n.value<double>(), 10);
  std::ostringstream s;
  n.visit([&](auto&& x) { s << x; });
  return s.str();
}

// One table of a stage ("stage[2]", "stage[2].end", "stage[2].control"): typed reads that
// remember the keys used, so that the others are refused.
class Table {
 public:
  Table(const toml::table* t, std::string file, std::string name)
      : t_(t), file_(std::move(file)), name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& why) const {
    throw InputError(file_ + ": " + name_ + (key.empty() ? "" : "." + key) + " = " + value + ": " + why);
  }
  const std::string& name() const { return name_; }
  bool has(const std::string& key) const { return t_ && t_->contains(key); }
  const toml::node* node(const std::string& key) {
    used_.insert(key);
    return t_ ? t_->get(key) : nullptr;
  }
  std::optional<real_t> number(const std::string& key) {
    const toml::node* n = node(key);
    if (!n) return std::nullopt;
    const std::optional<double> v = n->value<double>();
    if (!v || n->is_boolean()) fail(key, text(*n), "must be a number");
    if (!std::isfinite(*v)) fail(key, number_text(*v, 10), "must be a finite number");
    return *v;
  }
  std::optional<std::int64_t> integer(const std::string& key) {
    const toml::node* n = node(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) fail(key, text(*n), "must be an integer");
    return n->value<std::int64_t>();
  }
  std::optional<bool> boolean(const std::string& key) {
    const toml::node* n = node(key);
    if (!n) return std::nullopt;
    if (!n->is_boolean()) fail(key, text(*n), "must be true or false");
    return n->value<bool>();
  }
  std::optional<std::string> string(const std::string& key) {
    const toml::node* n = node(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(key, text(*n), "must be a string");
    return n->value<std::string>();
  }
  const toml::table* table(const std::string& key) {
    const toml::node* n = node(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail(key, text(*n), "must be a table");
    return n->as_table();
  }
  // A number that must satisfy 'ok'.
  real_t checked(const std::string& key, real_t v, bool ok, const std::string& why) const {
    if (!ok) fail(key, number_text(v, 10), why);
    return v;
  }
  void reject_unknown() const {
    if (!t_) return;
    for (auto&& [k, v] : *t_) {
      const std::string key(k.str());
      if (!used_.count(key)) fail(key, text(v), "unknown key in this table (see docs/scene.md, [[stage]])");
    }
  }

 private:
  const toml::table* t_;
  std::string file_, name_;
  std::set<std::string> used_;
};

const std::map<std::string, int> kTypes = {{"mixed", 0},
                                           {"isotropic", 1},
                                           {"anisotropic", 2},
                                           {"triaxial_compression", 3},
                                           {"triaxial_extension", 4},
                                           {"constant_p", 5},
                                           {"constant_volume", 6},
                                           {"true_triaxial", 7},
                                           {"cyclic_strain", 8},
                                           {"cyclic_stress", 9},
                                           {"hold", 10},
                                           {"simple_shear", 11},
                                           {"cyclic_simple_shear", 12},
                                           {"principal_rotation", 13}};
const char* const kTypeList =
    "\"mixed\", \"isotropic\", \"anisotropic\", \"triaxial_compression\", \"triaxial_extension\", "
    "\"constant_p\", \"constant_volume\", \"true_triaxial\", \"cyclic_strain\", \"cyclic_stress\", "
    "\"hold\", \"simple_shear\", \"cyclic_simple_shear\", \"principal_rotation\"";
constexpr int kMixed = 0, kHold = 10, kSimpleShear = 11, kCyclicShear = 12, kRotation = 13;
constexpr real_t kDegree = std::numbers::pi / 180;

real_t required_positive(Table& t, const char* key, const std::string& type) {
  const std::optional<real_t> v = t.number(key);
  if (!v) t.fail(key, "(missing)", "a stage of type \"" + type + "\" needs it");
  return t.checked(key, *v, *v > 0, "must be positive");
}

// control.axis_k = { stress = Pa } or { strain_rate = 1/s }, for the three axes.
void parse_axes(const toml::table* c, const std::string& file, const std::string& name, StageSpec& st) {
  Table C(c, file, name + ".control");
  for (int k = 0; k < 3; ++k) {
    const std::string key = "axis_" + std::to_string(k + 1);
    const toml::table* a = C.table(key);
    if (!a) C.fail(key, "(missing)", "give { stress = Pa } or { strain_rate = 1/s } for every axis");
    Table A(a, file, name + ".control." + key);
    const std::optional<real_t> s = A.number("stress"), r = A.number("strain_rate");
    if (s && r)
      C.fail(key, text(*c->get(key)), "contradictory controls: give stress or strain_rate on one axis, not both");
    if (!s && !r) C.fail(key, text(*c->get(key)), "give { stress = Pa } or { strain_rate = 1/s }");
    if (s) {
      A.checked("stress", *s, *s > 0, "must be positive (compression; a periodic packing carries no tension)");
      st.mode[k] = AxisMode::Stress;
      st.stress[k] = *s;
    } else {
      st.mode[k] = AxisMode::StrainRate;
      st.rate[k] = *r;
    }
    A.reject_unknown();
  }
  // control.shear_ij: optional; without it the component is held at a zero rate.
  for (int j = 0; j < 3; ++j) {
    const std::string key = std::string("shear_") + kShearNames[j];
    const toml::table* a = C.table(key);
    if (!a) continue;
    Table A(a, file, name + ".control." + key);
    const std::optional<real_t> s = A.number("stress"), r = A.number("strain_rate");
    if (s && r)
      C.fail(key, text(*c->get(key)),
             "contradictory controls: give stress or strain_rate on one shear component, not both");
    if (!s && !r) C.fail(key, text(*c->get(key)), "give { stress = Pa } or { strain_rate = 1/s } (engineering)");
    st.shear_mode[j] = s ? AxisMode::Stress : AxisMode::StrainRate;
    if (s) st.shear_stress[j] = *s;
    else st.shear_rate[j] = *r;
    A.reject_unknown();
  }
  C.reject_unknown();
}

// "12", "21", ... (or the integer 12): two different axes among 1, 2, 3, in the order given;
// nullopt (after failing) otherwise.
std::pair<int, int> axis_pair(Table& t, const std::string& key, const toml::node& n, const std::string& what) {
  std::string v;
  if (n.is_integer()) v = std::to_string(*n.value<std::int64_t>());
  else if (n.is_string()) v = *n.value<std::string>();
  if (v.size() != 2 || v[0] < '1' || v[0] > '3' || v[1] < '1' || v[1] > '3' || v[0] == v[1])
    t.fail(key, n.is_string() ? "\"" + v + "\"" : text(n),
           "must be two different axes among 1, 2, 3, as \"12\" (" + what + ")");
  return {v[0] - '1', v[1] - '1'};
}

// The shear component a shear end condition reads: end.shear_component, else the simple shear's
// plane, else the one shear component the stage controls (stress, or a non-zero rate).
int end_shear_component(Table& E, const StageSpec& st) {
  if (const toml::node* n = E.node("shear_component")) {
    if (!st.end.shear_strain) E.fail("shear_component", text(*n), "is used with shear_strain only");
    const auto [i, j] = axis_pair(E, "shear_component", *n, "the component of shear_strain");
    return shear_component(i, j);
  }
  if (st.shear_normal >= 0) return shear_component(st.shear_normal, st.shear_direction);
  int found = -1, count = 0;
  for (int c = 0; c < 3; ++c)
    if (st.shear_mode[c] == AxisMode::Stress || st.shear_rate[c] != 0) found = c, ++count;
  if (count != 1 && st.end.shear_strain)
    E.fail("shear_strain", number_text(*st.end.shear_strain, 10),
           std::string(count == 0 ? "this stage controls no shear component" : "this stage controls several") +
               ": name the one to watch with end.shear_component = \"12\", \"13\" or \"23\"");
  return std::max(found, 0);
}

// end.shear_strain (and the component it reads): a shear strain the stage drives the other way
// (or not at all) is refused.
void parse_shear_end(Table& E, StageSpec& st) {
  if (auto v = E.number("shear_strain"))
    st.end.shear_strain =
        E.checked("shear_strain", *v, *v != 0 && std::abs(*v) <= 10, "must be non-zero and lie in [-10, 10]");
  st.end.shear_component = end_shear_component(E, st);
  if (!st.end.shear_strain || st.cyclic_shear()) return;
  const int c = st.end.shear_component;
  if (st.shear_mode[c] != AxisMode::StrainRate) return;  // stress-controlled: either way
  const real_t drive = st.shear_rate[c];
  if (drive == 0 || drive * *st.end.shear_strain < 0)
    E.fail(
        "shear_strain", number_text(*st.end.shear_strain, 10),
        std::string("gamma_") + kShearNames[c] + " is driven " +
            (drive == 0 ? std::string("at a zero rate") : "the other way (rate " + number_text(drive, 10) + " 1/s)") +
            ": this shear strain is never reached");
}

void parse_end(Table& s, const std::string& file, StageSpec& st, bool cyclic) {
  const toml::table* e = s.table("end");
  Table E(e, file, s.name() + ".end");
  if (auto n = E.integer("steps")) {
    if (*n <= 0) E.fail("steps", std::to_string(*n), "must be positive");
    st.end.steps = *n;
  }
  if (auto v = E.number("strain")) {
    E.checked("strain", *v, *v != 0 && std::abs(*v) < 1, "must be non-zero and lie in (-1, 1)");
    st.end.strain = *v;
  }
  if (auto a = E.integer("strain_axis")) {
    if (*a < 1 || *a > 3) E.fail("strain_axis", std::to_string(*a), "must be 1, 2 or 3");
    if (!st.end.strain) E.fail("strain_axis", std::to_string(*a), "is used with strain only");
    st.end.strain_axis = int(*a - 1);
  }
  if (auto v = E.number("q_p")) st.end.q_p = E.checked("q_p", *v, *v > 0 && *v < 3, "must lie in (0, 3)");
  st.end.at_rest = E.boolean("at_rest").value_or(false);
  parse_shear_end(E, st);
  E.reject_unknown();
  st.end.cycles = cyclic;
  if (!st.end.steps && !st.end.strain && !st.end.q_p && !st.end.at_rest && !cyclic && !st.end.shear_strain &&
      !st.end.angle)
    s.fail("end", e ? text(*e) : "(missing)",
           st.shears() ? "no end condition: give end.shear_strain, end.steps, end.strain, end.q_p or end.at_rest = true"
                       : "no end condition: give end.steps, end.strain, end.q_p or end.at_rest = true");
  // A strain the stage's own control drives the other way never comes.
  if (st.end.strain && st.end.strain_axis == 0 && st.mode[0] == AxisMode::StrainRate &&
      st.path != StagePath::CyclicStrain && st.path != StagePath::CyclicStress) {
    const real_t drive = -st.rate[0];  // compression positive
    if (drive == 0 || drive * *st.end.strain < 0)
      E.fail("strain", number_text(*st.end.strain, 10),
             std::string("axis 1 is driven ") +
                 (drive > 0       ? "in compression (eps_1 grows)"
                      : drive < 0 ? "in extension (eps_1 falls)"
                                  : "at a zero rate") +
                 ": this strain is never reached");
  }
}

// The controls of the types that existed before the shear paths ("mixed" through "hold").
void parse_axes_type(Table& s, const toml::table* t, const std::string& file, const std::string& type, int ty,
                     StageSpec& st) {
  if (ty == kMixed) {
    const toml::table* c = s.table("control");
    if (!c) s.fail("control", "(missing)", "a stage of type \"mixed\" needs control.axis_1, axis_2 and axis_3");
    parse_axes(c, file, st.where, st);
  } else if (s.has("control")) {
    s.fail("control", text(*t->get("control")),
           "is used with type = \"mixed\" only (type \"" + type + "\" sets the controls itself)");
  }
  if (ty == 1) {
    const real_t p = required_positive(s, "pressure", type);
    st.stress = Vec3::Constant(p);
  } else if (ty == 2) {
    const toml::node* n = s.node("stress");
    const toml::array* a = n ? n->as_array() : nullptr;
    if (!n) s.fail("stress", "(missing)", "a stage of type \"anisotropic\" needs stress = [s11, s22, s33] (Pa)");
    if (!a || a->size() != 3) s.fail("stress", text(*n), "must be an array of three positive numbers (Pa)");
    for (int k = 0; k < 3; ++k) {
      const std::optional<double> v = a->get(k)->value<double>();
      if (!v || a->get(k)->is_boolean() || !std::isfinite(*v) || *v <= 0)
        s.fail("stress", text(*n), "must be an array of three positive numbers (Pa)");
      st.stress[k] = *v;
    }
  } else if (ty == kHold) {
    st.mode = {AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};
  } else if (ty >= 3 && ty <= 9) {
    if (ty != 6) st.pressure = required_positive(s, "pressure", type);
    const real_t rate = required_positive(s, "axial_strain_rate", type);
    st.mode = {AxisMode::StrainRate, AxisMode::Stress, AxisMode::Stress};
    st.rate = Vec3(ty == 4 ? rate : -rate, 0, 0);
    st.stress = Vec3(0, st.pressure, st.pressure);
    if (ty == 5) st.path = StagePath::ConstantP;
    if (ty == 6) {
      st.path = StagePath::ConstantVolume;
      st.mode = {AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};
      st.rate = Vec3(-rate, 0.5 * rate, 0.5 * rate);
      st.stress = Vec3::Zero();
    }
    if (ty == 7) {
      st.path = StagePath::TrueTriaxial;
      const std::optional<real_t> b = s.number("b");
      if (!b) s.fail("b", "(missing)", "a stage of type \"true_triaxial\" needs b = (s2 - s3) / (s1 - s3)");
      st.b = s.checked("b", *b, *b >= 0 && *b <= 1, "must lie in [0, 1]");
    }
    if (ty == 8 || ty == 9) {
      st.path = ty == 8 ? StagePath::CyclicStrain : StagePath::CyclicStress;
      const real_t amp = required_positive(s, "amplitude", type);
      if (ty == 8) s.checked("amplitude", amp, amp < 0.5, "must lie in (0, 0.5) (an amplitude of eps_1)");
      if (ty == 9)
        s.checked("amplitude", amp, amp < st.pressure,
                  "must lie below pressure = " + number_text(st.pressure, 10) +
                      " Pa (q = -amplitude needs s11 = pressure - amplitude > 0)");
      st.amplitude = amp;
      const std::optional<std::int64_t> n = s.integer("cycles");
      if (!n) s.fail("cycles", "(missing)", "a cyclic stage needs the number of cycles");
      if (*n < 1) s.fail("cycles", std::to_string(*n), "must be at least 1");
      st.cycles = *n;
    }
  }
}

// "simple_shear" and "cyclic_simple_shear": the plane, the rate, the normal axis (a pressure or
// fixed: constant volume) and the lateral axes (fixed, or at the pressure).
void parse_simple_shear(Table& s, const toml::table* t, const std::string& type, int ty, StageSpec& st) {
  const std::optional<real_t> rate = s.number("shear_strain_rate");
  if (!rate) s.fail("shear_strain_rate", "(missing)", "a stage of type \"" + type + "\" needs it (1/s, engineering)");
  if (ty == kCyclicShear)
    s.checked("shear_strain_rate", *rate, *rate > 0, "must be positive (the first half-cycle shears forward)");
  else s.checked("shear_strain_rate", *rate, *rate != 0, "must be non-zero (its sign is the way)");
  st.shear_normal = 0, st.shear_direction = 1;
  if (const toml::node* n = s.node("plane"))
    std::tie(st.shear_normal, st.shear_direction) =
        axis_pair(s, "plane", *n, "the shear plane's normal axis, then the axis it slides along");
  const bool cv = s.boolean("constant_volume").value_or(false);
  const std::string lateral = s.string("lateral").value_or("fixed");
  if (lateral != "fixed" && lateral != "pressure")
    s.fail("lateral", "\"" + lateral + "\"", "must be \"fixed\" or \"pressure\"");
  if (cv && s.has("pressure"))
    s.fail("pressure", text(*t->get("pressure")),
           "contradictory controls: constant_volume = true holds the shear plane's normal axis fixed, not at a "
           "pressure; give one of them");
  if (cv && lateral == "pressure")
    s.fail("lateral", "\"pressure\"", "contradictory controls: constant_volume = true holds every normal axis fixed");
  if (!cv) {
    const std::optional<real_t> p = s.number("pressure");
    if (!p)
      s.fail("pressure", "(missing)",
             "a stage of type \"" + type + "\" needs the normal stress on its shear plane (or constant_volume = true)");
    st.pressure = s.checked("pressure", *p, *p > 0, "must be positive");
  }
  st.mode = {AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate};
  for (int k = 0; k < 3; ++k)
    if ((k == st.shear_normal && !cv) || (k != st.shear_normal && lateral == "pressure")) {
      st.mode[k] = AxisMode::Stress;
      st.stress[k] = st.pressure;
    }
  st.shear_rate[shear_component(st.shear_normal, st.shear_direction)] = *rate;
  st.path = StagePath::SimpleShear;
  if (ty != kCyclicShear) return;
  const std::optional<real_t> amp = s.number("amplitude"), amp_s = s.number("amplitude_stress");
  if (amp && amp_s)
    s.fail("amplitude_stress", number_text(*amp_s, 10),
           "contradictory controls: give amplitude (a shear strain) or amplitude_stress (Pa), not both");
  if (!amp && !amp_s)
    s.fail("amplitude", "(missing)",
           "a stage of type \"cyclic_simple_shear\" needs amplitude (a shear strain) or amplitude_stress (Pa)");
  if (amp) st.amplitude = s.checked("amplitude", *amp, *amp > 0 && *amp < 1, "must lie in (0, 1) (a shear strain)");
  if (amp_s) st.amplitude = s.checked("amplitude_stress", *amp_s, *amp_s > 0, "must be positive (Pa)");
  st.path = amp ? StagePath::CyclicShearStrain : StagePath::CyclicShearStress;
  const std::optional<std::int64_t> n = s.integer("cycles");
  if (!n) s.fail("cycles", "(missing)", "a cyclic stage needs the number of cycles");
  if (*n < 1) s.fail("cycles", std::to_string(*n), "must be at least 1");
  st.cycles = *n;
}

// "principal_rotation": p, q and b held, the major axis turning in the 1-2 plane.
void parse_rotation(Table& s, const std::string& type, StageSpec& st) {
  st.pressure = required_positive(s, "pressure", type);
  st.q = required_positive(s, "q", type);
  const std::optional<real_t> b = s.number("b");
  if (!b) s.fail("b", "(missing)", "a stage of type \"principal_rotation\" needs b = (s2 - s3) / (s1 - s3)");
  st.b = s.checked("b", *b, *b >= 0 && *b <= 1, "must lie in [0, 1]");
  const std::optional<real_t> w = s.number("rotation_rate");
  if (!w) s.fail("rotation_rate", "(missing)", "a stage of type \"principal_rotation\" needs it (degrees/s)");
  st.rotation_rate =
      s.checked("rotation_rate", *w, *w != 0, "must be non-zero (degrees/s; its sign is the way)") * kDegree;
  st.angle = required_positive(s, "angle", type) * kDegree;
  if (auto a = s.number("start_angle"))
    st.start_angle = s.checked("start_angle", *a, *a > -90 && *a <= 90, "must lie in (-90, 90] (degrees)") * kDegree;
  const Vec3 sp = principal_stresses(st.pressure, st.q, st.b);
  const real_t s3 = sp[2];
  if (s3 <= 0)
    s.fail("q", number_text(st.q, 10),
           "is too large for pressure = " + number_text(st.pressure, 10) + " Pa and b = " + number_text(st.b, 10) +
               ": the minor principal stress would be " + number_text(s3, 6) + " Pa (a packing carries no tension)");
  st.mode = {AxisMode::Stress, AxisMode::Stress, AxisMode::Stress};
  st.shear_mode[0] = AxisMode::Stress;
  const Mat3 start = rotated_stress(sp, st.start_angle);
  st.stress = start.diagonal();
  st.shear_stress = Vec3(start(0, 1), 0, 0);
  st.path = StagePath::PrincipalRotation;
  st.end.angle = true;
}

// The contact parameters, the servo and the limits of a stage (every type).
void parse_settings(Table& s, StageSpec& st, int ty) {
  for (const LawParameter& p : kLawParameters)  // the contact parameters a stage may set
    if (p.stage)
      if (auto v = s.number(p.key))
        st.law.set(p.member, s.checked(p.key, *v, within(p.bound, *v), bound_text(p.bound)));
  if (auto v = s.number("local_damping"))
    st.local_damping = s.checked("local_damping", *v, *v >= 0 && *v < 1, "must lie in [0, 1)");
  st.reset_strain = s.boolean("reset_strain").value_or(false);
  st.fabric = StageFabric::AtRows;  // with [fabric] enabled: at every row of every stage
  st.track_peak = true;             // the peak q/p and stress error of stages.csv
  ServoSettings& sv = st.servo;
  if (auto v = s.number("max_strain_rate"))
    sv.max_strain_rate = s.checked("max_strain_rate", *v, *v > 0, "must be positive");
  if (auto v = s.number("servo_relaxation"))
    sv.relaxation = s.checked("servo_relaxation", *v, *v > 0 && *v <= 0.5, "must lie in (0, 0.5]");
  sv.integral_relaxation = std::min(sv.integral_relaxation, sv.relaxation);
  if (auto n = s.integer("servo_interval")) {
    if (*n <= 0) s.fail("servo_interval", std::to_string(*n), "must be positive");
    sv.interval = *n;
  }
  if (auto v = s.number("stress_tolerance"))
    sv.stress_tolerance = s.checked("stress_tolerance", *v, *v > 0, "must be positive");
  if (auto v = s.number("unbalanced_tolerance"))
    sv.unbalanced_tolerance = s.checked("unbalanced_tolerance", *v, *v > 0, "must be positive");
  if (auto n = s.integer("max_steps")) {
    if (*n <= 0) s.fail("max_steps", std::to_string(*n), "must be positive");
    st.max_steps = *n;
  }
  if (st.end.steps && *st.end.steps > st.max_steps)
    s.fail("end.steps", std::to_string(*st.end.steps),
           "exceeds max_steps = " + std::to_string(st.max_steps) + " (raise max_steps)");
  for (int k = 0; k < 3; ++k)
    if (st.mode[k] == AxisMode::StrainRate && std::abs(st.rate[k]) > sv.max_strain_rate)
      s.fail(ty == kMixed ? "control.axis_" + std::to_string(k + 1) + ".strain_rate" : std::string("axial_strain_rate"),
             number_text(std::abs(st.rate[k]), 10),
             "exceeds max_strain_rate = " + number_text(sv.max_strain_rate, 10) + " 1/s");
  for (int c = 0; c < 3; ++c)
    if (st.shear_mode[c] == AxisMode::StrainRate && std::abs(st.shear_rate[c]) > sv.max_strain_rate)
      s.fail(ty == kMixed ? std::string("control.shear_") + kShearNames[c] + ".strain_rate"
                          : std::string("shear_strain_rate"),
             number_text(std::abs(st.shear_rate[c]), 10),
             "exceeds max_strain_rate = " + number_text(sv.max_strain_rate, 10) + " 1/s");
}

StageSpec parse_one(const toml::table* t, const std::string& file, int index) {
  StageSpec st;
  st.where = "stage[" + std::to_string(index) + "]";
  Table s(t, file, st.where);
  const std::optional<std::string> type = s.string("type");
  if (!type) s.fail("type", "(missing)", std::string("every stage needs a type: one of ") + kTypeList);
  const auto it = kTypes.find(*type);
  if (it == kTypes.end())
    s.fail("type", "\"" + *type + "\"", std::string("unknown stage type (expected one of ") + kTypeList + ")");
  st.name = s.string("name").value_or(*type);
  if (st.name.empty() || st.name.find_first_of(",\n\"") != std::string::npos)
    s.fail("name", "\"" + st.name + "\"", "must be a non-empty name without commas, quotes or newlines");
  const int ty = it->second;
  parse_axes_type(s, t, file, *type, ty, st);
  if (ty == kSimpleShear || ty == kCyclicShear) parse_simple_shear(s, t, *type, ty, st);
  if (ty == kRotation) parse_rotation(s, *type, st);
  auto unused = [&](const char* k, bool used) {
    if (!used && s.has(k)) s.fail(k, text(*t->get(k)), "is not used by a stage of type \"" + *type + "\"");
  };
  const bool simple = ty == kSimpleShear || ty == kCyclicShear;
  unused("b", ty == 7 || ty == kRotation);
  unused("amplitude", ty == 8 || ty == 9 || ty == kCyclicShear);
  unused("cycles", ty == 8 || ty == 9 || ty == kCyclicShear);
  unused("pressure", ty == 1 || (ty >= 3 && ty <= 9 && ty != 6) || simple || ty == kRotation);
  unused("axial_strain_rate", ty >= 3 && ty <= 9);
  unused("stress", ty == 2);
  for (const char* k : {"shear_strain_rate", "plane", "constant_volume", "lateral"}) unused(k, simple);
  unused("amplitude_stress", ty == kCyclicShear);
  for (const char* k : {"q", "rotation_rate", "angle", "start_angle"}) unused(k, ty == kRotation);
  parse_end(s, file, st, ty == 8 || ty == 9 || ty == kCyclicShear);
  parse_settings(s, st, ty);
  s.reject_unknown();
  return st;
}

}  // namespace

std::vector<StageSpec> parse_stages(const toml::node* stages, const std::string& path) {
  std::vector<StageSpec> out;
  if (!stages) return out;
  const toml::array* a = stages->as_array();
  if (!a || a->empty() || !a->is_array_of_tables())
    throw InputError(path + ": stage = " + text(*stages) +
                     ": the loading stages are an array of tables, each [[stage]] (docs/scene.md)");
  int i = 0;
  for (const toml::node& n : *a) out.push_back(parse_one(n.as_table(), path, ++i));
  return out;
}

}  // namespace fabrica
