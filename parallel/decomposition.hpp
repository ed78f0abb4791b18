// Domain decomposition of the periodic cell over MPI ranks.
//
// The cell is divided into bins in reduced coordinates (x_k / L_k), so subdomain bounds follow
// the cell as it deforms. A bin's edge is at least half the interaction cutoff (2 Rmax + skin;
// made 1.25 times that, so that it stays so while an axis of the cell shrinks by 20 %),
// so every pair that can interact lies within two bins of each other along every axis
// (kReach = 2: the 124 neighbours of a bin, periodic). Half-cutoff bins let the subdomains be
// cut twice as finely as cutoff-wide bins would, for a better balance of the load.
// Each bin belongs to one rank:
//   - Cartesian: the ranks form a P1 x P2 x P3 grid (the factorisation of the rank count that
//     minimises the largest subdomain surface for this cell's aspect) and own blocks of bins;
//   - METIS: the bin graph (26-neighbour edges), weighted by the work in each bin, is
//     partitioned by METIS_PartGraphKway; bins then need not form boxes.
// The map is computed identically on every rank (METIS on rank 0, then broadcast).
#pragma once
#include "core/types.hpp"

#include <mpi.h>

#include <array>
#include <vector>

namespace fabrica {

enum class DecompositionKind { Cartesian, Metis };

inline constexpr int kReach = 2;  // bins per cutoff

class Decomposition {
 public:
  // Cartesian decomposition; throws std::runtime_error if the cell is too small for nranks
  // subdomains of at least one bin each.
  static Decomposition cartesian(int nranks, const Vec3& L, real_t cutoff);
  // METIS decomposition with one weight per bin (size dims product, in bin order).
  static Decomposition metis(int nranks, const Vec3& L, real_t cutoff,
                             const std::vector<double>& bin_work, MPI_Comm comm);
  // The bins for a cell and cutoff (the same for both kinds): edges >= cutoff / kReach.
  static std::array<int, 3> bin_dims(const Vec3& L, real_t cutoff);

  DecompositionKind kind() const { return kind_; }
  const std::array<int, 3>& dims() const { return dims_; }
  int bins() const { return dims_[0] * dims_[1] * dims_[2]; }
  const std::array<int, 3>& rank_grid() const { return grid_; }  // Cartesian only

  // Bin of a position wrapped into [0, L).
  int bin_of(const Vec3& x, const Vec3& L) const {
    int c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = int(x[k] / L[k] * dims_[k]);
      c[k] = c[k] < 0 ? 0 : (c[k] >= dims_[k] ? dims_[k] - 1 : c[k]);
    }
    return c[0] + dims_[0] * (c[1] + dims_[1] * c[2]);
  }
  int owner(int bin) const { return owner_[bin]; }
  // Distinct ranks, other than the bin's owner, that own a bin within kReach of 'bin' (periodic).
  const std::vector<int>& neighbour_ranks(int bin) const { return adj_ranks_[bin]; }
  // Distinct ranks, other than 'rank', that own a bin within kReach of one of rank's bins
  // (sorted): the only ranks it exchanges ghosts and migrants with. Symmetric: r is a partner
  // of s exactly when s is a partner of r.
  std::vector<int> partners(int rank) const;
  // True while bins are still at least cutoff / kReach wide in the current cell.
  bool fits(const Vec3& L, real_t cutoff) const;

 private:
  void finish(int nranks);  // fills adj_ranks_
  DecompositionKind kind_ = DecompositionKind::Cartesian;
  std::array<int, 3> dims_{1, 1, 1};
  std::array<int, 3> grid_{1, 1, 1};
  std::vector<int> owner_;
  std::vector<std::vector<int>> adj_ranks_;  // per bin: other ranks owning a neighbour bin
};

}  // namespace fabrica
