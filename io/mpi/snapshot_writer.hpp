// Writing one snapshot - the particles and contacts of a simulation at one instant - into its
// group of run.h5 (layout in docs/output.md), collectively over the ranks, in global id order
// whatever the number of ranks, with buffers of a bounded size.
//
// The id range [lo, hi] of the particles is cut into rounds. In each round every rank sends the
// particles, and the contacts by their id1, of that round's ids to the rank owning their slice
// of it (one MPI_Alltoallv each); the receiver sorts them and writes its rows of every dataset
// (one collective hyperslab write per dataset and round). Nothing is gathered on one rank, and
// besides the simulation's own share a rank holds at most one round's records: about
// round_records of each kind when the ids are spread over their range, as they are for
// generated specimens and data files numbered 1..N (ids clustered in one part of a sparse range
// load their slice's rank more).
#pragma once
#include "core/simulation.hpp"
#include "io/mpi/h5.hpp"

#include <mpi.h>

#include <cstdint>

namespace fabrica {

class SnapshotWriter {
 public:
  // Records per rank and round, on average: 2^15 particles (88 B each) and contacts (168 B),
  // about 8 MB, twice while they travel.
  static constexpr std::int64_t kRoundRecords = std::int64_t(1) << 15;

  // Collective: counts the particles and contacts over every rank, their id range, and the
  // strong-contact threshold (f_n above strong_ratio x the mean f_n of all particle contacts,
  // with the exact sum of core/exact_sum.hpp, so the same on any number of ranks). The contact
  // rows are the particle contacts and then the wall contacts (id2 = -1 - wall index; their
  // line cell runs from the sphere's centre to the contact point), never strong.
  SnapshotWriter(MPI_Comm comm, const Simulation& sim, double strong_ratio, std::int64_t round_records = kRoundRecords);

  std::int64_t particles() const { return np_; }
  std::int64_t contacts() const { return nc_; }  // rows: particle contacts and wall contacts
  std::int64_t wall_contacts() const { return nw_; }
  int rounds() const { return rounds_; }

  // Collective: creates g/particles and g/contacts with every dataset and writes them. Returns
  // the bytes of data written by all ranks.
  double write(const h5::Group& g) const;

 private:
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  const Simulation& sim_;
  std::int64_t np_ = 0, nc_ = 0, nw_ = 0;
  std::int64_t lo_ = 0, hi_ = 0;  // ids of the particles (0, 0 if there are none)
  double strong_threshold_ = 0;
  int rounds_ = 1;
};

}  // namespace fabrica
