// How the ranks share a field grid (docs/fields.md "A share of the grid on each rank"): each
// rank holds the fixed-point sums of the nodes its own items reach (a box of node indices) and
// the finished fields of its slab of z-layers, the writers' split. The box's integers are sent
// to the slabs' owners through ring(), added there in any order (integer addition is exact), so
// that every field is the same bits on any number of ranks. core/ stays MPI-free: the MPI ring
// is parallel/mpi_grid_exchange.hpp.
#pragma once
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace fabrica {

class GridExchange {
 public:
  virtual ~GridExchange() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // P rounds (P = size()): in round k this rank sends the words pack(to, words) fills to rank
  // to = (rank + k) mod P and passes the words it receives from rank (rank - k) mod P to
  // take(from, words); round 0 is this rank to itself. Collective.
  using Pack = std::function<void(int to, std::vector<std::uint64_t>& words)>;
  using Take = std::function<void(int from, std::span<const std::uint64_t> words)>;
  virtual void ring(const Pack& pack, const Take& take) = 0;
};

// The z-layers [first, end) of the grid that rank r of P holds: as the writers split a
// dataset's rows (nz r / P to nz (r + 1) / P).
struct Layers {
  int first = 0, end = 0;
};
inline Layers slab_of(int nz, int r, int P) {
  return {int(std::int64_t(nz) * r / P), int(std::int64_t(nz) * (r + 1) / P)};
}

}  // namespace fabrica
