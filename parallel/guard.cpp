#include "parallel/guard.hpp"

#include "io/errors.hpp"

#include <cstdio>
#include <exception>

namespace fabrica {

int run_guarded(const MpiContext& mpi, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    if (mpi.rank() == 0) std::fprintf(stderr, "fabrica: error: %s\n", e.what());
    return 1;
  } catch (const CollectiveError& e) {
    if (mpi.rank() == 0) std::fprintf(stderr, "fabrica: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    if (mpi.size() > 1) {
      std::fprintf(stderr, "fabrica: error on rank %d of %d: %s\n", mpi.rank(), mpi.size(), e.what());
      std::fflush(stderr);
      MPI_Abort(mpi.comm(), 1);
    }
    std::fprintf(stderr, "fabrica: error: %s\n", e.what());
    return 1;
  }
}

}  // namespace fabrica
