// Moving bytes between ranks. No physics here: ranks, counts and byte buffers only.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <vector>

namespace fabrica {

// Sends out[r] to every rank r and returns what each rank sent to this one (in[r]).
// Collective over comm (one MPI_Alltoall of sizes, then the bytes point to point with the ranks
// that send or receive any).
// Before: out.size() == comm size. After: in.size() == comm size.
std::vector<std::vector<char>> exchange_all(MPI_Comm comm, const std::vector<std::vector<char>>& out);

// Sends out[k] to partners[k] and returns what partners[k] sent to this one (in[k]): point to
// point with the partners only (sizes first, then bytes), no collective over comm.
// Before: the partner lists are symmetric (r lists s exactly when s lists r), every rank of the
// pattern calls it with the same tag. After: in.size() == partners.size().
std::vector<std::vector<char>> exchange_partners(MPI_Comm comm, const std::vector<int>& partners,
                                                 const std::vector<std::vector<char>>& out,
                                                 int tag);

// A plan for the same exchange repeated every step between fixed partners (ghost updates):
// what each partner gets and how many bytes each partner sends back.
struct NeighbourExchange {
  std::vector<int> send_ranks, recv_ranks;
  std::vector<std::size_t> recv_bytes;  // per recv rank
  std::vector<std::vector<char>> send_buf, recv_buf;
  std::vector<MPI_Request> requests;

  // Posts receives and sends of send_buf; after wait(), recv_buf holds the partners' bytes.
  void start(MPI_Comm comm, int tag);
  void wait();
  std::size_t bytes_sent() const;
};

}  // namespace fabrica
