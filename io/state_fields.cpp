#include "io/state_fields.hpp"

#include "io/errors.hpp"
#include "parallel/properties.hpp"

#include <cstring>
#include <type_traits>

namespace fabrica {

void write_law(FieldWriter& w, const ContactLawParams& l) {
  w.u8("law.stiffness_mode", l.stiffness_mode == NormalStiffnessMode::Direct ? 1 : 0);
  w.f64("law.youngs_modulus", l.youngs_modulus).f64("law.normal_stiffness", l.normal_stiffness);
  w.f64("law.stiffness_ratio", l.stiffness_ratio).f64("law.friction", l.friction);
  w.f64("law.rolling_friction", l.rolling_friction);
  w.f64("law.damping_ratio_n", l.damping_ratio_n).f64("law.damping_ratio_s", l.damping_ratio_s);
  w.f64("law.damping_rate_n", l.damping_rate_n).f64("law.damping_rate_s", l.damping_rate_s);
}

ContactLawParams read_law(FieldReader& r) {
  ContactLawParams l;
  l.stiffness_mode = r.u8("law.stiffness_mode") ? NormalStiffnessMode::Direct
                                                : NormalStiffnessMode::Deformability;
  l.youngs_modulus = r.f64("law.youngs_modulus");
  l.normal_stiffness = r.f64("law.normal_stiffness");
  l.stiffness_ratio = r.f64("law.stiffness_ratio");
  l.friction = r.f64("law.friction");
  l.rolling_friction = r.f64("law.rolling_friction");
  l.damping_ratio_n = r.f64("law.damping_ratio_n");
  l.damping_ratio_s = r.f64("law.damping_ratio_s");
  l.damping_rate_n = r.f64("law.damping_rate_n");
  l.damping_rate_s = r.f64("law.damping_rate_s");
  return l;
}

void write_dissipation(FieldWriter& w, const Dissipation& d) {
  w.f64("dissipation.friction", d.friction).f64("dissipation.rolling", d.rolling);
  w.f64("dissipation.viscous", d.viscous).f64("dissipation.local", d.local);
}

Dissipation read_dissipation(FieldReader& r) {
  Dissipation d;
  d.friction = r.f64("dissipation.friction");
  d.rolling = r.f64("dissipation.rolling");
  d.viscous = r.f64("dissipation.viscous");
  d.local = r.f64("dissipation.local");
  return d;
}

void write_macro(FieldWriter& w, const MacroState& m) {
  w.mat3("macro.stress", m.stress).f64("macro.p", m.p).f64("macro.q", m.q);
  w.f64("macro.coordination", m.coordination).f64("macro.mech_coordination", m.mech_coordination);
  w.i64("macro.contacts", m.contacts).i64("macro.sliding", m.sliding).i64("macro.rolling", m.rolling);
  w.f64("macro.kinetic", m.kinetic).f64("macro.e_normal", m.e_normal);
  w.f64("macro.e_shear", m.e_shear).f64("macro.e_rolling", m.e_rolling);
  write_dissipation(w, m.dissipated);
  w.f64("macro.unbalanced", m.unbalanced).f64("macro.volume", m.volume);
  w.f64("macro.void_ratio", m.void_ratio).i64("macro.particles", m.particles);
  w.f64("macro.mean_overlap", m.mean_overlap).f64("macro.max_overlap_ratio", m.max_overlap_ratio);
  w.i64("macro.max_overlap_a", m.max_overlap_a).i64("macro.max_overlap_b", m.max_overlap_b);
  w.i64("macro.first_nonfinite", m.first_nonfinite).i64("macro.fastest", m.fastest);
  w.vec3("macro.fastest_v", m.fastest_v).vec3("macro.fastest_w", m.fastest_w);
  w.f64("macro.energy_input", m.energy_input).f64("macro.gravity_work", m.gravity_work);
  w.i64("macro.wall_contacts", m.wall_contacts).u64("macro.walls", m.wall_force.size());
  for (const Vec3& f : m.wall_force) w.vec3("macro.wall_force", f);
  w.f64("macro.wall_work", m.wall_work).f64("macro.drive_work", m.drive_work);
}

MacroState read_macro(FieldReader& r) {
  MacroState m;
  m.stress = r.mat3("macro.stress");
  m.p = r.f64("macro.p");
  m.q = r.f64("macro.q");
  m.coordination = r.f64("macro.coordination");
  m.mech_coordination = r.f64("macro.mech_coordination");
  m.contacts = r.i64("macro.contacts");
  m.sliding = r.i64("macro.sliding");
  m.rolling = r.i64("macro.rolling");
  m.kinetic = r.f64("macro.kinetic");
  m.e_normal = r.f64("macro.e_normal");
  m.e_shear = r.f64("macro.e_shear");
  m.e_rolling = r.f64("macro.e_rolling");
  m.dissipated = read_dissipation(r);
  m.unbalanced = r.f64("macro.unbalanced");
  m.volume = r.f64("macro.volume");
  m.void_ratio = r.f64("macro.void_ratio");
  m.particles = r.i64("macro.particles");
  m.mean_overlap = r.f64("macro.mean_overlap");
  m.max_overlap_ratio = r.f64("macro.max_overlap_ratio");
  m.max_overlap_a = r.i64("macro.max_overlap_a");
  m.max_overlap_b = r.i64("macro.max_overlap_b");
  m.first_nonfinite = r.i64("macro.first_nonfinite");
  m.fastest = r.i64("macro.fastest");
  m.fastest_v = r.vec3("macro.fastest_v");
  m.fastest_w = r.vec3("macro.fastest_w");
  m.energy_input = r.f64("macro.energy_input");
  m.gravity_work = r.f64("macro.gravity_work");
  m.wall_contacts = r.i64("macro.wall_contacts");
  const std::uint64_t nw = r.u64("macro.walls");
  for (std::uint64_t k = 0; k < nw && k < 1000000; ++k) m.wall_force.push_back(r.vec3("macro.wall_force"));
  m.wall_work = r.f64("macro.wall_work");
  m.drive_work = r.f64("macro.drive_work");
  return m;
}

namespace {
// One value of a property, little-endian: ids as i64, vectors as f64[3], scalars as f64.
template <class T>
void put_value(std::string& out, const T& v) {
  if constexpr (std::is_same_v<T, GlobalId>) {
    put_le(out, std::uint64_t(v), 8);
  } else if constexpr (std::is_same_v<T, real_t>) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    put_le(out, b, 8);
  } else {
    static_assert(std::is_same_v<T, Vec3>, "a particle property of a type without a layout");
    for (int k = 0; k < 3; ++k) put_value(out, v[k]);
  }
}
template <class T>
const char* get_value(const char* in, T& v) {
  if constexpr (std::is_same_v<T, GlobalId>) {
    v = GlobalId(get_le(in, 8));
    return in + 8;
  } else if constexpr (std::is_same_v<T, real_t>) {
    const std::uint64_t b = get_le(in, 8);
    std::memcpy(&v, &b, 8);
    return in + 8;
  } else {
    for (int k = 0; k < 3; ++k) in = get_value(in, v[k]);
    return in;
  }
}
template <class T>
const char* type_of() {
  if constexpr (std::is_same_v<T, GlobalId>) return "i64";
  else if constexpr (std::is_same_v<T, real_t>) return "f64";
  else return "f64[3]";
}
}  // namespace

std::string particle_record_schema() {
  std::string s;
  Particles probe;
  for_each_property(probe, [&](const char* name, auto& vec, Travel) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    s += (s.empty() ? "" : ";") + std::string(name) + ":" + type_of<T>();
  });
  return s;
}

std::size_t particle_record_bytes() {
  std::size_t b = 0;
  Particles probe;
  for_each_property(probe, [&](const char*, auto& vec, Travel) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    b += std::is_same_v<T, Vec3> ? 24 : 8;
  });
  return b;
}

void write_particles(const Particles& p, std::string& out) {
  out.reserve(out.size() + p.n_owned() * particle_record_bytes());
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    for_each_property(p, [&](const char*, const auto& vec, Travel) { put_value(out, vec[a]); });
}

void read_particles(const char* in, std::size_t n, Particles& p) {
  const std::size_t first = p.append_owned(n);
  for (std::size_t a = first; a < first + n; ++a)
    for_each_property(p, [&](const char*, auto& vec, Travel) { in = get_value(in, vec[a]); });
}

std::string contact_record_schema() { return "a:i64;b:i64;fs:f64[3];mr:f64[3]"; }
std::size_t contact_record_bytes() { return 64; }

void write_contact(GlobalId a, GlobalId b, const ContactHistory& h, std::string& out) {
  put_value(out, a);
  put_value(out, b);
  put_value(out, h.fs);
  put_value(out, h.mr);
}

void read_contacts(const char* in, std::size_t n, HistoryMap& history) {
  for (std::size_t k = 0; k < n; ++k) {
    GlobalId a, b;
    ContactHistory h;
    in = get_value(in, a);
    in = get_value(in, b);
    in = get_value(in, h.fs);
    in = get_value(in, h.mr);
    history.insert(a, b, h);
  }
}

}  // namespace fabrica
