// make_setup (io/serial/setup.hpp) made by the ranks of a communicator together, so that no rank
// holds more than its share of the specimen (docs/large.md): the one sequence of set-up steps
// over the ranks of 'comm' (a SetupRanks of MPI, io/serial/setup_ranks.hpp):
//   - a data file is read in byte ranges, one per rank, its whole-file checks made through a
//     directory of ids (io/mpi/distributed_read.hpp);
//   - a generated specimen is made by regions, each rank its regions; or, with the sequential
//     generator, whole on every rank, each rank keeping its share;
//   - the checks that span ranks (cell size, the neighbour grid, the initial overlaps, the
//     walls, the driven sets) use the values of all ranks and the decomposition's ghosts, and
//     the time step the whole set's critical estimate: the result is the same as make_setup's
//     on one rank.
// Every error, on any rank, ends every rank with the message of the lowest rank that met one
// (InputError), before any output exists. The memory check counts the ranks of this node.
#pragma once
#include "io/serial/setup.hpp"
#include "parallel/mpi_domain.hpp"

#include <mpi.h>

namespace fabrica {

// Collective over 'comm'. The particles returned are this rank's, already in their owner's
// subdomain for the decomposition 'options' makes (holding = Share).
Setup make_distributed_setup(const Scene& scene, MPI_Comm comm, const MpiDomainOptions& options);

// make_setup on one rank, make_distributed_setup on several (collective).
Setup make_run_setup(const Scene& scene, MPI_Comm comm, const MpiDomainOptions& options);

// Totals over the particles of every rank, exact (core/exact_sum.hpp): the same bits on any
// rank count (collective).
struct SpecimenTotals {
  std::int64_t count = 0;
  double diameter_sum = 0, mass = 0, volume = 0;  // m, kg, m^3
};
SpecimenTotals specimen_totals(const Particles& p, MPI_Comm comm);

}  // namespace fabrica
