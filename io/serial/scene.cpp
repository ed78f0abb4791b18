#include "io/serial/scene.hpp"

#include "core/errors.hpp"
#include "core/fault.hpp"
#include "io/serial/memory_check.hpp"
#include "io/serial/stage_parse.hpp"

#include "core/coarse_grain.hpp"
#include "core/restitution.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "io/serial/demo_scene.inc"  // kDemoScene: the text of examples/demo.toml (generated)

namespace fabrica {
namespace {

// Reads one table, remembering which keys were used so that unknown keys can be refused.
class Section {
 public:
  Section(const toml::table* t, std::string file, std::string name)
      : t_(t), file_(std::move(file)), name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& why) const {
    throw InputError(file_ + ": [" + name_ + "] " + key + " = " + value + ": " + why);
  }

  bool has(const std::string& key) const { return t_ && t_->contains(key); }

  std::optional<real_t> number(const std::string& key) {
    used_.insert(key);
    if (!t_) return std::nullopt;
    const toml::node* n = t_->get(key);
    if (!n) return std::nullopt;
    std::optional<double> v = n->value<double>();
    if (!v || n->is_boolean()) fail(key, node_text(*n), "must be a number");
    if (!std::isfinite(*v)) fail(key, number_text(*v, 10), "must be a finite number");
    return *v;
  }
  real_t number(const std::string& key, real_t def) { return number(key).value_or(def); }

  std::optional<std::int64_t> integer(const std::string& key) {
    used_.insert(key);
    if (!t_) return std::nullopt;
    const toml::node* n = t_->get(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) fail(key, node_text(*n), "must be an integer");
    return n->value<std::int64_t>();
  }

  std::optional<bool> boolean(const std::string& key) {
    used_.insert(key);
    if (!t_) return std::nullopt;
    const toml::node* n = t_->get(key);
    if (!n) return std::nullopt;
    if (!n->is_boolean()) fail(key, node_text(*n), "must be true or false");
    return n->value<bool>();
  }

  std::optional<std::string> string(const std::string& key) {
    used_.insert(key);
    if (!t_) return std::nullopt;
    const toml::node* n = t_->get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(key, node_text(*n), "must be a string");
    return n->value<std::string>();
  }

  std::optional<Vec3> vec3(const std::string& key) {
    used_.insert(key);
    if (!t_) return std::nullopt;
    const toml::node* n = t_->get(key);
    if (!n) return std::nullopt;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) fail(key, node_text(*n), "must be an array of three numbers");
    Vec3 v;
    for (int k = 0; k < 3; ++k) {
      std::optional<double> x = a->get(k)->value<double>();
      if (!x || a->get(k)->is_boolean()) fail(key, node_text(*n), "must be an array of three numbers");
      if (!std::isfinite(*x)) fail(key, node_text(*n), "must hold finite numbers");
      v[k] = *x;
    }
    return v;
  }

  void mark_used(const std::string& key) { used_.insert(key); }

  void reject_unknown() const {
    if (!t_) return;
    for (auto&& [k, v] : *t_) {
      const std::string key(k.str());
      if (!used_.count(key)) fail(key, node_text(v), "unknown key in this table (see docs/scene.md)");
    }
  }

  static std::string node_text(const toml::node& n) {
    if (n.is_floating_point() || n.is_integer()) return number_text(*n.value<double>(), 10);
    if (const toml::array* a = n.as_array()) {  // on one line: [0, 0, 1]
      std::string t = "[";
      for (std::size_t k = 0; k < a->size(); ++k) t += (k ? ", " : "") + node_text(*a->get(k));
      return t + "]";
    }
    std::ostringstream s;
    n.visit([&](auto&& x) { s << x; });
    return s.str();
  }

 private:
  const toml::table* t_;
  std::string file_, name_;
  std::set<std::string> used_;
};

void require(Section& s, const std::string& key, real_t v, bool ok, const std::string& why) {
  if (!ok) s.fail(key, number_text(v, 10), why);
}

// ---- Restitution and walls (issue 13; docs/scene.md "Restitution" and "Walls") -------------

// restitution_normal / restitution_shear of a [contact] (or [[wall]]) table, converted to the
// damping ratios of the law (core/restitution.hpp); refused together with a damping key.
void parse_restitution(Section& s, ContactLawParams& law) {
  struct Key {
    const char* e;
    const char* ratio;
    const char* rate;
    real_t* beta;
    real_t* eta;
    bool normal;
  };
  const Key keys[2] = {{"restitution_normal", "damping_ratio_normal", "damping_rate_normal", &law.damping_ratio_n,
                        &law.damping_rate_n, true},
                       {"restitution_shear", "damping_ratio_shear", "damping_rate_shear", &law.damping_ratio_s,
                        &law.damping_rate_s, false}};
  for (const Key& k : keys) {
    const auto e = s.number(k.e);
    if (!e) continue;
    if (s.has(k.ratio) || s.has(k.rate))
      s.fail(k.e, number_text(*e, 10),
             std::string("give ") + k.e + " or " + (s.has(k.ratio) ? k.ratio : k.rate) + ", not both");
    require(s, k.e, *e, *e > 0 && *e <= 1, "must lie in (0, 1] (a coefficient of restitution)");
    if (law.model == ContactModel::HertzMindlin)
      *k.beta = k.normal ? hertz_damping_for_restitution(*e) : shear_damping_ratio_for_restitution(*e);
    else *k.beta = k.normal ? damping_ratio_for_restitution(*e) : shear_damping_ratio_for_restitution(*e);
    *k.eta = 0;
  }
  // Hertz-Mindlin without restitution_shear nor damping_ratio_shear: the tangential dashpot
  // has the normal one's beta (LIGGGHTS, Tsuji et al. 1992).
  if (law.model == ContactModel::HertzMindlin && s.has("restitution_normal") && !s.has("restitution_shear") &&
      !s.has("damping_ratio_shear"))
    law.damping_ratio_s = law.damping_ratio_n;
}

// The keys of one model that another cannot use, refused with the key and the model
// (kLawParameters' 'model').
void refuse_other_model_keys(Section& s, const toml::table* t, const ContactLawParams& law) {
  if (!t) return;
  const ForModel mine = law.model == ContactModel::HertzMindlin ? ForModel::HertzMindlin : ForModel::Linear;
  for (const LawParameter& p : kLawParameters) {
    if (!p.key || p.model == ForModel::Any || p.model == mine || !s.has(p.key)) continue;
    s.fail(p.key, Section::node_text(*t->get(p.key)),
           p.model == ForModel::Linear
               ? "is a parameter of model = \"linear\"; model = \"hertz_mindlin\" takes its stiffness "
                 "from youngs_modulus and poisson_ratio, its dashpots from restitution_normal or damping_ratio_*"
               : "is a parameter of model = \"hertz_mindlin\"; the linear law takes k_n from youngs_modulus or "
                 "normal_stiffness and k_s from stiffness_ratio");
  }
}

// The law's numbers a [contact] table (wall = false) or a [[wall]] table (wall = true) gives,
// over the declared list (core/contact/params.hpp kLawParameters): each checked by its bound
// and put in 'law' (a damping ratio also setting its rate form to 0), after the rules between
// keys: another model's keys refused, youngs_modulus or normal_stiffness (which sets the
// stiffness mode), a damping ratio or its rate, rolling_damping with "epsd" only. Returns
// whether any was given.
bool parse_law_numbers(Section& s, const toml::table* t, ContactLawParams& law, bool wall) {
  refuse_other_model_keys(s, t, law);
  const auto both = [&](const char* a, const char* b, const std::string& why) {
    if (s.has(a) && s.has(b)) s.fail(b, Section::node_text(*t->get(b)), why);
  };
  both("youngs_modulus", "normal_stiffness", "give either youngs_modulus or normal_stiffness, not both");
  both("damping_ratio_normal", "damping_rate_normal", "give damping_ratio_normal or damping_rate_normal, not both");
  both("damping_ratio_shear", "damping_rate_shear", "give damping_ratio_shear or damping_rate_shear, not both");
  if (s.has("rolling_damping") && law.rolling_model != RollingModel::Epsd)
    s.fail("rolling_damping", Section::node_text(*t->get("rolling_damping")),
           "is the dashpot of rolling_model = \"epsd\" only");
  bool given = false;
  for (const LawParameter& p : kLawParameters) {
    if (!p.key || (wall && !p.wall)) continue;
    if (p.model != ForModel::Any && (p.model == ForModel::HertzMindlin) != (law.model == ContactModel::HertzMindlin))
      continue;  // refused above if given
    const auto v = s.number(p.key);
    if (!v) continue;
    std::string why = bound_text(p.bound);
    if (p.member == &ContactLawParams::rolling_damping) why += " (a fraction of the critical rolling damping)";
    require(s, p.key, *v, within(p.bound, *v), why);
    law.*p.member = *v;
    if (p.clears) law.*p.clears = 0;
    given = true;
  }
  if (s.has("normal_stiffness")) law.stiffness_mode = NormalStiffnessMode::Direct;
  else if (s.has("youngs_modulus")) law.stiffness_mode = NormalStiffnessMode::Deformability;
  return given;
}

// The [contact] keys a [[wall]] table may give to replace the scene's for that wall.
void parse_wall_law(Section& W, const toml::table* t, WallSpec& w) {
  const bool given = parse_law_numbers(W, t, w.law, true);
  parse_restitution(W, w.law);
  w.own_law = w.own_law || given || W.has("restitution_normal") || W.has("restitution_shear");
}

// The names of the scene's materials, for a message.
std::string material_names(const Scene& sc) {
  std::string t = "the scene's: ";
  for (std::size_t k = 0; k < sc.materials.size(); ++k) t += (k ? ", \"" : "\"") + sc.materials[k].name + "\"";
  return t;
}

// [[material]] tables (docs/scene.md, "Materials"): each a name, the spheres it is (a data
// file's atom type, or a fraction of the generated spheres), their density, and the law keys
// it gives anew: those a [[wall]] may replace (kLawParameters 'wall') and the restitutions.
void parse_materials(const toml::node* node, const std::string& path, Scene& sc) {
  if (!node) return;
  const toml::array* a = node->as_array();
  if (!a || !a->is_array_of_tables() || a->empty())
    throw InputError(path + ": material = " + Section::node_text(*node) +
                     ": materials are tables [[material]] (docs/scene.md, \"Materials\")");
  if (a->size() > kMaxMaterials)
    throw InputError(path + ": [[material]]: " + std::to_string(a->size()) + " tables, more than the " +
                     std::to_string(kMaxMaterials) + " materials a scene may have");
  const bool file = sc.source == ParticleSource::File;
  real_t total = 0;
  for (std::size_t k = 0; k < a->size(); ++k) {
    const toml::table* t = a->get(k)->as_table();
    Section M(t, path, "material #" + std::to_string(k + 1));
    MaterialSpec m;
    const auto name = M.string("name");
    if (!name || name->empty()) M.fail("name", name ? "\"\"" : "(missing)", "a material needs a name");
    for (const MaterialSpec& o : sc.materials)
      if (o.name == *name) M.fail("name", "\"" + *name + "\"", "names another [[material]] too");
    m.name = *name;
    if (const auto ty = M.integer("type")) {
      if (!file) M.fail("type", std::to_string(*ty), "is the atom type of a data file: used with source = \"file\"");
      if (*ty < 1) M.fail("type", std::to_string(*ty), "must be a positive integer (a LAMMPS atom type)");
      for (const MaterialSpec& o : sc.materials)
        if (o.type == *ty) M.fail("type", std::to_string(*ty), "is the type of [[material]] \"" + o.name + "\" too");
      m.type = *ty;
    }
    if (const auto f = M.number("fraction")) {
      if (file)
        M.fail("fraction", number_text(*f, 10),
               "is a share of generated spheres: with source = \"file\" give the data file's atom type (type)");
      require(M, "fraction", *f, *f > 0 && *f <= 1, "must lie in (0, 1] (a share of the spheres by number)");
      m.fraction = *f;
      total += *f;
    }
    m.density = sc.density;
    if (const auto d = M.number("density")) {
      if (file) M.fail("density", number_text(*d, 10), "is given per sphere by the data file (its density column)");
      require(M, "density", *d, *d > 0, "must be positive (kg/m^3)");
      m.density = *d;
    }
    m.law = sc.law;
    // A material gives the keys a wall may give (the elastic constants, friction, dashpot ratios);
    // the damping rates and rolling_damping are the scene's ([contact]).
    for (const char* key : {"damping_rate_normal", "damping_rate_shear", "rolling_damping", "model", "rolling_model"})
      if (M.has(key))
        M.fail(key, Section::node_text(*t->get(key)), "is a [contact] key shared by every material; give it there");
    parse_law_numbers(M, t, m.law, true);
    parse_restitution(M, m.law);
    if (!sc.materials.empty() && m.law.model == ContactModel::Linear &&
        m.law.stiffness_mode != sc.materials[0].law.stiffness_mode) {
      const bool direct = m.law.stiffness_mode == NormalStiffnessMode::Direct;
      const char* key = direct ? "normal_stiffness" : "youngs_modulus";
      M.fail(key, M.has(key) ? Section::node_text(*t->get(key)) : "(from [contact])",
             std::string("mixes the ways of giving the linear law's stiffness: [[material]] \"") +
                 sc.materials[0].name + "\" takes k_n from " + (direct ? "youngs_modulus" : "normal_stiffness") +
                 "; every material gives youngs_modulus, or every one normal_stiffness");
    }
    M.reject_unknown();
    sc.materials.push_back(m);
  }
  // Each sphere of exactly one material.
  std::size_t spheres = 0;
  for (const MaterialSpec& m : sc.materials) spheres += m.spheres();
  if (spheres == 0)
    throw InputError(path + ": [[material]]: no material is given to spheres: give each sphere material " +
                     (file ? "the data file's atom type (type = N)" : "its share of the generated spheres (fraction)"));
  if (!file && std::abs(total - 1.0) > 1e-9)
    throw InputError(path + ": [[material]] fraction: the fractions add up to " + number_text(total, 10) +
                     ", not 1 (every generated sphere is of one material)");
}

// [[material_pair]] tables: the friction coefficients and dashpots of the contacts of two
// materials, replacing the mixing rule (as LIGGGHTS' peratomtypepair).
void parse_material_pairs(const toml::node* node, const std::string& path, Scene& sc) {
  if (!node) return;
  const toml::array* a = node->as_array();
  if (!a || !a->is_array_of_tables() || a->empty())
    throw InputError(path + ": material_pair = " + Section::node_text(*node) +
                     ": pairs of materials are tables [[material_pair]] (docs/scene.md, \"Materials\")");
  if (sc.materials.size() < 2) throw InputError(path + ": [[material_pair]] needs two or more [[material]] tables");
  for (std::size_t k = 0; k < a->size(); ++k) {
    const toml::table* t = a->get(k)->as_table();
    Section M(t, path, "material_pair #" + std::to_string(k + 1));
    M.mark_used("materials");
    const toml::node* n = t->get("materials");
    const toml::array* names = n ? n->as_array() : nullptr;
    if (!names || names->size() != 2 || !names->get(0)->is_string() || !names->get(1)->is_string())
      M.fail("materials", n ? Section::node_text(*n) : "(missing)",
             "must name the two materials of the pair: materials = [\"a\", \"b\"]");
    std::size_t ab[2];
    for (int e = 0; e < 2; ++e) {
      const std::string nm = *names->get(std::size_t(e))->value<std::string>();
      const auto it =
          std::find_if(sc.materials.begin(), sc.materials.end(), [&](const MaterialSpec& x) { return x.name == nm; });
      if (it == sc.materials.end())
        M.fail("materials", Section::node_text(*n),
               "\"" + nm + "\" is not a [[material]] (" + material_names(sc) + ")");
      ab[e] = std::size_t(it - sc.materials.begin());
    }
    for (const Materials::Given& g : sc.material_pairs)
      if ((g.a == ab[0] && g.b == ab[1]) || (g.a == ab[1] && g.b == ab[0]))
        M.fail("materials", Section::node_text(*n), "is given by another [[material_pair]] too");
    // The numbers into a copy of the law, then those given as the pair's.
    ContactLawParams law = sc.law;
    const auto numbers = {&ContactLawParams::friction, &ContactLawParams::rolling_friction,
                          &ContactLawParams::twisting_friction, &ContactLawParams::damping_ratio_n,
                          &ContactLawParams::damping_ratio_s};
    Materials::Given g{ab[0], ab[1], {}};
    for (const LawParameter& p : kLawParameters) {
      if (!p.key || std::find(numbers.begin(), numbers.end(), p.member) == numbers.end()) continue;
      const auto v = M.number(p.key);
      if (!v) continue;
      require(M, p.key, *v, within(p.bound, *v), bound_text(p.bound));
      g.numbers.set(p.member, *v);
    }
    for (const char* key : {"damping_ratio_normal", "damping_ratio_shear"}) {
      const char* e = key[14] == 'n' ? "restitution_normal" : "restitution_shear";
      if (M.has(key) && M.has(e))
        M.fail(e, Section::node_text(*t->get(e)), std::string("give ") + e + " or " + key + ", not both");
    }
    if (M.has("restitution_normal") || M.has("restitution_shear")) {
      parse_restitution(M, law);
      if (M.has("restitution_normal")) g.numbers.set(&ContactLawParams::damping_ratio_n, law.damping_ratio_n);
      if (M.has("restitution_shear") || (law.model == ContactModel::HertzMindlin && !M.has("damping_ratio_shear")))
        g.numbers.set(&ContactLawParams::damping_ratio_s, law.damping_ratio_s);
    }
    M.reject_unknown();
    if (!g.numbers.any())
      M.fail("materials", Section::node_text(*n),
             "gives no number for the pair (friction, rolling_friction, twisting_friction, restitution_normal, "
             "restitution_shear, damping_ratio_normal, damping_ratio_shear)");
    sc.material_pairs.push_back(g);
  }
}

// [[wall]] tables: planes of the periodic cell, perpendicular to a cell axis (the cell stays
// periodic along every axis: a plane not perpendicular to one would not be invariant under its
// periods). Checked against the cell and the particles in io/serial/wall_setup.cpp.
void parse_walls(const toml::node* node, const std::string& path, Scene& sc) {
  if (!node) return;
  const toml::array* a = node->as_array();
  if (!a || !a->is_array_of_tables() || a->empty())
    throw InputError(path + ": wall = " + Section::node_text(*node) +
                     ": walls are tables [[wall]] (docs/scene.md, \"Walls\")");
  if (sc.triaxial.enabled || sc.compress.enabled)
    throw InputError(path + ": [[wall]] with " + (sc.triaxial.enabled ? "[triaxial]" : "[compress]") +
                     ": the cell deforms in these stages and the walls do not follow it; walls are "
                     "used with a cell at rest ([run] steps)");
  for (std::size_t k = 0; k < a->size(); ++k) {
    const toml::table* t = a->get(k)->as_table();
    Section W(t, path, "wall #" + std::to_string(k + 1));
    WallSpec w;
    w.law = sc.law;
    const auto point = W.vec3("point"), normal = W.vec3("normal");
    if (!point) W.fail("point", "(missing)", "a wall needs a point of its plane [x, y, z] (m)");
    if (!normal)
      W.fail("normal", "(missing)", "a wall needs its normal [nx, ny, nz], pointing into the granular domain");
    const std::string ntext = Section::node_text(*t->get("normal"));
    int axes = 0;
    for (int c = 0; c < 3; ++c) axes += (*normal)[c] != 0;
    if (axes == 0) W.fail("normal", ntext, "must be a non-zero vector");
    if (axes != 1)
      W.fail("normal", ntext,
             "must be parallel to a cell axis (the cell is periodic along every axis; "
             "for an incline, tilt [run] gravity instead)");
    w.point = *point;
    w.normal = normal->normalized();
    w.velocity = W.vec3("velocity").value_or(Vec3::Zero());
    if (const auto P = W.number("pressure")) {  // a servo wall (docs/scene.md, "Servo walls")
      require(W, "pressure", *P, *P > 0, "must be positive (Pa: the push the servo holds on the wall)");
      w.pressure = *P;
      if (w.velocity.dot(w.normal) != 0)
        W.fail("velocity", Section::node_text(*t->get("velocity")),
               "has a part along the normal, which the servo of pressure sets; give only its part in the "
               "wall's plane (a drag) or no velocity");
      w.servo_relaxation = W.number("servo_relaxation", w.servo_relaxation);
      require(W, "servo_relaxation", w.servo_relaxation, w.servo_relaxation > 0 && w.servo_relaxation < 1,
              "must lie in (0, 1) (the fraction of the force error one step corrects)");
      w.max_speed = W.number("max_speed", 0.0);
      require(W, "max_speed", w.max_speed, w.max_speed > 0 || !W.has("max_speed"), "must be positive (m/s)");
    } else {
      for (const char* key : {"servo_relaxation", "max_speed"})
        if (W.has(key)) W.fail(key, Section::node_text(*t->get(key)), "is a setting of the servo: give pressure too");
    }
    if (const auto m = W.string("material")) {
      const auto it =
          std::find_if(sc.materials.begin(), sc.materials.end(), [&](const MaterialSpec& x) { return x.name == *m; });
      if (it == sc.materials.end())
        W.fail("material", "\"" + *m + "\"",
               sc.materials.empty() ? "names a material, but the scene has no [[material]] tables"
                                    : "is not the name of a [[material]] (" + material_names(sc) + ")");
      w.material = std::int32_t(it - sc.materials.begin());
    }
    if (!sc.materials.empty())  // the law of a wall is that of its material with the sphere's
      for (const LawParameter& p : kLawParameters)
        for (const char* key : {p.key, p.wall ? "restitution_normal" : nullptr, p.wall ? "restitution_shear" : nullptr})
          if (key && W.has(key))
            W.fail(key, Section::node_text(*t->get(key)),
                   "with [[material]] tables a wall's contacts take the law of its material and the sphere's: "
                   "give the wall material = \"<name>\" (a [[material]] of its own numbers) instead");
    parse_wall_law(W, t, w);
    if (w.material >= 0 && sc.materials.size() > 1) w.own_law = false;
    W.reject_unknown();
    sc.walls.push_back(w);
  }
}

// [[driven]] tables: particles held fixed or moved at a constant velocity and spin, named by an
// id list or an id range (checked against the specimen in io/serial/wall_setup.cpp).
void parse_driven(const toml::node* node, const std::string& path, Scene& sc) {
  if (!node) return;
  const toml::array* a = node->as_array();
  if (!a || !a->is_array_of_tables() || a->empty())
    throw InputError(path + ": driven = " + Section::node_text(*node) +
                     ": driven particles are tables [[driven]] (docs/scene.md, \"Driven particles\")");
  if (sc.triaxial.enabled || sc.compress.enabled)
    throw InputError(path + ": [[driven]] with " + (sc.triaxial.enabled ? "[triaxial]" : "[compress]") +
                     ": a driven particle's velocity is relative to the deforming cell's affine field "
                     "there; driven particles are used with a cell at rest ([run] steps)");
  for (std::size_t k = 0; k < a->size(); ++k) {
    const toml::table* t = a->get(k)->as_table();
    Section D(t, path, "driven #" + std::to_string(k + 1));
    DrivenSet d;
    const bool has_ids = D.has("ids"), has_range = D.has("id_range");
    D.mark_used("ids");
    D.mark_used("id_range");
    if (has_ids == has_range)
      D.fail(has_ids ? "id_range" : "ids", has_ids ? Section::node_text(*t->get("id_range")) : "(missing)",
             "give the particles as ids = [..] or as id_range = [first, last], one of the two");
    const char* key = has_ids ? "ids" : "id_range";
    const toml::node* n = t->get(key);
    const toml::array* ids = n->as_array();
    if (!ids || ids->empty() || (!has_ids && ids->size() != 2))
      D.fail(key, Section::node_text(*n),
             has_ids ? "must be a non-empty array of particle ids" : "must be [first, last], two particle ids");
    std::vector<GlobalId> v;
    for (const toml::node& e : *ids) {
      if (!e.is_integer() || *e.value<std::int64_t>() < 0)
        D.fail(key, Section::node_text(*n), "must hold particle ids (integers >= 0)");
      v.push_back(*e.value<std::int64_t>());
    }
    if (has_ids) {
      std::sort(v.begin(), v.end());
      if (std::adjacent_find(v.begin(), v.end()) != v.end())
        D.fail(key, Section::node_text(*n), "names a particle twice");
      d.ids = v;
    } else {
      if (v[0] > v[1]) D.fail(key, Section::node_text(*n), "first must not exceed last");
      d.first = v[0], d.last = v[1];
    }
    d.velocity = D.vec3("velocity").value_or(Vec3::Zero());
    d.spin = D.vec3("spin").value_or(Vec3::Zero());
    if (!(d.velocity.isZero() && d.spin.isZero()) && sc.local_damping > 0)
      D.fail(D.has("velocity") ? "velocity" : "spin",
             Section::node_text(*t->get(D.has("velocity") ? "velocity" : "spin")),
             "a moving driven particle is not damped, but [run] local_damping = " + number_text(sc.local_damping, 10) +
                 " would book its damping as dissipated; use local_damping = 0 or hold them fixed");
    D.reject_unknown();
    for (std::size_t j = 0; j < sc.driven.size(); ++j) {  // each particle in one set at most
      const DrivenSet& o = sc.driven[j];
      GlobalId shared = -1;
      if (d.ids.empty() && o.ids.empty()) {
        if (std::max(d.first, o.first) <= std::min(d.last, o.last)) shared = std::max(d.first, o.first);
      } else {
        const DrivenSet& list = d.ids.empty() ? o : d;
        const DrivenSet& other = d.ids.empty() ? d : o;
        for (GlobalId id : list.ids)
          if (other.contains(id)) {
            shared = id;
            break;
          }
      }
      if (shared >= 0)
        D.fail(key, Section::node_text(*n),
               "names particle " + std::to_string(shared) + " of [driven #" + std::to_string(j + 1) + "] too");
    }
    sc.driven.push_back(d);
  }
}

// ---- end of restitution and walls ----------------------------------------------------------

// [fields] (docs/fields.md, "Fields during a run"): what can be checked from the scene alone.
// The grid against the specimen (the kernel's reach, the memory, the radii of a data file) is
// checked once the specimen is made (check_run_fields, io/mpi/run_fields.hpp).
void parse_fields(const toml::table* t, const std::string& path, Scene& sc) {
  if (!t) return;
  Section S(t, path, "fields");
  FieldsSpec& f = sc.fields;
  f.enabled = true;
  if (S.has("cells") && S.has("spacing"))
    S.fail("spacing", Section::node_text(*t->get("spacing")), "give either cells or spacing, not both");
  S.mark_used("cells");
  if (const toml::node* n = t->get("cells")) {
    const toml::array* a = n->as_array();
    bool ok = a && a->size() == 3;
    std::array<int, 3> c{};
    for (std::size_t k = 0; ok && k < 3; ++k) {
      const std::optional<std::int64_t> v = a->get(k)->is_integer() ? a->get(k)->value<std::int64_t>() : std::nullopt;
      ok = v && *v >= 1 && *v <= 1000000;
      if (ok) c[k] = int(*v);
    }
    if (!ok) S.fail("cells", Section::node_text(*n), "must be three integers from 1 to 1000000 (nx, ny, nz)");
    f.cells = c;
  }
  if (auto h = S.number("spacing")) {
    require(S, "spacing", *h, *h > 0, "must be positive (m)");
    f.spacing = *h;
  }
  const std::string kernel = S.string("kernel").value_or("gaussian");
  if (kernel != "gaussian" && kernel != "lucy")
    S.fail("kernel", "\"" + kernel + "\"", "must be \"gaussian\" or \"lucy\"");
  f.lucy = kernel == "lucy";
  const std::optional<real_t> w = S.number("width");
  if (!w)
    S.fail("width", "(missing)",
           "the kernel width is needed (m: the Gaussian's standard deviation, Lucy's support radius)");
  f.width = *w;
  require(S, "width", f.width, f.width > 0, "must be positive (m)");
  if (sc.source == ParticleSource::Generate && f.width < 0.5 * sc.generate.d_min)
    S.fail("width", number_text(f.width, 10),
           "is below the smallest sphere radius " + number_text(0.5 * sc.generate.d_min, 10) +
               " m ([particles] d_min / 2): the fields would resolve the inside of the spheres");
  if (auto c = S.number("cutoff")) {
    if (f.lucy) S.fail("cutoff", number_text(*c, 10), "is for the Gaussian kernel only (Lucy's support is its width)");
    f.cutoff = *c;
  }
  require(S, "cutoff", f.cutoff, f.cutoff >= 1, "must be at least 1 (widths)");
  if (auto e = S.integer("every")) f.every = *e;
  if (f.every < 1) S.fail("every", std::to_string(f.every), "must be at least 1 (output rows between field instants)");
  S.mark_used("quantities");
  if (const toml::node* n = t->get("quantities")) {
    const toml::array* a = n->as_array();
    if (!a || a->empty()) S.fail("quantities", Section::node_text(*n), "must be a non-empty array of names");
    for (const toml::node& e : *a) {
      const std::optional<std::string> q = e.value<std::string>();
      if (!q || !e.is_string()) S.fail("quantities", Section::node_text(*n), "must hold names (strings)");
      if (!field_quantity_known(*q))
        S.fail("quantities", "\"" + *q + "\"",
               "unknown quantity (solid_fraction, density, velocity, kinetic_stress, contact_stress, stress, "
               "spin, contact_density_<network>, fabric_<network>, \"networks\" for every network's two, "
               "displacement, displacement_gradient, strain_increment)");
      f.quantities.push_back(*q);
    }
  }
  S.reject_unknown();
  if (!sc.hdf5)
    throw InputError(path + ": [fields] with [run] hdf5 = false: the fields are written into run.h5; remove one");
  if (f.cells) {
    FieldGrid g;
    g.n = *f.cells;
    // The least any rank count needs (a layer a rank: the grid shared over as many ranks as it
    // has layers); check_run_fields checks the share on the run's ranks before the run.
    const double bytes = field_bytes(g, {}, g.n[2]), memory = machine_memory_bytes();
    if (memory > 0 && bytes > 0.5 * memory)
      S.fail("cells", Section::node_text(*t->get("cells")),
             "a grid of " + std::to_string(g.nodes()) + " nodes needs " + number_text(bytes, 3) +
                 " B of memory on every rank, more than half of the machine's " + number_text(memory, 3) +
                 " B: give fewer cells");
  }
}

// [particles]: the specimen, generated or read from a data file.
void parse_particles(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section P(table("particles"), path, "particles");
  const std::string source = P.string("source").value_or("generate");
  if (source == "generate") {
    sc.source = ParticleSource::Generate;
  } else if (source == "file") {
    sc.source = ParticleSource::File;
  } else {
    P.fail("source", "\"" + source + "\"", "must be \"generate\" or \"file\"");
  }
  if (auto f = P.string("file")) {
    if (sc.source != ParticleSource::File) P.fail("file", *f, "is only used with source = \"file\"");
    std::filesystem::path fp(*f);
    if (fp.is_relative()) fp = std::filesystem::path(path).parent_path() / fp;
    sc.data_file = fp.string();
  } else if (sc.source == ParticleSource::File) {
    P.fail("file", "(missing)", "source = \"file\" needs the path of a LAMMPS data file");
  }
  GenerateSpec& g = sc.generate;
  if (auto n = P.integer("count")) g.count = *n;
  if (g.count < 2) P.fail("count", std::to_string(g.count), "must be at least 2");
  g.fractal_dimension = P.number("fractal_dimension", g.fractal_dimension);
  require(P, "fractal_dimension", g.fractal_dimension, g.fractal_dimension > 0 && g.fractal_dimension < 3,
          "must lie in (0, 3)");
  g.d_min = P.number("d_min", g.d_min);
  require(P, "d_min", g.d_min, g.d_min >= kMinDiameter && g.d_min <= kMaxDiameter,
          "must be positive and lie in [1e-09, 1000] m (a sphere diameter in metres)");
  g.d_max = P.number("d_max", g.d_max);
  require(P, "d_max", g.d_max, g.d_max >= g.d_min, "must be >= d_min = " + number_text(g.d_min, 10));
  require(P, "d_max", g.d_max, g.d_max <= kMaxDiameter, "must be at most 1000 m (a sphere diameter in metres)");
  if (auto s = P.integer("seed")) {
    if (*s < 0) P.fail("seed", std::to_string(*s), "must be >= 0");
    g.seed = std::uint64_t(*s);
  }
  g.solid_fraction = P.number("solid_fraction", g.solid_fraction);
  require(P, "solid_fraction", g.solid_fraction, g.solid_fraction > 0 && g.solid_fraction < 0.5,
          "must lie in (0, 0.5) for a random loose placement");
  if (auto a = P.vec3("aspect")) {
    if (!(a->minCoeff() > 0))
      P.fail("aspect", Section::node_text(*table("particles")->get("aspect")), "must be positive");
    g.aspect = *a;
  }
  // Default: sequential below kRegionsFrom spheres (the study's specimens, unchanged), regions
  // from there on (no rank makes the whole specimen).
  g.placement =
      g.count >= GenerateSpec::kRegionsFrom ? GenerateSpec::Placement::Regions : GenerateSpec::Placement::Sequential;
  if (auto pl = P.string("placement")) {
    if (*pl == "sequential") g.placement = GenerateSpec::Placement::Sequential;
    else if (*pl == "regions") g.placement = GenerateSpec::Placement::Regions;
    else P.fail("placement", "\"" + *pl + "\"", "must be \"sequential\" or \"regions\"");
    if (sc.source == ParticleSource::File)
      P.fail("placement", "\"" + *pl + "\"", "is only used with source = \"generate\"");
  }
  sc.density = P.number("density", sc.density);
  require(P, "density", sc.density, sc.density > 0, "must be positive");
  P.reject_unknown();
}

// [cell]: the cell's size.
void parse_cell(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section C(table("cell"), path, "cell");
  if (auto s = C.vec3("size")) {
    if (!(s->minCoeff() > 0)) C.fail("size", Section::node_text(*table("cell")->get("size")), "must be positive");
    sc.cell_size = *s;
  }
  C.reject_unknown();
}

// [contact]: the contact law, then the [[material]] and [[material_pair]] tables (a scene of one
// material takes its law and density).
void parse_contact(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section K(table("contact"), path, "contact");
  ContactLawParams& law = sc.law;
  if (const auto m = K.string("model")) {
    if (*m == "linear") law.model = ContactModel::Linear;
    else if (*m == "hertz_mindlin") law.model = ContactModel::HertzMindlin;
    else
      K.fail("model", "\"" + *m + "\"", "must be \"linear\" or \"hertz_mindlin\" (docs/scene.md, \"Contact models\")");
  }
  if (const auto m = K.string("rolling_model")) {
    if (*m == "elastic_plastic") law.rolling_model = RollingModel::ElasticPlastic;
    else if (*m == "epsd") law.rolling_model = RollingModel::Epsd;
    else if (*m == "constant_torque") law.rolling_model = RollingModel::ConstantTorque;
    else
      K.fail(
          "rolling_model", "\"" + *m + "\"",
          "must be \"elastic_plastic\", \"epsd\" or \"constant_torque\" (docs/scene.md, \"Rolling resistance models\")");
  }
  parse_law_numbers(K, table("contact"), law, false);
  parse_restitution(K, law);
  K.reject_unknown();
  parse_materials(root.get("material"), path, sc);
  parse_material_pairs(root.get("material_pair"), path, sc);
  if (sc.materials.size() == 1) {  // one material: the scene's law and density are its own
    sc.law = sc.materials[0].law;
    if (sc.source == ParticleSource::Generate) sc.density = sc.materials[0].density;
  }
}

// [compress]: the optional isotropic compression.
void parse_compress(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section Q(table("compress"), path, "compress");
  CompressSpec& cp = sc.compress;
  cp.enabled = table("compress") != nullptr;
  cp.target_pressure = Q.number("target_pressure", cp.target_pressure);
  require(Q, "target_pressure", cp.target_pressure, cp.target_pressure > 0, "must be positive");
  cp.strain_rate = Q.number("strain_rate", cp.strain_rate);
  require(Q, "strain_rate", cp.strain_rate, cp.strain_rate < 0, "must be negative (compression)");
  if (auto m = Q.integer("max_steps")) cp.max_steps = *m;
  if (cp.max_steps <= 0) Q.fail("max_steps", std::to_string(cp.max_steps), "must be positive");
  cp.friction = Q.number("friction", cp.friction);
  require(Q, "friction", cp.friction, cp.friction >= 0, "must be >= 0");
  Q.reject_unknown();
}

// [run]: time step, output, guards and checkpoints.
void parse_run(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section R(table("run"), path, "run");
  if (auto s = R.integer("steps")) sc.steps = *s;
  if (sc.steps < 0) R.fail("steps", std::to_string(sc.steps), "must be >= 0");
  sc.time_step_fraction = R.number("time_step_fraction", sc.time_step_fraction);
  require(R, "time_step_fraction", sc.time_step_fraction, sc.time_step_fraction > 0, "must be positive");
  if (auto dt = R.number("time_step")) {
    if (R.has("time_step_fraction"))
      R.fail("time_step", number_text(*dt, 10), "give time_step or time_step_fraction, not both");
    require(R, "time_step", *dt, *dt > 0, "must be positive");
    sc.time_step = *dt;
  }
  sc.force_time_step = R.boolean("force_time_step").value_or(false);
  sc.skin = R.number("skin", sc.skin);
  require(R, "skin", sc.skin, sc.skin > 0, "must be positive");
  if (auto o = R.integer("output_every")) sc.output_every = *o;
  if (sc.output_every <= 0) R.fail("output_every", std::to_string(sc.output_every), "must be positive");
  sc.gravity = R.vec3("gravity").value_or(Vec3::Zero());
  sc.max_overlap = R.number("max_overlap", sc.max_overlap);
  require(R, "max_overlap", sc.max_overlap, sc.max_overlap > 0 && sc.max_overlap <= 1,
          "must lie in (0, 1] (fraction of the smaller radius)");
  sc.kinetic_runaway = R.number("kinetic_runaway", sc.kinetic_runaway);
  require(R, "kinetic_runaway", sc.kinetic_runaway, sc.kinetic_runaway >= 1,
          "must be >= 1 (a multiple of the energy put into the system)");
  sc.max_initial_overlap = R.number("max_initial_overlap", sc.max_initial_overlap);
  require(R, "max_initial_overlap", sc.max_initial_overlap, sc.max_initial_overlap > 0 && sc.max_initial_overlap <= 1,
          "must lie in (0, 1] (fraction of the smaller radius)");
  sc.density_scaling = R.number("density_scaling", sc.density_scaling);
  require(R, "density_scaling", sc.density_scaling, sc.density_scaling > 0, "must be positive");
  sc.local_damping = R.number("local_damping", sc.local_damping);
  require(R, "local_damping", sc.local_damping, sc.local_damping >= 0 && sc.local_damping < 1, "must lie in [0, 1)");
  if (auto k = R.integer("snapshot_every")) sc.snapshot_every = *k;
  if (sc.snapshot_every <= 0) R.fail("snapshot_every", std::to_string(sc.snapshot_every), "must be positive");
  sc.hdf5 = R.boolean("hdf5").value_or(sc.hdf5);
  if (auto c = R.integer("checkpoint_every")) sc.checkpoint_every = *c;
  if (sc.checkpoint_every < 0)
    R.fail("checkpoint_every", std::to_string(sc.checkpoint_every), "must be >= 0 (0 = off)");
  sc.checkpoint_seconds = R.number("checkpoint_seconds", sc.checkpoint_seconds);
  require(R, "checkpoint_seconds", sc.checkpoint_seconds, sc.checkpoint_seconds >= 0, "must be >= 0 (0 = off)");
  R.reject_unknown();
}

// [triaxial]: the periodic triaxial test, its sweep, realisations and consolidation frictions.
void parse_triaxial(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  GenerateSpec& g = sc.generate;
  Section T(table("triaxial"), path, "triaxial");
  TriaxialSpec& tx = sc.triaxial;
  tx.enabled = table("triaxial") != nullptr;
  auto positive = [&](const char* key, real_t& v) {
    v = T.number(key, v);
    require(T, key, v, v > 0, "must be positive");
  };
  positive("confining_pressure", tx.confining_pressure);
  tx.consolidation_friction = T.number("consolidation_friction", tx.consolidation_friction);
  require(T, "consolidation_friction", tx.consolidation_friction, tx.consolidation_friction >= 0, "must be >= 0");
  const std::string eq = T.string("equilibration").value_or("common");
  if (eq != "case" && eq != "common" && eq != "none")
    T.fail("equilibration", "\"" + eq + "\"", "must be \"case\", \"common\" or \"none\"");
  tx.equilibration = eq == "common" ? TriaxialSpec::Equilibration::Common
      : eq == "none"                ? TriaxialSpec::Equilibration::None
                                    : TriaxialSpec::Equilibration::Case;
  const bool gains_given = T.has("servo_gain") || T.has("servo_integral_gain");
  const std::string servo = T.string("servo").value_or(gains_given ? "gains" : "stiffness");
  if (servo != "stiffness" && servo != "gains")
    T.fail("servo", "\"" + servo + "\"", "must be \"stiffness\" or \"gains\"");
  tx.servo = servo == "gains" ? ServoMode::Gains : ServoMode::Stiffness;
  if (tx.servo == ServoMode::Stiffness && gains_given)
    T.fail(T.has("servo_gain") ? "servo_gain" : "servo_integral_gain", "given",
           "is used with servo = \"gains\" only (servo = \"stiffness\" derives its gain from the "
           "specimen's stiffness: set servo_relaxation instead)");
  if (tx.servo == ServoMode::Gains && (T.has("servo_relaxation") || T.has("servo_integral_relaxation")))
    T.fail(T.has("servo_relaxation") ? "servo_relaxation" : "servo_integral_relaxation", "given",
           "is used with servo = \"stiffness\" only");
  positive("servo_gain", tx.servo_gain);
  tx.servo_integral_gain = T.number("servo_integral_gain", tx.servo_integral_gain);
  require(T, "servo_integral_gain", tx.servo_integral_gain, tx.servo_integral_gain >= 0, "must be >= 0");
  tx.servo_relaxation = T.number("servo_relaxation", tx.servo_relaxation);
  require(T, "servo_relaxation", tx.servo_relaxation, tx.servo_relaxation > 0 && tx.servo_relaxation <= 0.5,
          "must lie in (0, 0.5]");
  tx.servo_integral_relaxation = T.number("servo_integral_relaxation", tx.servo_integral_relaxation);
  require(T, "servo_integral_relaxation", tx.servo_integral_relaxation,
          tx.servo_integral_relaxation >= 0 && tx.servo_integral_relaxation <= tx.servo_relaxation,
          "must lie in [0, servo_relaxation]");
  positive("max_strain_rate", tx.max_strain_rate);
  positive("stress_tolerance", tx.stress_tolerance);
  positive("unbalanced_tolerance", tx.unbalanced_tolerance);
  tx.servo_interval = tx.servo == ServoMode::Gains ? 5 : 2;  // the fixed gains were tuned at 5
  if (auto k = T.integer("servo_interval")) tx.servo_interval = *k;
  if (tx.servo_interval <= 0) T.fail("servo_interval", std::to_string(tx.servo_interval), "must be positive");
  positive("axial_strain_rate", tx.axial_strain_rate);
  positive("axial_strain", tx.axial_strain);
  require(T, "axial_strain", tx.axial_strain, tx.axial_strain < 1, "must be below 1");
  tx.preparation_damping = T.number("preparation_damping", tx.preparation_damping);
  require(T, "preparation_damping", tx.preparation_damping, tx.preparation_damping >= 0 && tx.preparation_damping < 1,
          "must lie in [0, 1)");
  tx.shear_damping = T.number("shear_damping", tx.shear_damping);
  require(T, "shear_damping", tx.shear_damping, tx.shear_damping >= 0 && tx.shear_damping < 1, "must lie in [0, 1)");
  if (auto k = T.integer("max_stage_steps")) tx.max_stage_steps = *k;
  if (tx.max_stage_steps <= 0) T.fail("max_stage_steps", std::to_string(tx.max_stage_steps), "must be positive");
  positive("progress_seconds", tx.progress_seconds);
  if (T.has("rolling_friction_cases")) {
    const toml::node* n = table("triaxial")->get("rolling_friction_cases");
    const toml::array* a = n->as_array();
    if (!a || a->empty())
      T.fail("rolling_friction_cases", Section::node_text(*n), "must be a non-empty array of numbers");
    for (const toml::node& e : *a) {
      const std::optional<double> v = e.value<double>();
      if (!v || e.is_boolean() || !std::isfinite(*v) || *v < 0)
        T.fail("rolling_friction_cases", Section::node_text(*n), "must hold finite numbers >= 0");
      tx.rolling_friction_cases.push_back(*v);
    }
  }
  T.mark_used("rolling_friction_cases");
  T.mark_used("consolidation_friction_cases");
  if (const toml::node* n = table("triaxial") ? table("triaxial")->get("consolidation_friction_cases") : nullptr) {
    const toml::array* a = n->as_array();
    if (!a || a->empty())
      T.fail("consolidation_friction_cases", Section::node_text(*n), "must be a non-empty array of numbers");
    for (const toml::node& e : *a) {
      const std::optional<double> v = e.value<double>();
      if (!v || e.is_boolean() || !std::isfinite(*v) || *v < 0)
        T.fail("consolidation_friction_cases", Section::node_text(*n), "must hold finite numbers >= 0");
      if (std::find(tx.consolidation_friction_cases.begin(), tx.consolidation_friction_cases.end(), *v) !=
          tx.consolidation_friction_cases.end())
        T.fail("consolidation_friction_cases", Section::node_text(*n),
               "names mu_s = " + number_text(*v, 10) + " twice");
      tx.consolidation_friction_cases.push_back(*v);
    }
  }
  if (T.has("realisations") && T.has("seeds"))
    T.fail("seeds", Section::node_text(*table("triaxial")->get("seeds")), "give realisations or seeds, not both");
  if (const auto n = T.integer("realisations")) {
    if (*n < 1) T.fail("realisations", std::to_string(*n), "must be at least 1");
    if (*n > 100000) T.fail("realisations", std::to_string(*n), "must be at most 100000");
    if (*n > 1)
      for (std::int64_t k = 0; k < *n; ++k) tx.seeds.push_back(g.seed + std::uint64_t(k));
  }
  T.mark_used("seeds");
  if (const toml::node* n = table("triaxial") ? table("triaxial")->get("seeds") : nullptr) {
    const toml::array* a = n->as_array();
    if (!a || a->empty()) T.fail("seeds", Section::node_text(*n), "must be a non-empty array of seeds (integers >= 0)");
    for (const toml::node& e : *a) {
      if (!e.is_integer() || *e.value<std::int64_t>() < 0)
        T.fail("seeds", Section::node_text(*n), "must hold seeds (integers >= 0)");
      const auto v = std::uint64_t(*e.value<std::int64_t>());
      if (std::find(tx.seeds.begin(), tx.seeds.end(), v) != tx.seeds.end())
        T.fail("seeds", Section::node_text(*n), "names seed " + std::to_string(v) + " twice");
      tx.seeds.push_back(v);
    }
    if (tx.seeds.size() == 1) g.seed = tx.seeds[0], tx.seeds.clear();
  }
  if (!tx.seeds.empty() && sc.source == ParticleSource::File)
    T.fail(T.has("seeds") ? "seeds" : "realisations",
           Section::node_text(*table("triaxial")->get(T.has("seeds") ? "seeds" : "realisations")),
           "realisations are generated specimens: [particles] source = \"file\" has one");
  T.reject_unknown();
}

// [parallel]: the decomposition and the groups of ranks.
void parse_parallel(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section M(table("parallel"), path, "parallel");
  ParallelSpec& ps = sc.parallel;
  ps.decomposition = M.string("decomposition").value_or(ps.decomposition);
  if (ps.decomposition != "cartesian" && ps.decomposition != "metis")
    M.fail("decomposition", "\"" + ps.decomposition + "\"", "must be \"cartesian\" or \"metis\"");
  ps.rebalance_threshold = M.number("rebalance_threshold", ps.rebalance_threshold);
  require(M, "rebalance_threshold", ps.rebalance_threshold, ps.rebalance_threshold >= 1.0,
          "must be >= 1 (max/mean work)");
  if (auto k = M.integer("rebalance_interval")) ps.rebalance_interval = *k;
  if (ps.rebalance_interval <= 0)
    M.fail("rebalance_interval", std::to_string(ps.rebalance_interval), "must be positive");
  ps.cut = M.string("cut").value_or(ps.cut);
  ps.balance = M.string("balance").value_or(ps.balance);
  if (const toml::node* n = table("parallel") ? table("parallel")->get("groups") : nullptr) {
    M.mark_used("groups");
    if (n->is_string() && *n->value<std::string>() == "auto") ps.groups = 0;
    else if (n->is_integer() && *n->value<std::int64_t>() >= 1) ps.groups = *n->value<std::int64_t>();
    else M.fail("groups", Section::node_text(*n), "must be a positive integer or \"auto\"");
  }
  if (ps.cut != "work" && ps.cut != "even") M.fail("cut", "\"" + ps.cut + "\"", "must be \"work\" or \"even\"");
  if (ps.balance != "count" && ps.balance != "time")  // the policies of parallel/balance_policy.cpp
    M.fail("balance", "\"" + ps.balance + "\"", "must be \"count\" or \"time\"");
  M.reject_unknown();
}

// [fabric]: the fabric analysis.
void parse_fabric(const toml::table& root, const std::string& path, Scene& sc) {
  auto table = [&](const char* n) { return root[n].as_table(); };
  Section F(table("fabric"), path, "fabric");
  FabricSpec& fs = sc.fabric;
  fs.enabled = F.boolean("enabled").value_or(fs.enabled);
  fs.strong_ratio = F.number("strong_ratio", fs.strong_ratio);
  require(F, "strong_ratio", fs.strong_ratio, fs.strong_ratio > 0, "must be positive");
  if (auto b = F.integer("rose_bins")) fs.rose_bins = *b;
  if (fs.rose_bins < 1 || fs.rose_bins > 3600)
    F.fail("rose_bins", std::to_string(fs.rose_bins), "must lie in [1, 3600]");
  F.reject_unknown();
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& path) {
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    std::ostringstream m;
    m << path << ":" << e.source().begin.line << ":" << e.source().begin.column
      << ": TOML syntax error: " << e.description();
    throw InputError(m.str());
  }
  static const std::set<std::string> tables = {"particles", "cell",     "contact", "compress", "run",
                                               "triaxial",  "parallel", "fabric",  "fields"};
  for (auto&& [k, v] : root) {
    const std::string key(k.str());
    if (key == "stage") continue;                               // [[stage]]: io/serial/stage_parse.cpp, below
    if (key == "wall" || key == "driven") continue;             // [[wall]], [[driven]]: parse_walls, parse_driven
    if (key == "material" || key == "material_pair") continue;  // parse_materials, parse_material_pairs
    if (!tables.count(key) || !v.is_table())
      throw InputError(path + ": " + key + " = " + Section::node_text(v) +
                       ": unknown top-level entry (expected one of the tables [particles], "
                       "[cell], [contact], [compress], [run], [triaxial], [parallel], [fabric], [fields], "
                       "[[stage]], [[wall]], [[driven]], [[material]], [[material_pair]])");
  }
  auto table = [&](const char* name) { return root[name].as_table(); };

  Scene sc;
  sc.path = path;
  sc.text = text;
  const toml::table* run = table("run");
  const bool steps_given = run && run->contains("steps");

  // One function per table, in this order: later tables read earlier ones' values (the particle
  // source, the law, the materials); then the rules between tables.
  parse_particles(root, path, sc);
  parse_cell(root, path, sc);
  parse_contact(root, path, sc);
  parse_compress(root, path, sc);
  parse_run(root, path, sc);
  parse_triaxial(root, path, sc);
  if (sc.triaxial.enabled && steps_given)
    throw InputError(path + ": [run] steps = " + std::to_string(sc.steps) +
                     ": not used with [triaxial], which runs until [triaxial] axial_strain; remove it");
  if (sc.triaxial.enabled && sc.compress.enabled)
    throw InputError(path +
                     ": [compress] and [triaxial] both given: the triaxial test consolidates "
                     "the specimen itself; remove [compress]");

  // The loading stages ([[stage]], io/serial/stage_parse.cpp): one protocol per scene.
  sc.stages = parse_stages(root.get("stage"), path);
  if (!sc.stages.empty() && sc.triaxial.enabled)
    throw InputError(path +
                     ": [[stage]] and [triaxial] both given: [triaxial] is the study's "
                     "protocol as stages (docs/triaxial.md); give one of them");
  if (!sc.stages.empty() && sc.compress.enabled)
    throw InputError(path +
                     ": [[stage]] and [compress] both given: prepare the specimen with a "
                     "stage (type = \"isotropic\"); remove [compress]");
  if (!sc.stages.empty() && steps_given)
    throw InputError(path + ": [run] steps = " + std::to_string(sc.steps) +
                     ": not used with [[stage]], whose stages end by their end conditions; remove it");

  parse_parallel(root, path, sc);
  parse_fabric(root, path, sc);
  parse_fields(table("fields"), path, sc);
  parse_walls(root.get("wall"), path, sc);
  parse_driven(root.get("driven"), path, sc);
  // The stages strain the cell, which walls and driven particles do not follow (as [triaxial]).
  if (!sc.stages.empty() && !sc.walls.empty())
    throw InputError(path +
                     ": [[stage]] and [[wall]] both given: the stages deform the periodic "
                     "cell and the walls would not follow it; remove one of them");
  if (!sc.stages.empty() && !sc.driven.empty())
    throw InputError(path +
                     ": [[stage]] and [[driven]] both given: the stages deform the periodic "
                     "cell and the driven particles would not follow it; remove one of them");
  return sc;
}

bool FieldsSpec::keeps(const std::string& name) const {
  if (quantities.empty()) return true;
  const bool network = name.starts_with("contact_density_") || name.starts_with("fabric_");
  for (const std::string& q : quantities)
    if (q == name || (q == "networks" && network)) return true;
  return false;
}

bool FieldsSpec::networks() const {
  if (quantities.empty()) return true;
  for (const std::string& q : quantities)
    if (q == "networks" || q.starts_with("contact_density_") || q.starts_with("fabric_")) return true;
  return false;
}

bool FieldsSpec::displacement() const {
  return keeps("displacement") || keeps("displacement_gradient") || keeps("strain_increment");
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path + ": is a directory, not a scene file (TOML)");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  const int err = errno;  // what open(2) said: no such file, permission denied (a directory that cannot be entered)
  if (!in || fault_injected("scene"))
    throw InputError(path + ": cannot open the scene file (" +
                     (in ? fault_text("scene") : std::string(err ? std::strerror(err) : "unreadable")) + ")");
  std::ostringstream s;
  s << in.rdbuf();
  return parse_scene(s.str(), path);
}

Scene default_scene() { return parse_scene(kDemoScene, "<built-in demo scene>"); }

Materials scene_materials(const Scene& sc) {
  Materials m;
  if (sc.materials.size() < 2) return m;
  for (const MaterialSpec& x : sc.materials) {
    m.names.push_back(x.name);
    m.laws.push_back(x.law);
  }
  m.mix_pairs(sc.material_pairs);
  return m;
}

std::uint8_t generated_material(const Scene& sc, GlobalId id) {
  // The fractional part of (id + 1) / golden ratio: evenly spread over [0, 1) for consecutive
  // ids (the counts of each material within a few of fraction x N), and a function of the id
  // alone.
  const real_t u = std::fmod(real_t(id + 1) * 0.6180339887498949, 1.0);
  real_t upto = 0;
  std::size_t last = 0;
  for (std::size_t k = 0; k < sc.materials.size(); ++k) {
    if (sc.materials[k].fraction <= 0) continue;
    last = k;
    upto += sc.materials[k].fraction;
    if (u < upto) return std::uint8_t(k);
  }
  return std::uint8_t(last);  // the rounding of the sum of the fractions
}

}  // namespace fabrica
