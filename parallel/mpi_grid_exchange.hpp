// The ring of core/grid_exchange.hpp over an MPI communicator: in each round one MPI_Sendrecv
// of the word count and then of the words (in pieces of at most 2^27 words, the int counts of
// MPI), so that a rank holds one message at a time whatever the rank count.
#pragma once
#include "core/grid_exchange.hpp"

#include <mpi.h>

namespace fabrica {

class MpiGridExchange final : public GridExchange {
 public:
  explicit MpiGridExchange(MPI_Comm comm);
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void ring(const Pack& pack, const Take& take) override;

 private:
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
};

}  // namespace fabrica
