// CSV output of the fabric analysis (core/fabric.hpp): fabric.csv (one row per network),
// sff.csv (one row) and rose.csv (two rows per network) per analysed instant. The columns are
// documented in docs/fabric.md. Used by the triaxial application and by `fabrica fabric`.
#pragma once
#include "core/fabric.hpp"

#include <cstdint>
#include <ostream>
#include <string>

namespace fabrica {

struct FabricStreams {
  std::ostream* fabric = nullptr;
  std::ostream* sff = nullptr;
  std::ostream* rose = nullptr;
};

// 'principal' (a run that shears the cell): fabric.csv ends with the non-coaxiality of each
// network's fabric and the specimen's stress, and the principal values of the four anisotropy
// tensors: noncoaxiality,ac_1,ac_2,ac_3,ab_1,ab_2,ab_3,an_1,an_2,an_3,at_1,at_2,at_3
// (docs/fabric.md); without it the files are those of before sheared cells.
void write_fabric_headers(const FabricStreams& out, int rose_bins, bool principal = false);
// 'stage' and 'eps1' (the axial strain of the stage's reference) label the rows.
void write_fabric_rows(const FabricStreams& out, const std::string& stage, std::int64_t step, real_t eps1,
                       const FabricResult& r, bool principal = false);

}  // namespace fabrica
