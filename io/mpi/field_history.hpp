// The previous field instant's particle positions, from which a run's displacement fields are
// computed at the next instant ([fields], docs/fields.md "Fields during a run").
//
// Particles migrate between ranks between two instants, so the positions are not kept by the
// rank that owned a particle then but by a home rank chosen from its id (id mod P): at an instant
// every rank sends the id, position and radius of each particle it owns to the particle's home
// rank (one all-to-all), and each home rank pairs what it receives with what it kept from the
// previous instant of the same case. The pairs are the motions of its ids, whose displacement
// terms it adds to the fields itself: the sums of displacement_fields() are exact, so the fields
// are the same bits whichever rank adds a term (core/coarse_grain.hpp). Between instants nothing
// is done; the positions take 32 bytes a particle over all ranks.
#pragma once
#include "core/coarse_grain.hpp"
#include "core/particles.hpp"

#include <mpi.h>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace fabrica {

class FieldHistory {
 public:
  // A field instant: its case (of run.h5), step, cell lengths and cell matrix (orthorhombic:
  // diag(lengths)).
  struct Instant {
    std::string case_name;
    std::int64_t step = 0;
    Vec3 lengths = Vec3::Zero();
    Mat3 matrix = Mat3::Zero();  // zero: not given (diag(lengths))
    Mat3 cell_matrix() const { return matrix.isZero(0) ? Mat3(lengths.asDiagonal()) : matrix; }
  };
  // What advance() finds: the instant the motions start from (none at the first instant of a
  // case) and this rank's motions (its home ids found at both instants; x0 as kept, x1 and the
  // radius now).
  struct Step {
    std::optional<Instant> from;
    std::vector<CgMotion> motions;
  };

  // At instant 'now': the motions since the instant kept, if it is of the same case; then keeps
  // the owned particles of 'p' at 'now'. Collective over 'comm' (every rank, the same 'now').
  Step advance(MPI_Comm comm, const Particles& p, const Instant& now);

  // The instant kept (none before the first, or after clear()): the same on every rank.
  const std::optional<Instant>& instant() const { return at_; }
  // This rank's kept positions (its home ids, in increasing order) and the ids.
  std::span<const GlobalId> ids() const { return id_; }
  std::span<const Vec3> positions() const { return x_; }

  // Keeps 'ids' at positions 'x' as instant 'at', from any split over the ranks (a checkpoint's
  // records): each goes to its home rank. Collective over 'comm'.
  void adopt(MPI_Comm comm, const Instant& at, std::span<const GlobalId> ids, std::span<const Vec3> x);
  // The instant kept becomes one of case 'case_name' (the same positions).
  void rename(const std::string& case_name);
  void clear();

 private:
  std::optional<Instant> at_;
  std::vector<GlobalId> id_;  // increasing
  std::vector<Vec3> x_;
};

}  // namespace fabrica
