// The fabric files of a run (docs/fabric.md): rank 0 writes them, every write checked.
#pragma once
#include "apps/fabric_output.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace fabrica {

// DIR/<prefix>fabric.csv, sff.csv, rose.csv with their headers (when 'open'; rank 0). With
// 'resume_step' >= 0 (a restart in the stage that writes them) the existing files keep their
// rows up to that step (the others are written again) and are appended to. 'principal': a run
// that shears the cell, whose fabric.csv has the principal columns (write_fabric_headers).
class FabricFiles {
 public:
  FabricFiles(bool open, const std::filesystem::path& dir, const std::string& prefix, int rose_bins,
              std::int64_t resume_step = -1, bool principal = false);
  const FabricStreams* streams() const { return streams_.fabric ? &streams_ : nullptr; }
  // Each throws a WriteError naming the file if a write so far failed (io/serial/write_check.hpp).
  void check();  // the rows so far written
  void flush();  // the rows so far on disk (before a checkpoint)
  void close();  // synced and closed

 private:
  std::array<std::string, 3> paths_;
  std::ofstream fabric_, sff_, rose_;
  FabricStreams streams_;
};

}  // namespace fabrica
