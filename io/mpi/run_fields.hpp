// The coarse-grained fields during a run ([fields], docs/fields.md "Fields during a run"): the
// grid and kernel of the scene (on a sheared cell, a grid in its fractional coordinates:
// docs/fields.md "A sheared cell"), the check of the grid against the specimen before the run, and
// the fields of the simulation's current state (collective over the simulation's domain), and its
// displacement fields since the previous field instant. They are written into run.h5 by
// RunOutput::fields (io/mpi/run_output.hpp).
#pragma once
#include "core/coarse_grain.hpp"
#include "core/simulation.hpp"
#include "io/mpi/field_history.hpp"
#include "io/serial/scene.hpp"

#include <mpi.h>

#include <optional>

namespace fabrica {

// The grid of [fields] for 'cell': its cells, or round(h_a / spacing) nodes along axis a (at
// least 1; spacing defaults to the width), h the cell's heights (its lengths when orthorhombic).
FieldGrid run_field_grid(const FieldsSpec& f, const PeriodicCell& cell);
FieldKernel run_field_kernel(const FieldsSpec& f);

// Refuses (InputError, the same message on every rank of 'comm') a [fields] grid and kernel that
// cannot be used on the specimen of 'p' (owned particles; any split over the ranks) in 'cell':
// a width below the smallest radius, a support short of the nearest node, a grid
// above half of the machine's memory on the largest rank's share of the grid (field_bytes() on
// the ranks of 'comm'). Collective.
void check_run_fields(const Scene& scene, const Particles& p, const PeriodicCell& cell, MPI_Comm comm);

// The fields of 'sim' now: each rank its owned particles and the contacts of the bodies 1 it owns
// (particle-particle only); the same bits on any number of ranks and the same as `fabrica fields`
// computes from a snapshot of the same step. With 'exchange' (of several ranks) each rank gets its
// slab of z-layers (FieldsResult::layers, core/grid_exchange.hpp), else the whole grid. Only the
// quantities of [fields] are kept (the network sums are skipped when none of theirs is asked).
// Collective over sim.domain() and 'exchange'. 'recycle': a previous result whose storage is
// reused (coarse_grain).
FieldsResult run_fields(const FieldsSpec& f, double strong_ratio, const std::string& scene_path, Simulation& sim,
                        FieldsResult* recycle = nullptr, GridExchange* exchange = nullptr);

// The displacement fields of 'sim' now (r: its instant's fields, of run_fields()) since the
// instant of case 'case_name' that 'history' keeps (io/mpi/field_history.hpp), as `fabrica fields`
// computes them between snapshots at the two steps (displacement_fields() on the grid of this
// instant's counts in the earlier cell, positions as the snapshots store them); those [fields]
// keeps are appended to r. 'history' then keeps this instant. Returns the instant they start
// from, none at the first instant of a case (then nothing is appended). Collective over 'comm'
// (the home ranks of the history) and sim.domain(). 'recycle', 'exchange': as for run_fields()
// (the same layers as r's). A sheared cell deformed too much since the instant kept to undo a
// flip of its edges (deformed_reference_edges) is an InputError naming 'scene_path' and [fields].
std::optional<FieldHistory::Instant> run_displacement_fields(const FieldsSpec& f, MPI_Comm comm, FieldHistory& history,
                                                             const std::string& case_name, Simulation& sim,
                                                             FieldsResult& r, const std::string& scene_path,
                                                             FieldsResult* recycle = nullptr,
                                                             GridExchange* exchange = nullptr);

// The localisation index (core/localisation.hpp) of a strain increment held by slabs over the
// ranks of 'comm' (each rank its layers): every rank's finite gamma gathered to every rank (8
// bytes a node), then the index, the same bits as of the whole field on one rank. Collective.
double run_localisation_index(MPI_Comm comm, std::span<const double> strain_increment);

}  // namespace fabrica
