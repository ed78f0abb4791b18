// Agreement over the ranks (parallel/guard.hpp): an error thrown by one rank in a rank-local
// phase is thrown by every rank, with that rank's message and kind; sums of doubles are the
// same bits on every rank (MpiDomain::sum_all takes rank 0's). Registered at 1 to 4 ranks.
#include "core/errors.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_domain.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cstring>
#include <stdexcept>
#include <vector>

using namespace fabrica;

namespace {
int rank_of(MPI_Comm c) {
  int r;
  MPI_Comm_rank(c, &r);
  return r;
}
int size_of(MPI_Comm c) {
  int s;
  MPI_Comm_size(c, &s);
  return s;
}
}  // namespace

TEST(Agree, NoErrorReturnsOnEveryRank) {
  int calls = 0;
  agree(MPI_COMM_WORLD, [&] { ++calls; });
  EXPECT_EQ(calls, 1);
}

TEST(Agree, InputErrorOfTheLastRankReachesEveryRank) {
  const int last = size_of(MPI_COMM_WORLD) - 1;
  try {
    agree(MPI_COMM_WORLD, [&] {
      if (rank_of(MPI_COMM_WORLD) == last)
        throw InputError("file.toml: [x] y = 1: bad on rank " + std::to_string(last));
    });
    FAIL() << "no error on rank " << rank_of(MPI_COMM_WORLD);
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "file.toml: [x] y = 1: bad on rank " + std::to_string(last));
  }
}

TEST(Agree, LowestFailingRankWinsAndOtherErrorsBecomeCollective) {
  // Every rank but rank 0 fails with its own message: the lowest failing one's is taken.
  const int size = size_of(MPI_COMM_WORLD), rank = rank_of(MPI_COMM_WORLD);
  if (size == 1) GTEST_SKIP() << "needs 2 ranks";
  try {
    agree(MPI_COMM_WORLD, [&] {
      if (rank > 0) throw std::runtime_error("out.csv: cannot write on rank " + std::to_string(rank));
    });
    FAIL() << "no error on rank " << rank;
  } catch (const InputError&) { FAIL() << "a runtime_error became an InputError"; } catch (const CollectiveError& e) {
    EXPECT_EQ(std::string(e.what()), "out.csv: cannot write on rank 1");
  }
}

TEST(SumAll, SameBitsOnEveryRank) {
  // Terms of very different magnitudes and signs: any two summation orders would round apart.
  const int rank = rank_of(MPI_COMM_WORLD), size = size_of(MPI_COMM_WORLD);
  std::vector<double> v(64);
  for (std::size_t k = 0; k < v.size(); ++k)
    v[k] = (k % 2 ? -1.0 : 1.0) * std::ldexp(1.0 + 0.1 * double(rank), int(k % 7) * 20 - 60) +
        0.3 * double(rank + 1) / double(k + 1);
  MpiDomain d(MPI_COMM_WORLD);
  d.sum_all(std::span<double>(v));
  std::vector<double> all(v.size() * std::size_t(size));
  MPI_Allgather(v.data(), int(v.size()), MPI_DOUBLE, all.data(), int(v.size()), MPI_DOUBLE, MPI_COMM_WORLD);
  for (int r = 1; r < size; ++r)
    EXPECT_EQ(std::memcmp(all.data(), all.data() + std::size_t(r) * v.size(), v.size() * sizeof(double)), 0)
        << "rank " << r << " holds other bits than rank 0";
}
