// The seam between the physics (core/) and the communication (parallel/). Simulation::step()
// calls these hooks at fixed points; the serial domain (core/serial_domain.hpp) does nothing,
// the MPI domain
// (parallel/mpi_domain.hpp) exchanges ghosts, migrates particles with their contact history and
// reduces sums. Every rank calls every hook at the same point of every step, so the
// collectives inside are never behind data-dependent control flow.
#pragma once
#include "core/cell.hpp"
#include "core/history_map.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace fabrica {

// How the particles handed to Domain::adopt are held by the ranks.
enum class Holding {
  Whole,  // every rank the same complete set
  Share,  // each rank a disjoint part
};

// What a restart on the same rank count needs to remake a decomposition (a checkpoint field):
// the cell lengths it was made for and, for a Cartesian one whose runs follow the work, the
// first bin of each run along each axis (Decomposition::cuts, flattened: P1, then P2, then P3
// values), and the rebuilds since the runs were last checked against the work (so that a
// restart checks them at the same rebuilds as the run it continues; -1: not checked yet).
// Zero lengths: nothing to remake (one rank, METIS, or another rank count).
struct DecompositionRecord {
  Vec3 lengths = Vec3::Zero();
  std::vector<std::int32_t> cuts;  // empty: runs of equal length
  std::int64_t since_check = -1;
  bool empty() const { return lengths.isZero(); }
};

// The drift of a step (x <- x + dt v, then mapped by the cell's deformation when 'deform'),
// which a forward ghost update may apply to the ghosts instead of carrying their positions
// (Domain::begin_ghost_update).
struct GhostDrift {
  real_t dt = 0;
  CellStep deformation;
  bool deform = false;
};

class Domain {
 public:
  virtual ~Domain() = default;

  // Before: owned particles' x, v, w are current. After: every ghost has its owner's x, v, w.
  void update_ghosts(Particles& p) {
    begin_ghost_update(p, nullptr);
    end_ghost_update(p);
  }

  // The same in two halves, so that work which reads no ghost (and writes no x, v, w) can run
  // while the messages travel: begin sends the owned particles' x, v, w; end receives them
  // into the ghosts. Other hooks may be called in between (their collectives let the messages
  // progress), but not adopt, redistribute or build_ghosts; and nothing in between may read or
  // write the ghosts' x, v, w, nor reallocate p's arrays: the MPI domain receives them in place.
  // Given a drift, begin sends v and w alone, and end advances each ghost's position itself
  // (drifted(), core/integrator.hpp): before, every owned particle has moved by exactly that
  // drift since the ghosts last had its position, with the velocity it now has (a step's drift:
  // the update comes after it, and nothing else moved the owned particles).
  virtual void begin_ghost_update(Particles& p, const GhostDrift* drift) = 0;
  virtual void end_ghost_update(Particles& p) = 0;

  // The largest value over all ranks (every rank calls it once per step).
  virtual real_t max_all(real_t local) = 0;

  // Element-wise maximum over all ranks, in place.
  virtual void max_all(std::span<double> values) = 0;

  // Element-wise sum over all ranks, in place; the same bits on every rank (rank 0's result).
  virtual void sum_all(std::span<double> values) = 0;

  // Element-wise sum of integers over all ranks, in place: exact, so the same on any number of
  // ranks (with core/exact_sum.hpp, exact sums of doubles; used by core/fabric.cpp).
  virtual void sum_all(std::span<std::int64_t> values) = 0;

  // At start-up. Before, with Holding::Whole: every rank holds the same complete set of
  // particles, as generated, wrapped into the cell; with Holding::Share: each rank holds a part
  // (any part: the parts are disjoint and together the specimen, as read in chunks from a data
  // file or a checkpoint), and 'history', if given, a part of the contacts' springs (each
  // contact on at least one rank). After: each rank holds exactly the particles of its
  // subdomain, whose bins are at least 'cutoff' (2 Rmax + skin) wide, and in 'history' the
  // springs of every contact one of whose bodies it owns. No rank ever holds more than its
  // share plus what it read. With 'decomposed_as' (a restart on the same rank count), the
  // decomposition is the saved one (see decomposition_record()), so that every rank owns what
  // it owned when saved.
  virtual void adopt(Particles& p, const PeriodicCell& cell, real_t cutoff,
                     const DecompositionRecord* decomposed_as = nullptr, Holding holding = Holding::Whole,
                     HistoryMap* history = nullptr) = 0;

  // How to remake the current decomposition (empty for the serial domain or a decomposition
  // that cannot be remade from it, METIS).
  virtual DecompositionRecord decomposition_record() const = 0;

  // At a rebuild, with owned positions wrapped into the cell. Before: 'history' holds the
  // springs of this rank's touching contacts, keyed by the two global ids. After: every owned
  // particle lies in this rank's subdomain; particles that left were sent to their new owners
  // with the springs of their contacts, and those received were added to 'history'. Ghosts are
  // dropped (they are rebuilt by build_ghosts after any reordering of the owned particles).
  // 'work': the cost of each owned particle over the last list (1 + the list pairs it is in,
  // n_owned values), which a decomposition may be balanced by; null when not known (then null
  // on every rank: the decision to balance is collective).
  virtual void migrate(Particles& p, const PeriodicCell& cell, HistoryMap& history,
                       const std::vector<std::int32_t>* work) = 0;

  // Whether the decomposition is balanced by measured time ([parallel] balance = "time"): then
  // Simulation::step reports the seconds of each force phase to note_force_seconds.
  virtual bool wants_force_seconds() const { return false; }
  virtual void note_force_seconds(double /*seconds*/) {}

  // Before: no ghosts, owned particles in their subdomain. After: every particle of another
  // rank within 'cutoff' (2 Rmax + skin, a lower bound on the decomposition bin edge) of this
  // subdomain is a ghost here, at its owner's (wrapped) position, with every property set.
  virtual void build_ghosts(Particles& p, const PeriodicCell& cell, real_t cutoff) = 0;

  // A copy of this domain's state (decomposition, ghost plan), for a copy of the simulation.
  virtual std::unique_ptr<Domain> clone() const = 0;

  virtual int rank() const = 0;
  virtual int size() const = 0;

 protected:
  // Copied only by a derived class's clone(), never sliced through the base.
  Domain() = default;
  Domain(const Domain&) = default;
  Domain& operator=(const Domain&) = default;
};

}  // namespace fabrica
