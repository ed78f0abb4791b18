// The seam between the physics (core/) and the communication (parallel/). Simulation::step()
// calls these hooks at fixed points; the serial domain does nothing, the MPI domain
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

namespace fabrica {

// How the particles handed to Domain::adopt are held by the ranks.
enum class Holding {
  Whole,  // every rank the same complete set
  Share,  // each rank a disjoint part
};

class Domain {
 public:
  virtual ~Domain() = default;

  // Before: owned particles' x, v, w are current. After: every ghost has its owner's x, v, w.
  virtual void update_ghosts(Particles& p) { (void)p; }

  // The largest value over all ranks (every rank calls it once per step).
  virtual real_t max_all(real_t local) { return local; }

  // Element-wise maximum over all ranks, in place.
  virtual void max_all(std::span<double> values) { (void)values; }

  // Element-wise sum over all ranks, in place; the same bits on every rank (rank 0's result).
  virtual void sum_all(std::span<double> values) { (void)values; }

  // Element-wise sum of integers over all ranks, in place: exact, so the same on any number of
  // ranks (with core/exact_sum.hpp, exact sums of doubles; used by core/fabric.cpp).
  virtual void sum_all(std::span<std::int64_t> values) { (void)values; }

  // At start-up. Before, with Holding::Whole: every rank holds the same complete set of
  // particles, as generated, wrapped into the cell; with Holding::Share: each rank holds a part
  // (any part: the parts are disjoint and together the specimen, as read in chunks from a data
  // file or a checkpoint), and 'history', if given, a part of the contacts' springs (each
  // contact on at least one rank). After: each rank holds exactly the particles of its
  // subdomain, whose bins are at least 'cutoff' (2 Rmax + skin) wide, and in 'history' the
  // springs of every contact one of whose bodies it owns. No rank ever holds more than its
  // share plus what it read. With 'decomposed_for' (a restart on the same rank count), the
  // decomposition is the one made for a cell of those lengths (see decomposition_lengths()),
  // so that every rank owns what it owned when saved.
  virtual void adopt(Particles& p, const PeriodicCell& cell, real_t cutoff,
                     const Vec3* decomposed_for = nullptr, Holding holding = Holding::Whole,
                     HistoryMap* history = nullptr) {
    (void)p, (void)cell, (void)cutoff, (void)decomposed_for, (void)holding, (void)history;
  }

  // The cell lengths the current decomposition was made for (zero for the serial domain or a
  // decomposition that cannot be remade from them, METIS).
  virtual Vec3 decomposition_lengths() const { return Vec3::Zero(); }

  // At a rebuild, with owned positions wrapped into the cell. Before: 'history' holds the
  // springs of this rank's touching contacts, keyed by the two global ids. After: every owned
  // particle lies in this rank's subdomain; particles that left were sent to their new owners
  // with the springs of their contacts, and those received were added to 'history'. Ghosts are
  // dropped (they are rebuilt by build_ghosts after any reordering of the owned particles).
  virtual void migrate(Particles& p, const PeriodicCell& cell, HistoryMap& history) {
    (void)p, (void)cell, (void)history;
  }

  // Before: no ghosts, owned particles in their subdomain. After: every particle of another
  // rank within 'cutoff' (2 Rmax + skin, a lower bound on the decomposition bin edge) of this
  // subdomain is a ghost here, at its owner's (wrapped) position, with every property set.
  virtual void build_ghosts(Particles& p, const PeriodicCell& cell, real_t cutoff) {
    (void)p, (void)cell, (void)cutoff;
  }

  // A copy of this domain's state (decomposition, ghost plan), for a copy of the simulation.
  virtual std::unique_ptr<Domain> clone() const { return std::make_unique<Domain>(*this); }

  virtual int rank() const { return 0; }
  virtual int size() const { return 1; }
};

}  // namespace fabrica
