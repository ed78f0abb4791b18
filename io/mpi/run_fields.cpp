#include "io/mpi/run_fields.hpp"

#include "core/contact_snapshot.hpp"
#include "core/errors.hpp"
#include "core/localisation.hpp"
#include "io/serial/memory_check.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace fabrica {
namespace {

// The motions sent to the ranks whose z-layers of g0 their earlier positions lie in (each once
// over all ranks), so that each rank's displacement sums cover its layers and the kernel's reach
// around them, not the whole grid as the home ranks' scattered ids would (7 doubles a motion).
std::vector<CgMotion> motions_by_layer(const std::vector<CgMotion>& mine, const FieldGrid& g0, GridExchange& ex) {
  const std::int64_t P = ex.size(), nz = g0.n[2];
  std::vector<int> owner(mine.size());
  for (std::size_t i = 0; i < mine.size(); ++i) {
    const double s = g0.layer_coordinate(mine[i].x0);
    const std::int64_t k = std::clamp<std::int64_t>(std::int64_t(s * double(nz)), 0, nz - 1);
    owner[i] = int(((k + 1) * P - 1) / nz);
  }
  std::vector<CgMotion> out;
  const GridExchange::Pack pack = [&](int to, std::vector<std::uint64_t>& w) {
    for (std::size_t i = 0; i < mine.size(); ++i)
      if (owner[i] == to) {
        const CgMotion& m = mine[i];
        for (double v : {m.x0[0], m.x0[1], m.x0[2], m.x1[0], m.x1[1], m.x1[2], double(m.radius)})
          w.push_back(std::bit_cast<std::uint64_t>(v));
      }
  };
  const GridExchange::Take take = [&](int, std::span<const std::uint64_t> w) {
    const auto d = [&](std::size_t i) { return std::bit_cast<double>(w[i]); };
    for (std::size_t i = 0; i + 7 <= w.size(); i += 7)
      out.push_back({Vec3(d(i), d(i + 1), d(i + 2)), Vec3(d(i + 3), d(i + 4), d(i + 5)), d(i + 6)});
  };
  ex.ring(pack, take);
  return out;
}

}  // namespace

FieldGrid run_field_grid(const FieldsSpec& f, const PeriodicCell& cell) {
  FieldGrid g;
  g.set_matrix(cell.sheared() ? cell.matrix() : Mat3(cell.lengths().asDiagonal()));
  const Vec3 L = cell.heights();
  const double h = f.spacing ? *f.spacing : f.width;
  // As `fabrica fields --spacing` (apps/fields_offline.cpp): the same counts for the same cell.
  for (int k = 0; k < 3; ++k)
    g.n[k] = f.cells ? (*f.cells)[k] : int(std::max(1.0, std::min(std::round(L[k] / h), 2.0e9)));
  return g;
}

FieldKernel run_field_kernel(const FieldsSpec& f) {
  FieldKernel k;
  k.type = f.lucy ? KernelType::Lucy : KernelType::Gaussian;
  k.width = f.width;
  k.cutoff = f.cutoff;
  return k;
}

void check_run_fields(const Scene& scene, const Particles& p, const PeriodicCell& cell, MPI_Comm comm) {
  if (!scene.fields.enabled) return;
  double rmin = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < p.n_owned(); ++i) rmin = std::min(rmin, double(p.radius[i]));
  MPI_Allreduce(MPI_IN_PLACE, &rmin, 1, MPI_DOUBLE, MPI_MIN, comm);
  if (!std::isfinite(rmin)) rmin = 0;  // no particles: nothing to resolve
  const FieldGrid g = run_field_grid(scene.fields, cell);
  const FieldKernel k = run_field_kernel(scene.fields);
  const std::string where = scene.path + ": [fields] ";
  const std::string grid = "grid " + std::to_string(g.n[0]) + " x " + std::to_string(g.n[1]) + " x " +
      std::to_string(g.n[2]) + " nodes in the " + (g.sheared ? "sheared cell of heights " : "cell of ") +
      number_text(cell.heights()[0], 6) + " x " + number_text(cell.heights()[1], 6) + " x " +
      number_text(cell.heights()[2], 6) + " m";
  const std::string why = check_field_grid(g, k, rmin);
  if (!why.empty()) throw InputError(where + "width = " + number_text(k.width, 10) + " (" + grid + "): " + why);
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  const double bytes = field_bytes(g, k, ranks), memory = machine_memory_bytes();
  if (memory > 0 && bytes > 0.5 * memory)
    throw InputError(where + (scene.fields.cells ? "cells" : "spacing") + " (" + grid + "): the grid needs " +
                     number_text(bytes, 3) + " B of memory on every rank, more than half of the machine's " +
                     number_text(memory, 3) + " B: give " + (scene.fields.cells ? "fewer cells" : "a larger spacing"));
}

FieldsResult run_fields(const FieldsSpec& f, double strong_ratio, const std::string& scene_path, Simulation& sim,
                        FieldsResult* recycle, GridExchange* exchange) {
  // Read through the const simulation: the non-const particles() would mark the positions as
  // changed, and the run would then differ from one without fields.
  const Simulation& cs = sim;
  const Particles& p = cs.particles();
  const FieldGrid grid = run_field_grid(f, cs.cell());
  const FieldKernel kernel = run_field_kernel(f);
  // A cell that has deformed since the check: the grid is checked again (the same on every rank).
  if (const std::string why = check_field_grid(grid, kernel, 0); !why.empty())
    throw InputError(scene_path + ": [fields] at step " + std::to_string(cs.step_count()) + " (grid " +
                     std::to_string(grid.n[0]) + " x " + std::to_string(grid.n[1]) + " x " + std::to_string(grid.n[2]) +
                     "): " + why);
  std::vector<CgParticle> parts(p.n_owned());
  std::unordered_map<GlobalId, std::size_t> index;
  index.reserve(p.n_owned());
  for (std::size_t i = 0; i < p.n_owned(); ++i) {
    parts[i] = {p.x[i], p.v[i], p.w[i], p.radius[i], p.mass[i]};
    index.emplace(p.id[i], i);
  }
  std::vector<CgContact> conts;
  // Body 1 of every record is owned here (for_each_contact_record: the pairs of owned bodies 1);
  // its stored position is the snapshot's, so the fields equal those of `fabrica fields`.
  for_each_contact_record(
      p, cs.cell(), cs.params().law, cs.pairs(),
      [&](const ContactRecord& c) {
        const std::size_t i = index.at(c.id1);
        conts.push_back({c, p.x[i], p.radius[i]});
      },
      &cs.params().materials);
  FieldOptions opt;
  opt.strong_ratio = strong_ratio;
  opt.networks = f.networks();
  FieldsResult r = coarse_grain(grid, kernel, parts, conts, opt, sim.domain(), recycle, exchange);
  std::erase_if(r.fields, [&](const Field& x) { return !f.keeps(x.name); });
  return r;
}

std::optional<FieldHistory::Instant> run_displacement_fields(const FieldsSpec& f, MPI_Comm comm, FieldHistory& history,
                                                             const std::string& case_name, Simulation& sim,
                                                             FieldsResult& r, const std::string& scene_path,
                                                             FieldsResult* recycle, GridExchange* exchange) {
  const Simulation& cs = sim;  // const: as run_fields(), the positions are not marked as changed
  const FieldHistory::Instant now{case_name, cs.step_count(), cs.cell().lengths(), cs.cell().matrix()};
  FieldHistory::Step s = history.advance(comm, cs.particles(), now);
  if (!s.from) return std::nullopt;
  // As `fabrica fields` (apps/fields_offline.cpp): the grid of this instant's counts, in the
  // earlier cell (the reference configuration of the displacements).
  FieldGrid g0 = r.grid;
  g0.set_matrix(s.from->cell_matrix());
  if (exchange && exchange->size() > 1) s.motions = motions_by_layer(s.motions, g0, *exchange);
  FieldsResult d;
  try {  // a flip of a sheared cell's edges undone (the same outcome on every rank: the cells are)
    d = displacement_fields(g0, r.kernel, now.cell_matrix(), s.motions, sim.domain(), recycle, exchange);
  } catch (const std::domain_error& e) {
    throw InputError(scene_path + ": [fields] at step " + std::to_string(now.step) +
                     ": the displacement fields since step " + std::to_string(s.from->step) + ": " + e.what());
  }
  for (Field& x : d.fields)
    if (f.keeps(x.name)) r.fields.push_back(std::move(x));
  return s.from;
}

double run_localisation_index(MPI_Comm comm, std::span<const double> strain_increment) {
  std::vector<double> mine = finite_shear_intensities(strain_increment);
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (size == 1) return localisation_index_of(std::move(mine));
  std::vector<int> counts(std::size_t(size), 0), offsets(std::size_t(size), 0);
  const int n = int(mine.size());
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  for (std::size_t r = 1; r < counts.size(); ++r) offsets[r] = offsets[r - 1] + counts[r - 1];
  std::vector<double> all(std::size_t(offsets.back() + counts.back()));
  MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE, comm);
  return localisation_index_of(std::move(all));
}

}  // namespace fabrica
