#include "parallel/exchange.hpp"

#include <stdexcept>

namespace fabrica {

std::vector<std::vector<char>> exchange_all(MPI_Comm comm, const std::vector<std::vector<char>>& out) {
  constexpr int kTag = 7131;
  int size = 1, rank = 0;
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &rank);
  std::vector<long long> scount(size), rcount(size);
  for (int r = 0; r < size; ++r) scount[r] = static_cast<long long>(out[r].size());
  MPI_Alltoall(scount.data(), 1, MPI_LONG_LONG, rcount.data(), 1, MPI_LONG_LONG, comm);
  // The bytes point to point, from out[r] straight into in[r]: no packed copy of all that is
  // sent or received (memory at large N: a set-up's directory exchange moves every particle).
  std::vector<std::vector<char>> in(size);
  std::vector<MPI_Request> req;
  req.reserve(2 * std::size_t(size));
  for (int r = 0; r < size; ++r)  // checked before any request is posted
    if (scount[r] > INT32_MAX || rcount[r] > INT32_MAX)
      throw std::runtime_error("exchange_all: more than 2 GiB between two ranks in one exchange");
  for (int r = 0; r < size; ++r) {
    if (r == rank || rcount[r] == 0) continue;
    in[r].resize(std::size_t(rcount[r]));
    MPI_Irecv(in[r].data(), int(rcount[r]), MPI_BYTE, r, kTag, comm, &req.emplace_back());
  }
  for (int r = 0; r < size; ++r) {
    if (r == rank || scount[r] == 0) continue;
    MPI_Isend(out[r].data(), int(scount[r]), MPI_BYTE, r, kTag, comm, &req.emplace_back());
  }
  in[rank] = out[rank];
  MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE);
  return in;
}

std::vector<std::vector<char>> exchange_partners(MPI_Comm comm, const std::vector<int>& partners,
                                                 const std::vector<std::vector<char>>& out, int tag) {
  const std::size_t n = partners.size();
  std::vector<long long> scount(n), rcount(n);
  std::vector<MPI_Request> req(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    if (out[k].size() > std::size_t(INT32_MAX))
      throw std::runtime_error("exchange_partners: more than 2 GiB to one rank");
    scount[k] = static_cast<long long>(out[k].size());
    MPI_Irecv(&rcount[k], 1, MPI_LONG_LONG, partners[k], tag, comm, &req[k]);
  }
  for (std::size_t k = 0; k < n; ++k) MPI_Isend(&scount[k], 1, MPI_LONG_LONG, partners[k], tag, comm, &req[n + k]);
  MPI_Waitall(int(2 * n), req.data(), MPI_STATUSES_IGNORE);
  std::vector<std::vector<char>> in(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (rcount[k] > INT32_MAX) throw std::runtime_error("exchange_partners: more than 2 GiB from one rank");
    in[k].resize(std::size_t(rcount[k]));
    MPI_Irecv(in[k].data(), int(rcount[k]), MPI_BYTE, partners[k], tag + 1, comm, &req[k]);
  }
  for (std::size_t k = 0; k < n; ++k)
    MPI_Isend(out[k].data(), int(out[k].size()), MPI_BYTE, partners[k], tag + 1, comm, &req[n + k]);
  MPI_Waitall(int(2 * n), req.data(), MPI_STATUSES_IGNORE);
  return in;
}

void NeighbourExchange::start(MPI_Comm comm, int tag, const std::vector<std::vector<BytePiece>>& recv_pieces) {
  requests.clear();
  for (std::size_t k = 0; k < recv_ranks.size(); ++k)
    for (const BytePiece& piece : recv_pieces[k]) {
      requests.emplace_back();
      MPI_Irecv(piece.at, int(piece.bytes), MPI_BYTE, recv_ranks[k], tag, comm, &requests.back());
    }
  for (std::size_t k = 0; k < send_ranks.size(); ++k) {
    std::size_t at = 0;
    for (std::size_t bytes : send_pieces[k]) {
      requests.emplace_back();
      MPI_Isend(send_buf[k].data() + at, int(bytes), MPI_BYTE, send_ranks[k], tag, comm, &requests.back());
      at += bytes;
    }
  }
}

void NeighbourExchange::wait() { MPI_Waitall(int(requests.size()), requests.data(), MPI_STATUSES_IGNORE); }

std::size_t NeighbourExchange::bytes_sent() const {
  std::size_t b = 0;
  for (const auto& s : send_buf) b += s.size();
  return b;
}

}  // namespace fabrica
