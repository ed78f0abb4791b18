#include "parallel/mpi_grid_exchange.hpp"

#include <algorithm>

namespace fabrica {

MpiGridExchange::MpiGridExchange(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

void MpiGridExchange::ring(const Pack& pack, const Take& take) {
  constexpr std::uint64_t kPiece = std::uint64_t(1) << 27;
  constexpr int kTagCount = 7301, kTagWords = 7302;  // apart from the domain's messages
  std::vector<std::uint64_t> out, in;
  for (int k = 0; k < size_; ++k) {
    const int to = (rank_ + k) % size_, from = (rank_ - k + size_) % size_;
    out.clear();
    pack(to, out);
    if (k == 0) {  // this rank to itself
      take(from, out);
      continue;
    }
    std::uint64_t n_out = out.size(), n_in = 0;
    MPI_Sendrecv(&n_out, 1, MPI_UINT64_T, to, kTagCount, &n_in, 1, MPI_UINT64_T, from, kTagCount, comm_,
                 MPI_STATUS_IGNORE);
    in.resize(n_in);
    // Every piece posted at once: each side counts the pieces of its own message.
    std::vector<MPI_Request> req;
    for (std::uint64_t b = 0; b < n_in; b += kPiece)
      MPI_Irecv(in.data() + b, int(std::min(kPiece, n_in - b)), MPI_UINT64_T, from, kTagWords, comm_,
                &req.emplace_back());
    for (std::uint64_t a = 0; a < n_out; a += kPiece)
      MPI_Isend(out.data() + a, int(std::min(kPiece, n_out - a)), MPI_UINT64_T, to, kTagWords, comm_,
                &req.emplace_back());
    MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE);
    take(from, in);
  }
}

}  // namespace fabrica
