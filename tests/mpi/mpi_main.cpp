// GoogleTest main for MPI tests: every rank runs every test (tests call collectives), only rank 0
// prints, and the program fails on every rank if any rank failed.
#include "parallel/mpi_context.hpp"

#include <gtest/gtest.h>

int main(int argc, char** argv) {
  fabrica::MpiContext mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (mpi.rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  int failed = RUN_ALL_TESTS() != 0;
  int any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, mpi.comm());
  if (failed) std::fprintf(stderr, "rank %d: some tests failed\n", mpi.rank());
  return any;
}
