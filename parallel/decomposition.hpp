// Domain decomposition of the periodic cell over MPI ranks.
//
// The cell is divided into bins in reduced coordinates (x_k / L_k; a sheared cell's fractional
// coordinates, BinFrame), so subdomain bounds follow the cell as it deforms. A bin's edge is at least half the interaction cutoff (2 Rmax + skin;
// made 1.25 times that, so that it stays so while an axis of the cell shrinks by 20 %),
// so every pair that can interact lies within two bins of each other along every axis
// (kReach = 2: the 124 neighbours of a bin, periodic). Half-cutoff bins let the subdomains be
// cut twice as finely as cutoff-wide bins would, for a better balance of the load.
// Each bin belongs to one rank:
//   - Cartesian: the ranks form a P1 x P2 x P3 grid (the factorisation of the rank count that
//     minimises the largest subdomain surface for this cell's aspect) and own blocks of bins:
//     along each axis the bins are cut into Pk runs of consecutive (periodic) bin planes, of
//     equal length, or - given the work of each bin - placed so that the heaviest slab of the
//     axis is as light as whole bin planes allow (balanced_runs). Everything it holds is per
//     bin plane or per rank (a bin's owner from the run of each of its coordinates, its
//     neighbour ranks from the runs within reach of each), not per bin: the bins are as fine
//     as the cutoff allows at any specimen size, and the balance is as fine as they are;
//   - METIS: the bin graph (26-neighbour edges), weighted by the work in each bin, is
//     partitioned by METIS_PartGraphKway; bins then need not form boxes. Its map is a table per
//     bin, on every rank, so its bins are coarsened to at most 32,768 (docs/large.md).
// The map is computed identically on every rank (METIS on rank 0, then broadcast).
#pragma once
#include "core/cell.hpp"
#include "core/types.hpp"

#include <mpi.h>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace fabrica {

enum class DecompositionKind { Cartesian, Metis };

// The coordinates bins are cut in. An orthorhombic cell: positions and lengths themselves. A
// sheared cell: y_k = s_k h_k, the fractional coordinates times the heights between opposite
// faces, so that y_k is a distance from the face s_k = 0 along its normal, and a bin is the
// parallelepiped between two planes of each family; the same on every rank (the same bits of
// the cell).
struct BinFrame {
  bool sheared = false;
  Vec3 L;       // the lengths the bins divide: orthorhombic, the edges; sheared, the heights
  Mat3 to_bin;  // sheared: diag(h) H^-1
  // The largest eigenvalue of N N^T, N the unit face normals as rows (1 when orthogonal): the
  // per-axis distances d_k from a point to a bin bound its distance D by sum d_k^2 <= this D^2.
  real_t normal_spread = 1;
  explicit BinFrame(const PeriodicCell& cell);
  Vec3 coords(const Vec3& x) const { return sheared ? Vec3(to_bin * x) : x; }
};

inline constexpr int kReach = 2;  // bins per cutoff

// Along each axis k, the first bin of each of the Pk runs of the rank grid, ascending; run j
// ends where run j + 1 starts, and the last one wraps round to cuts[k][0] (periodic).
using CartesianCuts = std::array<std::vector<int>, 3>;

// Along each axis k, the work summed over each of the dims[k] bin planes normal to k: all that
// the runs of a tensor-product grid depend on (dims[0] + dims[1] + dims[2] values, not one per
// bin, so that the sums over the ranks stay small at 10^6 spheres).
using PlaneWork = std::array<std::vector<std::int64_t>, 3>;

// 'parts' runs of consecutive planes (periodic, each at least one plane) of weights w, whose
// heaviest run is as light as possible; among the best, the one starting at the lowest plane.
// Returns the first plane of each run, ascending. Exact (integer weights): the same on every
// rank.
std::vector<int> balanced_runs(std::span<const std::int64_t> w, int parts);
// The same, near the runs 'current' (first planes, ascending, one per part): among the splits
// whose heaviest run is at most 1 % (rounded down) above the lightest possible, the one that
// moves the least weight from one run to another (ties: the one from the lowest start). Balancing
// the runs of a running decomposition this way moves the particles of the few planes the load
// asks for, not a relabelled half of every subdomain: on a uniform packing many splits are
// about as light, and the lightest can start at any plane (869,376 spheres on 8 ranks: 72 %
// of each rank's particles moved at the first cut check, 32 MB in flight per rank).
std::vector<int> balanced_runs(std::span<const std::int64_t> w, int parts, std::span<const int> current);

class Decomposition {
 public:
  // Cartesian decomposition; throws std::runtime_error if the cell is too small for nranks
  // subdomains of at least one bin each.
  static Decomposition cartesian(int nranks, const Vec3& L, real_t cutoff);
  // The same grid of ranks, its runs along each axis placed by the work of the bin planes
  // (balanced_runs of plane_work[k], which holds dims()[k] values); throws std::logic_error if
  // the sizes do not match this cell's bins. Given the runs of the decomposition in use (on the
  // same bins), the runs are placed near them (balanced_runs with 'current').
  static Decomposition by_work(int nranks, const Vec3& L, real_t cutoff, const PlaneWork& plane_work,
                               const CartesianCuts* current = nullptr);
  // The same grid of ranks with the given runs (a decomposition saved in a checkpoint); throws
  // std::runtime_error if they do not fit this cell's bins and rank grid.
  static Decomposition cartesian(int nranks, const Vec3& L, real_t cutoff, const CartesianCuts& cuts);
  // METIS decomposition with one weight per bin (size dims product, in bin order).
  static Decomposition metis(int nranks, const Vec3& L, real_t cutoff, const std::vector<double>& bin_work,
                             MPI_Comm comm);
  // The bins of a kind of decomposition for a cell and cutoff: edges >= cutoff / kReach (and for
  // METIS at most 32,768 bins).
  static std::array<int, 3> bin_dims(const Vec3& L, real_t cutoff, DecompositionKind kind);
  // One rank owning every bin of 'kind' for this cell: its bins, to sum work over.
  static Decomposition shape(DecompositionKind kind, const Vec3& L, real_t cutoff);

  DecompositionKind kind() const { return kind_; }
  const std::array<int, 3>& dims() const { return dims_; }
  int bins() const { return dims_[0] * dims_[1] * dims_[2]; }
  const std::array<int, 3>& rank_grid() const { return grid_; }  // Cartesian only
  const CartesianCuts& cuts() const { return cuts_; }            // Cartesian only

  // Bin of a position wrapped into the cell (any shape).
  int bin_of(const Vec3& x, const BinFrame& f) const { return bin_of(f.coords(x), f.L); }
  // Bin of a position wrapped into [0, L) (an orthorhombic cell, or BinFrame coordinates).
  int bin_of(const Vec3& x, const Vec3& L) const {
    int c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = int(x[k] / L[k] * dims_[k]);
      c[k] = c[k] < 0 ? 0 : (c[k] >= dims_[k] ? dims_[k] - 1 : c[k]);
    }
    return c[0] + dims_[0] * (c[1] + dims_[1] * c[2]);
  }
  int owner(int bin) const {
    if (kind_ == DecompositionKind::Metis) return owner_[bin];
    return owner_at(bin % dims_[0], bin / dims_[0] % dims_[1], bin / (dims_[0] * dims_[1]));
  }
  // The owner of the bin at coordinates (x, y, z), each within [0, dims()[k]).
  int owner_at(int x, int y, int z) const {
    if (kind_ == DecompositionKind::Metis) return owner_[x + dims_[0] * (y + dims_[1] * z)];
    return run_[0][x] + grid_[0] * (run_[1][y] + grid_[1] * run_[2][z]);
  }
  // Distinct ranks, other than the bin's owner, that own a bin within kReach of 'bin' (periodic),
  // ascending.
  const std::vector<int>& neighbour_ranks(int bin) const {
    if (kind_ == DecompositionKind::Metis) return adj_ranks_[bin];
    const int x = bin % dims_[0], y = bin / dims_[0] % dims_[1], z = bin / (dims_[0] * dims_[1]);
    return adj_ranks_[near_[0][x] + near_count_[0] * (near_[1][y] + near_count_[1] * near_[2][z])];
  }
  // Distinct ranks, other than 'rank', that own a bin within kReach of one of rank's bins
  // (sorted): the only ranks it exchanges ghosts and migrants with. Symmetric: r is a partner
  // of s exactly when s is a partner of r.
  std::vector<int> partners(int rank) const;
  // True while bins are still at least cutoff / kReach wide in the current cell.
  bool fits(const Vec3& L, real_t cutoff) const;

 private:
  // dims_ (Cartesian bins) and grid_
  static Decomposition grid(int nranks, const Vec3& L, real_t cutoff);
  void own_by_cuts();  // Cartesian: run_, near_, near_count_ and adj_ranks_ from cuts_
  void finish();       // METIS: adj_ranks_ per bin from owner_
  DecompositionKind kind_ = DecompositionKind::Cartesian;
  std::array<int, 3> dims_{1, 1, 1};
  std::array<int, 3> grid_{1, 1, 1};
  CartesianCuts cuts_;
  std::vector<int> owner_;  // METIS: per bin
  // Cartesian, per axis k: the run of each bin plane; and the class of each plane, one class
  // per distinct set of runs within kReach of a plane (near_count_[k] classes).
  std::array<std::vector<int>, 3> run_;
  std::array<std::vector<int>, 3> near_;
  std::array<int, 3> near_count_{1, 1, 1};
  // METIS: per bin, the other ranks owning a bin within reach. Cartesian: the same per
  // combination of the three axes' classes (at most (2 P1)(2 P2)(2 P3) lists).
  std::vector<std::vector<int>> adj_ranks_;
};

}  // namespace fabrica
