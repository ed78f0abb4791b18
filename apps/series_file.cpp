#include "apps/series_file.hpp"

#include "io/mpi/checkpoint.hpp"
#include "io/serial/write_check.hpp"
#include "parallel/guard.hpp"

#include <filesystem>

namespace fabrica {

SeriesFile::SeriesFile(MPI_Comm comm, std::string path, const std::string& header, int step_column,
                       std::int64_t resume_step)
    : comm_(comm), path_(std::move(path)) {
  int rank = 0;
  MPI_Comm_rank(comm_, &rank);
  root_ = rank == 0;
  agree(comm_, [&] {
    if (!root_) return;
    make_output_directory(std::filesystem::path(path_).parent_path().string());
    if (resume_step >= 0 && keep_series_through(path_, step_column, resume_step))
      open_checked(f_, path_, std::ios::app);
    else open_checked(f_, path_);
    if (f_.tellp() == 0) f_ << header;
    check_stream(f_, path_);
  });
  open_ = true;
}

void SeriesFile::check() {
  agree(comm_, [&] {
    if (root_ && open_) check_stream(f_, path_);
  });
}

void SeriesFile::sync() {
  agree(comm_, [&] {
    if (root_ && open_) sync_stream(f_, path_);
  });
}

void SeriesFile::close() {
  agree(comm_, [&] {
    if (root_ && open_) close_checked(f_, path_);
  });
  open_ = false;
}

}  // namespace fabrica
