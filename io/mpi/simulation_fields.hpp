// The fields of a simulation's global section in a checkpoint (<prefix>.global,
// docs/checkpoint.md#format), declared once: simulation_global_fields (simulation_fields.cpp)
// lists them in the file's order, and writing (a FieldWriter), reading (a FieldReader, formats
// 6 to 11 with their defaults) and the comparison with the documentation
// (tests/io/test_checkpoint_format.cpp, from the layout a write records) all follow from it.
// The list's parts are lists of their own: the contact law (core/contact/params.hpp
// kLawParameters, with the format each field came in), the materials, the last measured state
// and the dissipation (io/mpi/state_fields.hpp).
#pragma once
#include "core/simulation.hpp"
#include "io/mpi/fields.hpp"

#include <cstdint>
#include <string>

namespace fabrica {

// What <prefix>.global holds: the state of a Simulation but its particles, contacts and
// per-rank accumulators (the other sections of the prefix).
struct SimulationGlobal {
  std::string particle_record, contact_record;  // the layouts of the records (state_fields.hpp)
  Vec3 cell_lengths = Vec3::Zero(), cell_strain_rate = Vec3::Zero();
  // A sheared cell (core/cell.hpp): its matrix H, velocity gradient G and strain integral, which
  // restore it exactly (PeriodicCell::restore_sheared); an orthorhombic cell has none of them.
  bool cell_sheared = false;
  Mat3 cell_matrix = Mat3::Zero(), cell_velocity_gradient = Mat3::Zero(), cell_strain = Mat3::Zero();
  SimulationParams params;  // law, dt, skin, gravity, local damping, walls, driven sets, materials
  std::int64_t step = 0, rebuilds = 0;
  real_t time = 0;
  MacroState macro;
  DecompositionRecord decomposition;
  EnergyAccount energy;  // all but gravity_work_local (per rank: <prefix>.gravity_work)
};

// A field of the list that not every file holds: one a later format added (a file of an older
// format lacks it, and this build reads as it says in its place), or one only some scenes write.
// The law's such fields are in kLawParameters ('since').
struct OptionalField {
  const char* name;
  std::uint32_t since;  // the checkpoint format that added it
  const char* when;     // what writes it, and what its absence reads as
};
inline constexpr OptionalField kWallMaterialField = {
    "wall.material", 10, "a scene of several materials; absent: material 0 (a scene of one material)"};
inline constexpr OptionalField kMaterialsField = {
    "materials", 10, "a scene of several materials (their count, names, laws and pairs); absent: one material"};
// A sheared cell's three fields, after cell.strain_rate, all or none.
inline constexpr OptionalField kCellMatrixField = {
    "cell.matrix", 11, "a sheared cell (with the next two); absent: an orthorhombic cell of cell.lengths"};
inline constexpr OptionalField kCellVelocityGradientField = {"cell.velocity_gradient", 11,
                                                             "a sheared cell; absent: diag(cell.strain_rate)"};
inline constexpr OptionalField kCellStrainField = {"cell.strain", 11, "a sheared cell; absent: none"};
inline constexpr OptionalField kOptionalGlobalFields[] = {kWallMaterialField, kMaterialsField, kCellMatrixField,
                                                          kCellVelocityGradientField, kCellStrainField};

// The global section of 'sim', to write.
SimulationGlobal simulation_global(const Simulation& sim);
// The cell the section holds: orthorhombic (lengths and strain rates) or sheared (H, G and the
// strain integral), the same bits as the saved one.
PeriodicCell cell_of(const SimulationGlobal& g);
void write_simulation_global(FieldWriter& w, const SimulationGlobal& g);
// Reads it back; 'where' names the section in messages ("PATH: section PREFIX"), and
// 'writer_ranks' bounds the decomposition's runs. Throws InputError naming the field for a
// field of another name or type, a count out of bounds or a material out of range.
SimulationGlobal read_simulation_global(FieldReader& r, const std::string& where, std::int32_t writer_ranks);

}  // namespace fabrica
