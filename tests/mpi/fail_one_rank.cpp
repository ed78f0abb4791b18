// An exception on one rank while the others wait in a collective must end every rank with that
// rank's message and a non-zero exit (ctest: WILL_FAIL-free check through expect_error.sh, with
// a timeout so that a hang fails the test).
#include "parallel/guard.hpp"

#include <stdexcept>

int main(int argc, char** argv) {
  fabrica::MpiContext mpi(argc, argv);
  return fabrica::run_guarded(mpi, [&]() -> int {
    if (mpi.rank() == mpi.size() - 1) throw std::runtime_error("injected failure");
    MPI_Barrier(mpi.comm());  // the other ranks wait here forever unless the failing one aborts
    return 0;
  });
}
