// The field layout of the engine's state in a checkpoint (docs/checkpoint.md#format): the
// global values of a simulation, and the particle and contact records. Each is written through
// io/mpi/fields.hpp (named, typed, little-endian, no padding) so that another build reads it or
// refuses it naming the field.
#pragma once
#include "core/simulation.hpp"
#include "io/mpi/fields.hpp"

#include <string>
#include <vector>

namespace fabrica {

// Contact law, measures, dissipation: one field per member, named "<prefix>.<member>".
void write_law(FieldWriter& w, const ContactLawParams& law);
ContactLawParams read_law(FieldReader& r);
// The materials of a scene of several (format 10): names, own laws, and every pair's law with
// its effective moduli.
void write_materials(FieldWriter& w, const Materials& m);
Materials read_materials(FieldReader& r);
void write_macro(FieldWriter& w, const MacroState& m);
MacroState read_macro(FieldReader& r);
void write_dissipation(FieldWriter& w, const Dissipation& d);
Dissipation read_dissipation(FieldReader& r);

// Particle records: every property of parallel/properties.hpp, in its order (id i64, vectors
// f64[3], scalars f64, the material u8), the material only in a scene of several materials
// ('materials'; format 10): a record without it reads as material 0.
std::string particle_record_schema(bool materials = false);
std::size_t particle_record_bytes(bool materials = false);
void write_particles(const Particles& p, std::string& out, bool materials = false);  // the owned ones
// Owned particles [first, first + n) only.
void write_particles(const Particles& p, std::size_t first, std::size_t n, std::string& out, bool materials = false);
// The particle records of a checkpoint by the layout it names ('name:type;...'): this build's,
// or an earlier one whose other fields are values this build derives (checkpoint format 6:
// inertia, inv_mass and inv_inertia, all f64, derived from mass and radius since format 7),
// in any order. Throws InputError naming 'where' and the field for a field of another name or
// type, a property of this build missing, or a field twice.
class ParticleRecordReader {
 public:
  ParticleRecordReader(const std::string& schema, const std::string& where);
  std::size_t bytes() const { return bytes_; }
  // Appends n records from 'in' (n * bytes() bytes) as owned particles.
  void read(const char* in, std::size_t n, Particles& p) const;

 private:
  struct Field {
    int property;       // index in for_each_property's order; -1: a derived value, skipped
    std::size_t bytes;  // its size in the record
  };
  std::vector<Field> fields_;
  std::size_t bytes_ = 0;
};

// Contact records: the two ids (walls: -1 - wall index), the shear and rolling springs and,
// in a scene with twisting resistance (and only there: format 9), the twisting spring.
std::string contact_record_schema(bool twisting);
std::size_t contact_record_bytes(bool twisting);
void write_contact(GlobalId a, GlobalId b, const ContactHistory& h, bool twisting, std::string& out);
// Into 'history' (reset before, with its twisting springs kept if 'twisting').
void read_contacts(const char* in, std::size_t n, bool twisting, HistoryMap& history);

}  // namespace fabrica
