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
// This build's particle properties in record order (parallel/properties.hpp), the material
// included: "name:type" and bytes each (the readers of io/mpi/checkpoint_older.hpp).
struct RecordedProperty {
  std::string entry;
  std::size_t bytes;
};
std::vector<RecordedProperty> particle_properties();
// Reads property k (of that list) of particle a from 'in'; returns the byte after it.
const char* read_particle_property(std::size_t k, const char* in, Particles& p, std::size_t a);

// Contact records: the two ids (walls: -1 - wall index), the shear and rolling springs and,
// in a scene with twisting resistance (and only there: format 9), the twisting spring.
std::string contact_record_schema(bool twisting);
std::size_t contact_record_bytes(bool twisting);
void write_contact(GlobalId a, GlobalId b, const ContactHistory& h, bool twisting, std::string& out);
// Into 'history' (reset before, with its twisting springs kept if 'twisting').
void read_contacts(const char* in, std::size_t n, bool twisting, HistoryMap& history);

}  // namespace fabrica
