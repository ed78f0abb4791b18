#include "parallel/guard.hpp"

#include "core/errors.hpp"
#include "core/fault.hpp"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <thread>

namespace fabrica {
namespace {

bool g_skip_finalize = false;

// True if every rank of 'comm' arrives within the wait (a non-blocking barrier, polled).
bool all_arrive(MPI_Comm comm) {
  double wait = 5;
  if (const char* w = std::getenv("FABRICA_ERROR_WAIT")) wait = std::atof(w) > 0 ? std::atof(w) : wait;
  MPI_Request req;
  MPI_Ibarrier(comm, &req);
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    int done = 0;
    MPI_Test(&req, &done, MPI_STATUS_IGNORE);
    if (done) return true;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > wait) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

int fail(const MpiContext& mpi, MPI_Comm guard, const char* what) {
  if (mpi.size() > 1 && !all_arrive(guard)) {
    std::fprintf(stderr, "fabrica: error on rank %d of %d: %s\n", mpi.rank(), mpi.size(), what);
    std::fprintf(stderr, "fabrica: the other ranks did not meet this error: ending every rank\n");
    std::fflush(stderr);
    MPI_Abort(mpi.comm(), 1);
  }
  if (mpi.rank() == 0) std::fprintf(stderr, "fabrica: error: %s\n", what);
  if (g_skip_finalize) {
    std::fflush(stdout);
    std::fflush(stderr);
    std::_Exit(1);
  }
  return 1;
}

}  // namespace

int run_guarded(const MpiContext& mpi, const std::function<int()>& body) {
  std::signal(SIGXFSZ, SIG_IGN);
  set_fault_rank(mpi.rank());
  MPI_Comm guard = MPI_COMM_NULL;
  MPI_Comm_dup(mpi.comm(), &guard);
  int rc = 1;
  try {
    rc = body();
  } catch (const std::exception& e) { rc = fail(mpi, guard, e.what()); }
  MPI_Comm_free(&guard);
  return rc;
}

void exit_without_finalize_on_error() { g_skip_finalize = true; }

void agree(MPI_Comm comm, const std::function<void()>& phase) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::string msg;
  int input = 0;
  try {
    phase();
  } catch (const InputError& e) { msg = e.what(), input = 1; } catch (const std::exception& e) {
    msg = e.what();
    if (msg.empty()) msg = "unknown error";
  }
  int first = msg.empty() ? size : rank;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return;
  int len = int(msg.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  MPI_Bcast(&input, 1, MPI_INT, first, comm);
  msg.resize(std::size_t(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, first, comm);
  if (input) throw InputError(msg);
  throw CollectiveError(msg);
}

}  // namespace fabrica
