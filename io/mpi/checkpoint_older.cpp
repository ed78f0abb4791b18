#include "io/mpi/checkpoint_older.hpp"

#include "core/errors.hpp"
#include "io/mpi/state_fields.hpp"

#include <algorithm>
#include <iterator>

namespace fabrica {
namespace {
// The fields of earlier particle records that this build derives instead of reading.
constexpr const char* kDerivedFields[] = {"inertia:f64", "inv_mass:f64", "inv_inertia:f64"};
}  // namespace

ParticleRecordReader::ParticleRecordReader(const std::string& schema, const std::string& where) {
  const std::vector<RecordedProperty> mine = particle_properties();
  std::vector<bool> seen(mine.size(), false);
  std::size_t at = 0;
  while (at <= schema.size()) {
    const std::size_t end = std::min(schema.find(';', at), schema.size());
    const std::string f = schema.substr(at, end - at);
    at = end + 1;
    const auto k =
        std::find_if(mine.begin(), mine.end(), [&](const RecordedProperty& p) { return p.entry == f; }) - mine.begin();
    if (std::size_t(k) < mine.size()) {
      if (seen[k]) throw InputError(where + ": particle record field '" + f + "' given twice");
      seen[k] = true;
      fields_.push_back({int(k), mine[k].bytes});
    } else if (std::find(std::begin(kDerivedFields), std::end(kDerivedFields), f) != std::end(kDerivedFields)) {
      fields_.push_back({-1, 8});
    } else {
      throw InputError(where + ": particle record field '" + f + "' is not one this build reads (its record: '" +
                       particle_record_schema() + "')");
    }
    bytes_ += fields_.back().bytes;
  }
  for (std::size_t k = 0; k < mine.size(); ++k)
    if (!seen[k] && mine[k].entry != "material:u8")  // one material: not recorded, 0
      throw InputError(where + ": the particle records have no field '" + mine[k].entry + "' (their layout: '" +
                       schema + "')");
}

void ParticleRecordReader::read(const char* in, std::size_t n, Particles& p) const {
  const std::size_t first = p.append_owned(n);
  for (std::size_t a = first; a < first + n; ++a)
    for (const Field& f : fields_) {
      if (f.property < 0) in += f.bytes;
      else in = read_particle_property(std::size_t(f.property), in, p, a);
    }
}

bool contact_records_twisting(const std::string& schema, const std::string& where) {
  // The twisting spring is in the records of a scene with twisting resistance only.
  const bool twisting = schema == contact_record_schema(true);
  if (!twisting && schema != contact_record_schema(false))
    throw InputError(where + ": written by a build with other contact records ('" + schema + "'; this build: '" +
                     contact_record_schema(false) + "' or '" + contact_record_schema(true) + "')");
  return twisting;
}

}  // namespace fabrica
