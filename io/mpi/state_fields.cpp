#include "io/mpi/state_fields.hpp"

#include "core/errors.hpp"
#include "parallel/properties.hpp"

#include <algorithm>
#include <cstring>
#include <iterator>
#include <string_view>
#include <type_traits>

namespace fabrica {

namespace {

// Each struct's fields, listed once: 'io' is a FieldWriter (with a const struct) or a
// FieldReader (with a struct to fill), both taking field(name, value). The law's list is
// core/contact/params.hpp's law_fields.

template <class Io, class D>
void dissipation_fields(Io& io, D& d) {
  io.field("dissipation.friction", d.friction);
  io.field("dissipation.rolling", d.rolling);
  io.field("dissipation.viscous", d.viscous);
  io.field("dissipation.local", d.local);
}

template <class Io, class M>
void macro_fields(Io& io, M& m) {
  io.field("macro.stress", m.stress);
  io.field("macro.p", m.p);
  io.field("macro.q", m.q);
  io.field("macro.coordination", m.coordination);
  io.field("macro.mech_coordination", m.mech_coordination);
  io.field("macro.contacts", m.contacts);
  io.field("macro.sliding", m.sliding);
  io.field("macro.rolling", m.rolling);
  io.field("macro.kinetic", m.kinetic);
  io.field("macro.e_normal", m.e_normal);
  io.field("macro.e_shear", m.e_shear);
  io.field("macro.e_rolling", m.e_rolling);
  dissipation_fields(io, m.dissipated);
  io.field("macro.unbalanced", m.unbalanced);
  io.field("macro.volume", m.volume);
  io.field("macro.void_ratio", m.void_ratio);
  io.field("macro.particles", m.particles);
  io.field("macro.mean_overlap", m.mean_overlap);
  io.field("macro.max_overlap_ratio", m.max_overlap_ratio);
  io.field("macro.max_overlap_a", m.max_overlap_a);
  io.field("macro.max_overlap_b", m.max_overlap_b);
  io.field("macro.first_nonfinite", m.first_nonfinite);
  io.field("macro.fastest", m.fastest);
  io.field("macro.fastest_v", m.fastest_v);
  io.field("macro.fastest_w", m.fastest_w);
  io.field("macro.energy_input", m.energy_input);
  io.field("macro.gravity_work", m.gravity_work);
  io.field("macro.wall_contacts", m.wall_contacts);
  // The walls' forces: their count, then one Vec3 per wall.
  std::uint64_t walls = m.wall_force.size();
  io.field("macro.walls", walls);
  if constexpr (!std::is_const_v<M>) {
    if (walls > 1000000)
      throw InputError("checkpoint field macro.walls = " + std::to_string(walls) +
                       ": more than a million walls (a corrupt or foreign file)");
    m.wall_force.assign(std::size_t(walls), Vec3::Zero());
  }
  for (auto& f : m.wall_force) io.field("macro.wall_force", f);
  io.field("macro.wall_work", m.wall_work);
  io.field("macro.drive_work", m.drive_work);
}

}  // namespace

void write_law(FieldWriter& w, const ContactLawParams& l) { law_fields(w, l); }
ContactLawParams read_law(FieldReader& r) {
  ContactLawParams l;
  // Formats 6 and 7 end the law before law.model (the linear law, the only one then), format 8
  // before law.twisting_friction (no twisting resistance then).
  law_fields(r, l, [](const FieldReader& in, const char* name) { return in.next_is(name); });
  if (std::uint8_t(l.model) > std::uint8_t(ContactModel::HertzMindlin))
    throw InputError("checkpoint field law.model = " + std::to_string(int(l.model)) +
                     ": not a contact model of this build (a corrupt file or a newer version)");
  if (std::uint8_t(l.rolling_model) > std::uint8_t(RollingModel::ConstantTorque))
    throw InputError("checkpoint field law.rolling_model = " + std::to_string(int(l.rolling_model)) +
                     ": not a rolling model of this build (a corrupt file or a newer version)");
  return l;
}

void write_materials(FieldWriter& w, const Materials& m) {
  w.u64("materials", m.size());
  for (std::size_t k = 0; k < m.size(); ++k) {
    w.text("material.name", m.names[k]);
    write_law(w, m.laws[k]);
  }
  for (const ContactLawParams& l : m.pairs) {
    write_law(w, l);
    w.f64("pair.estar", l.pair_estar).f64("pair.gstar", l.pair_gstar);
  }
}

Materials read_materials(FieldReader& r) {
  Materials m;
  const std::uint64_t n = r.u64("materials");
  if (n < 2 || n > kMaxMaterials)
    throw InputError("checkpoint field materials = " + std::to_string(n) + ": not a count of materials (2 to " +
                     std::to_string(kMaxMaterials) + "; a corrupt file)");
  for (std::uint64_t k = 0; k < n; ++k) {
    m.names.push_back(r.text("material.name"));
    m.laws.push_back(read_law(r));
  }
  for (std::uint64_t k = 0; k < n * n; ++k) {
    ContactLawParams l = read_law(r);
    l.pair_estar = r.f64("pair.estar");
    l.pair_gstar = r.f64("pair.gstar");
    m.pairs.push_back(l);
  }
  return m;
}

void write_dissipation(FieldWriter& w, const Dissipation& d) { dissipation_fields(w, d); }
Dissipation read_dissipation(FieldReader& r) {
  Dissipation d;
  dissipation_fields(r, d);
  return d;
}

void write_macro(FieldWriter& w, const MacroState& m) { macro_fields(w, m); }
MacroState read_macro(FieldReader& r) {
  MacroState m;
  macro_fields(r, m);
  return m;
}

namespace {
// One value of a property, little-endian: ids as i64, vectors as f64[3], scalars as f64.
template <class T>
void put_value(std::string& out, const T& v) {
  if constexpr (std::is_same_v<T, GlobalId>) {
    put_le(out, std::uint64_t(v), 8);
  } else if constexpr (std::is_same_v<T, std::uint8_t>) {
    out.push_back(char(v));
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
  } else if constexpr (std::is_same_v<T, std::uint8_t>) {
    v = std::uint8_t(*in);
    return in + 1;
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
  else if constexpr (std::is_same_v<T, std::uint8_t>) return "u8";
  else if constexpr (std::is_same_v<T, real_t>) return "f64";
  else return "f64[3]";
}
template <class T>
constexpr std::size_t size_of() {
  return std::is_same_v<T, Vec3> ? 24 : std::is_same_v<T, std::uint8_t> ? 1 : 8;
}
// The material is in the records of a scene of several materials only (format 10).
bool recorded(const char* name, bool materials) { return materials || std::string_view(name) != "material"; }
}  // namespace

std::string particle_record_schema(bool materials) {
  std::string s;
  Particles probe;
  for_each_property(probe, [&](const char* name, auto& vec, Travel) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    if (recorded(name, materials)) s += (s.empty() ? "" : ";") + std::string(name) + ":" + type_of<T>();
  });
  return s;
}

std::size_t particle_record_bytes(bool materials) {
  std::size_t b = 0;
  Particles probe;
  for_each_property(probe, [&](const char* name, auto& vec, Travel) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    if (recorded(name, materials)) b += size_of<T>();
  });
  return b;
}

void write_particles(const Particles& p, std::size_t first, std::size_t n, std::string& out, bool materials) {
  out.reserve(out.size() + n * particle_record_bytes(materials));
  for (std::size_t a = first; a < first + n; ++a)
    for_each_property(p, [&](const char* name, const auto& vec, Travel) {
      if (recorded(name, materials)) put_value(out, vec[a]);
    });
}

void write_particles(const Particles& p, std::string& out, bool materials) {
  write_particles(p, 0, p.n_owned(), out, materials);
}

std::vector<RecordedProperty> particle_properties() {
  std::vector<RecordedProperty> out;
  Particles probe;
  for_each_property(probe, [&](const char* name, auto& vec, Travel) {
    using T = typename std::decay_t<decltype(vec)>::value_type;
    out.push_back({std::string(name) + ":" + type_of<T>(), size_of<T>()});
  });
  return out;
}

const char* read_particle_property(std::size_t k, const char* in, Particles& p, std::size_t a) {
  std::size_t at = 0;
  for_each_property(p, [&](const char*, auto& vec, Travel) {
    if (at++ == k) in = get_value(in, vec[a]);
  });
  return in;
}

std::string contact_record_schema(bool twisting) {
  return twisting ? "a:i64;b:i64;fs:f64[3];mr:f64[3];mt:f64" : "a:i64;b:i64;fs:f64[3];mr:f64[3]";
}
std::size_t contact_record_bytes(bool twisting) { return twisting ? 72 : 64; }

void write_contact(GlobalId a, GlobalId b, const ContactHistory& h, bool twisting, std::string& out) {
  put_value(out, a);
  put_value(out, b);
  put_value(out, h.fs);
  put_value(out, h.mr);
  if (twisting) put_value(out, h.mt);
}

void read_contacts(const char* in, std::size_t n, bool twisting, HistoryMap& history) {
  for (std::size_t k = 0; k < n; ++k) {
    GlobalId a, b;
    ContactHistory h;
    in = get_value(in, a);
    in = get_value(in, b);
    in = get_value(in, h.fs);
    in = get_value(in, h.mr);
    if (twisting) in = get_value(in, h.mt);
    history.insert(a, b, h);
  }
}

}  // namespace fabrica
