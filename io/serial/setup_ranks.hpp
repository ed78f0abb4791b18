// The ranks that make a set-up together, as the set-up's one sequence of steps sees them
// (make_setup(scene, ranks), io/serial/setup.hpp). Every step and every check of the set-up is
// written once, over this interface: the agreement (an error met on any rank becomes one error
// of every rank; reductions of what each rank holds) and the few steps that depend on how the
// specimen is spread over the ranks (reading a data file, placing regions, taking each rank's
// share). This base class is the one-rank case: the agreement is the identity and the steps are
// the serial ones (make_setup(scene)). io/mpi/distributed_setup.cpp derives the ranks of a
// communicator from it (MPI reductions, parallel/guard.hpp's agree, the distributed read and the
// decomposition); io/serial/ stays MPI-free.
#pragma once
#include "core/exact_sum.hpp"
#include "core/region_packing.hpp"
#include "io/serial/lammps_data.hpp"
#include "io/serial/setup.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace fabrica {

class SetupRanks {
 public:
  virtual ~SetupRanks() = default;
  virtual int rank() const { return 0; }
  virtual int ranks() const { return 1; }
  // The ranks of this machine among them (the memory check counts what they hold together).
  virtual int ranks_on_node() { return 1; }
  // How the result is held: the whole specimen, or this rank's share of it.
  virtual Holding holding() const { return Holding::Whole; }

  // The agreement. agree: runs 'phase' on every rank; if it threw on any, every rank throws
  // the error of the lowest such rank (an InputError kept as one). The reductions return the
  // value over every rank; sum() leaves 'sums' normalized.
  virtual void agree(const std::function<void()>& phase) { phase(); }
  virtual double min(double x) { return x; }
  virtual double max(double x) { return x; }
  virtual std::int64_t min(std::int64_t x) { return x; }
  virtual void sum(std::vector<std::int64_t>&) {}
  virtual void sum(ExactSums&) {}
  // The largest of every rank's report (ties: the lowest rank's).
  virtual OverlapReport largest(const OverlapReport& mine) { return mine; }

  // The steps that depend on the spread. read_data: the data file's particles this rank reads
  // (all, or its share; the whole file's checks made). region_owners: the rank that places
  // each region (default: contiguous blocks); region_exchange: the hand-over of placed spheres
  // to the ranks of adjacent regions (core/region_packing.hpp; one rank: nothing to hand over).
  // take_share: this rank takes the particles of its subdomain (held as 'h' before) and returns
  // the largest overlap of its pairs, with a cutoff for the neighbours it needs.
  virtual DataFile read_data(const std::string& path, const std::vector<std::int64_t>* types) {
    return read_lammps_data(path, types);
  }
  virtual std::vector<int> region_owners(const RegionCut& cut, const PeriodicCell& cell, real_t cutoff);
  virtual RegionExchange region_exchange(const Scene& scene, const RegionCut& cut, const PeriodicCell& cell,
                                         const std::vector<int>& owners);
  virtual OverlapReport take_share(Particles& p, const PeriodicCell& cell, real_t cutoff, Holding h);
};

}  // namespace fabrica
