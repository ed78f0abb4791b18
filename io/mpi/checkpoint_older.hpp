// Checkpoints of the formats before this build's (docs/checkpoint.md#format): what formats 6 to
// 10 lack or hold otherwise, and how this build reads them. A file names its own layouts (the
// fields of its global sections, the fields of its records), so each difference is read by
// what the file says, not by its version number:
//   6 -> 7: the particle records carry inertia, inv_mass and inv_inertia, which this build
//     derives from mass and radius: ParticleRecordReader skips them;
//   7 -> 8: a law without law.model, law.poisson_ratio, law.rolling_model, law.rolling_damping
//     is the linear law with the elastic-plastic rolling spring (core/contact/params.hpp
//     kLawParameters 'since', io/mpi/state_fields.cpp read_law);
//   8 -> 9: a law without law.twisting_friction has no twisting resistance, and contact
//     records without the twisting spring (every contact record of a scene without twisting
//     resistance, in any format): contact_records_twisting;
//   9 -> 10: no material in the particle records (material 0), no wall.material, no materials
//     (io/mpi/simulation_fields.hpp kOptionalGlobalFields): a scene of one material;
//   10 -> 11: no cell.matrix, cell.velocity_gradient, cell.strain (kOptionalGlobalFields): an
//     orthorhombic cell of cell.lengths and cell.strain_rate, as every cell before sheared ones.
#pragma once
#include "core/particles.hpp"

#include <string>
#include <vector>

namespace fabrica {

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
    int property;       // index in particle_properties(); -1: a derived value, skipped
    std::size_t bytes;  // its size in the record
  };
  std::vector<Field> fields_;
  std::size_t bytes_ = 0;
};

// Whether contact records of layout 'schema' hold the twisting spring (this build's two
// layouts); throws InputError naming 'where' for another layout.
bool contact_records_twisting(const std::string& schema, const std::string& where);

}  // namespace fabrica
