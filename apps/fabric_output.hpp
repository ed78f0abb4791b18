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

void write_fabric_headers(const FabricStreams& out, int rose_bins);
// 'stage' and 'eps1' (the axial strain of the stage's reference) label the rows.
void write_fabric_rows(const FabricStreams& out, const std::string& stage, std::int64_t step, real_t eps1,
                       const FabricResult& r);

}  // namespace fabrica
