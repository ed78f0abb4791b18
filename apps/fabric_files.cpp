#include "apps/fabric_files.hpp"

#include "io/mpi/checkpoint.hpp"
#include "io/serial/write_check.hpp"

namespace fabrica {

// The fabric files of one directory (rank 0 only; 'open' false: no files, null streams).
FabricFiles::FabricFiles(bool open, const std::filesystem::path& dir, const std::string& prefix, int rose_bins,
                         std::int64_t resume_step, bool principal) {
  if (!open) return;
  make_output_directory(dir.string());
  const std::filesystem::path f = dir / (prefix + "fabric.csv"), s = dir / (prefix + "sff.csv"),
                              r = dir / (prefix + "rose.csv");
  // On a restart, the rows after the checkpoint's step go (column 1 is the step), as in the
  // series; if any of the three files is missing, all three start again.
  bool kept = false;
  if (resume_step >= 0) {
    kept = true;
    for (const auto& p : {f, s, r})
      if (!keep_series_through(p.string(), 1, resume_step)) kept = false;
  }
  const auto mode = kept ? std::ios::app : std::ios::trunc;
  paths_ = {f.string(), s.string(), r.string()};
  open_checked(fabric_, paths_[0], mode);
  open_checked(sff_, paths_[1], mode);
  open_checked(rose_, paths_[2], mode);
  streams_ = {&fabric_, &sff_, &rose_};
  if (!kept) write_fabric_headers(streams_, rose_bins, principal);
  check();
}

void FabricFiles::check() {
  if (!streams_.fabric) return;
  check_stream(fabric_, paths_[0]), check_stream(sff_, paths_[1]), check_stream(rose_, paths_[2]);
}

void FabricFiles::flush() {
  if (!streams_.fabric) return;
  sync_stream(fabric_, paths_[0]), sync_stream(sff_, paths_[1]), sync_stream(rose_, paths_[2]);
}

void FabricFiles::close() {
  if (!streams_.fabric) return;
  close_checked(fabric_, paths_[0]), close_checked(sff_, paths_[1]), close_checked(rose_, paths_[2]);
  streams_ = {};
}

}  // namespace fabrica
