// Moving bytes between ranks. No physics here: ranks, counts and byte buffers only.
#pragma once
#include "parallel/byte_buffer.hpp"

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
                                                 const std::vector<std::vector<char>>& out, int tag);

// A plan for the same exchange repeated every step between fixed partners (ghost updates):
// what each partner gets, cut into pieces, and where each partner's pieces go. The pieces of
// one message are sent as separate messages of one tag, which MPI matches in order between
// two ranks (non-overtaking), so the receiver's k-th piece from a rank is the sender's k-th.
struct NeighbourExchange {
  std::vector<int> send_ranks, recv_ranks;
  std::vector<std::vector<char>> send_buf;            // per send rank
  std::vector<std::vector<std::size_t>> send_pieces;  // per send rank: piece sizes, in order
  std::vector<MPI_Request> requests;

  // Posts one receive per piece of recv_pieces[k] (from recv_ranks[k]) straight into its place,
  // and one send per piece of send_buf[k]; after wait(), every place holds its bytes.
  // Before: the pieces' sizes sum to send_buf[k].size(); the places stay valid until wait().
  void start(MPI_Comm comm, int tag, const std::vector<std::vector<BytePiece>>& recv_pieces);
  void wait();
  std::size_t bytes_sent() const;
};

}  // namespace fabrica
