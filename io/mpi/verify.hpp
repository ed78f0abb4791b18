// Verification of a whole run file: every dataset read once, so that HDF5 checks each chunk's
// Fletcher-32 checksum (docs/output.md, "Checksums"). Serial; used by `fabrica info` and, on
// rank 0, by a restart before it continues the file.
#pragma once
#include <cstddef>
#include <string>

namespace fabrica {

struct VerifyReport {
  std::size_t datasets = 0;     // every dataset of the file
  std::size_t checksummed = 0;  // those with the Fletcher-32 filter (all but the scene text and empty ones)
  double bytes = 0;             // data read
  double seconds = 0;
};

// Throws InputError "<file>: <dataset>: the data do not match their checksum ..." naming the
// first damaged dataset (in name order).
VerifyReport verify_run_file(const std::string& path);

}  // namespace fabrica
