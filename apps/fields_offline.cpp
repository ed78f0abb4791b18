#include "apps/fields_offline.hpp"

#include "core/cell.hpp"
#include "core/coarse_grain.hpp"
#include "core/exact_sum.hpp"
#include "core/serial_domain.hpp"
#include "core/errors.hpp"
#include "io/mpi/h5.hpp"
#include "io/mpi/layout.hpp"
#include "io/serial/memory_check.hpp"
#include "io/serial/scene.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/mpi/version.hpp"
#include "io/serial/write_check.hpp"
#include "io/mpi/xdmf.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_domain.hpp"
#include "parallel/mpi_grid_exchange.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>

namespace fabrica {
namespace {

// The cell of a snapshot as the fields take it: its matrix when sheared, else diag(cell_lengths).
Mat3 cell_of(const SnapshotInfo& s) { return s.sheared() ? s.cell_matrix : Mat3(s.cell_lengths.asDiagonal()); }

// The grid of one instant: the given cell counts, or round(h / spacing) nodes along each axis,
// h the cell's heights (the distances between opposite faces: the lengths of an orthorhombic cell).
FieldGrid grid_of(const FieldsOfflineArgs& a, const SnapshotInfo& s, double spacing) {
  FieldGrid g;
  g.set_matrix(cell_of(s));
  const Vec3 L = g.sheared ? PeriodicCell::from_matrix(g.H).heights() : g.lengths;
  for (int k = 0; k < 3; ++k)
    g.n[k] = a.cells ? (*a.cells)[k] : int(std::max(1.0, std::min(std::round(L[k] / spacing), 2.0e9)));
  return g;
}

// Each particle's mass: its material's density (or --density) x density_scaling x its volume.
struct Masses {
  std::vector<double> density;  // by material
  double scaling = 1;
  double of(std::uint8_t material, double r) const {
    const double rho = density[std::min<std::size_t>(material, density.size() - 1)];
    // As the run computes it (Particles::add, then Particles::scale_density): the same bits.
    return rho * 4.0 / 3.0 * std::numbers::pi * r * r * r * scaling;
  }
};

Masses masses_of(const MpiContext& mpi, const FieldsOfflineArgs& a) {
  Masses m;
  if (a.density) {
    if (!(*a.density > 0) || !std::isfinite(*a.density))
      throw InputError(fmt::format("--density = {}: must be positive", *a.density));
    m.density = {*a.density};
    return m;
  }
  RunFileInfo ri;
  agree(mpi.comm(), [&] { ri = read_run_info(a.file); });
  Scene sc;
  try {
    sc = parse_scene(ri.scene_text, ri.scene_path);
  } catch (const InputError& e) {
    throw InputError(
        fmt::format("{}: cannot take the densities from the run's scene ({}): give --density", a.file, e.what()));
  }
  if (sc.materials.empty()) m.density = {sc.density};
  for (const MaterialSpec& s : sc.materials) m.density.push_back(s.density);
  m.scaling = sc.density_scaling;
  return m;
}

// The rank that coarse-grains an item at x (m, any image) of the grid g: the owner of the
// z-layer it lies in (core/grid_exchange.hpp; sheared: the layers of the fractional coordinate
// s3), so that each rank's items reach its own layers and the kernel's reach around them (its box
// of sums).
std::size_t rank_of_layer(const Vec3& x, const FieldGrid& g, std::size_t P) {
  const double s = g.layer_coordinate(x);
  const int nz = g.n[2];
  const std::int64_t k = std::clamp<std::int64_t>(std::int64_t(s * nz), 0, nz - 1);
  return std::size_t(((k + 1) * std::int64_t(P) - 1) / nz);
}

// Rank q's layers of one field to rank 0 (in pieces of at most 2^27 values).
void send_layers(const MpiContext& mpi, std::vector<double>& v, int q) {
  constexpr std::size_t kPiece = std::size_t(1) << 27;
  if (mpi.rank() == q)
    for (std::size_t a = 0; a < v.size(); a += kPiece)
      MPI_Send(v.data() + a, int(std::min(kPiece, v.size() - a)), MPI_DOUBLE, 0, 7303, mpi.comm());
  else if (mpi.rank() == 0)
    for (std::size_t a = 0; a < v.size(); a += kPiece)
      MPI_Recv(v.data() + a, int(std::min(kPiece, v.size() - a)), MPI_DOUBLE, q, 7303, mpi.comm(), MPI_STATUS_IGNORE);
}

// Writes one instant's fields into group g of rank 0's file (g: valid on rank 0 only): a dataset
// per field, shape (nz, ny, nx[, comps]), each rank's layers sent to rank 0 in turn (rank 0
// holds one rank's layers of one field at a time). Collective; an HDF5 error on rank 0 is
// raised on every rank once every layer has been sent.
void write_fields(const MpiContext& mpi, const h5::Group* g, const FieldsResult& r,
                  std::vector<std::pair<std::string, int>>& listed) {
  const std::array<int, 3>& n = r.grid.n;
  const std::size_t P = std::size_t(mpi.size()), layer = std::size_t(n[0]) * std::size_t(n[1]);
  std::string failed;
  std::vector<double> buf;
  for (const Field& f : r.fields) {
    std::vector<hsize_t> dims{hsize_t(n[2]), hsize_t(n[1]), hsize_t(n[0])};
    if (f.components > 1) dims.push_back(hsize_t(f.components));
    h5::Dataset d;
    try {
      if (g && failed.empty()) d = g->create_dataset(f.name, h5::Type::F64, dims), d.set_attr("unit", f.unit);
    } catch (const h5::Error& e) { failed = e.what(); }
    for (std::size_t q = 0; q < P; ++q) {
      // Rank q's layers: all of them on one rank, else its slab (FieldsResult::layers).
      const Layers L = P == 1 ? r.layers : slab_of(n[2], int(q), int(P));
      const std::size_t count = std::size_t(L.end - L.first) * layer * std::size_t(f.components);
      if (q == std::size_t(mpi.rank())) buf.assign(f.values.begin(), f.values.begin() + std::ptrdiff_t(count));
      else if (mpi.rank() == 0) buf.assign(count, 0.0);
      if (q > 0) send_layers(mpi, buf, int(q));
      try {
        if (g && failed.empty() && count > 0)
          d.write_rows(h5::Type::F64, hsize_t(L.first), hsize_t(L.end - L.first), buf.data(), true);
      } catch (const h5::Error& e) { failed = e.what(); }
    }
    listed.emplace_back(f.name, f.components);
  }
  agree(mpi.comm(), [&] {
    if (!failed.empty()) throw InputError(failed);
  });
}

std::string kernel_text(const FieldKernel& k) {
  return k.type == KernelType::Gaussian ? fmt::format("gaussian, width {} m, cut-off {} widths", k.width, k.cutoff)
                                        : fmt::format("lucy, support radius {} m", k.width);
}

// The kernel and the grid's options from the command line, checked.
FieldKernel checked_kernel(const FieldsOfflineArgs& a) {
  FieldKernel kernel;
  if (a.kernel == "gaussian") kernel.type = KernelType::Gaussian;
  else if (a.kernel == "lucy") kernel.type = KernelType::Lucy;
  else throw InputError(fmt::format("--kernel = \"{}\": must be \"gaussian\" or \"lucy\"", a.kernel));
  kernel.cutoff = a.cutoff;
  if (a.spacing && (!(*a.spacing > 0) || !std::isfinite(*a.spacing)))
    throw InputError(fmt::format("--spacing = {}: must be positive", *a.spacing));
  if (a.cells)
    for (int k = 0; k < 3; ++k)
      if ((*a.cells)[k] < 1)
        throw InputError(
            fmt::format("--cells = {} {} {}: each must be at least 1", (*a.cells)[0], (*a.cells)[1], (*a.cells)[2]));
  if (a.width && (!(*a.width > 0) || !std::isfinite(*a.width)))
    throw InputError(fmt::format("--width = {}: must be positive", *a.width));
  if (!(a.strong_ratio > 0)) throw InputError(fmt::format("--strong-ratio = {}: must be positive", a.strong_ratio));
  return kernel;
}

using SnapshotsByCase = std::map<std::string, std::vector<SnapshotInfo>>;

// Which snapshots (as `fabrica fabric`): 'listed' every snapshot of the cases asked for,
// 'chosen' those to coarse-grain. Every rank reads run.h5 itself and the ranks agree on the
// outcome of each read (parallel/guard.hpp).
void choose_snapshots(const MpiContext& mpi, const FieldsOfflineArgs& a, SnapshotsByCase& listed,
                      SnapshotsByCase& chosen) {
  std::vector<SnapshotInfo> all;
  agree(mpi.comm(), [&] { all = list_snapshots(a.file); });
  for (const SnapshotInfo& s : all)
    if (a.case_name.empty() || s.case_name == a.case_name) listed[s.case_name].push_back(s);
  if (listed.empty())
    throw InputError(a.case_name.empty() ? fmt::format("{}: no snapshots in the file", a.file)
                                         : fmt::format("{}: no snapshots of case \"{}\"", a.file, a.case_name));
  for (const auto& [name, list] : listed) {
    if (a.step) {
      for (const SnapshotInfo& s : list)
        if (s.step == *a.step) chosen[name].push_back(s);
      if (!chosen.count(name) && !a.case_name.empty())
        throw InputError(fmt::format("{}: case \"{}\" has no snapshot at step {}", a.file, name, *a.step));
    } else if (a.all) {
      chosen[name] = list;
    } else {
      chosen[name] = {list.back()};
    }
  }
  if (chosen.empty()) throw InputError(fmt::format("{}: no case has a snapshot at step {}", a.file, *a.step));
  // A sheared cell's displacement fields undo a flip of its edges between two snapshots
  // (deformed_reference_edges, core/coarse_grain.hpp): a deformation too large to tell one from
  // is refused before anything is computed.
  for (const auto& [name, list] : chosen)
    for (const SnapshotInfo& s : list) {
      const SnapshotInfo* prev = nullptr;
      for (const SnapshotInfo& e : listed.at(name))
        if (e.step < s.step) prev = &e;
      if (!prev || (!s.sheared() && !prev->sheared())) continue;
      try {
        deformed_reference_edges(cell_of(*prev), cell_of(s));
      } catch (const std::domain_error& e) {
        throw InputError(fmt::format("{}: case \"{}\": displacement fields from step {} to step {}: {}", a.file, name,
                                     prev->step, s.step, e.what()));
      }
    }
}

// The radii (the same in every snapshot of a run) set the default width and the smallest width
// allowed; every grid is checked before any field is computed. Returns the grid spacing.
double check_grids(const MpiContext& mpi, const FieldsOfflineArgs& a, const SnapshotsByCase& chosen,
                   FieldKernel& kernel) {
  ParticleSnapshot first;
  agree(mpi.comm(), [&] {
    const SnapshotInfo& s = chosen.begin()->second.front();
    first = read_particle_snapshot(a.file, s.case_name, s.step);
  });
  if (first.radius.empty()) throw InputError(fmt::format("{}: the snapshots hold no particles", a.file));
  const double rmin = *std::min_element(first.radius.begin(), first.radius.end());
  double dmean = 0;
  for (double r : first.radius) dmean += 2 * r;
  dmean /= double(first.radius.size());
  kernel.width = a.width ? *a.width : (kernel.type == KernelType::Gaussian ? dmean : 3 * dmean);
  const double spacing = a.spacing ? *a.spacing : dmean;
  const double memory = machine_memory_bytes();
  for (const auto& [name, list] : chosen)
    for (const SnapshotInfo& s : list) {
      const FieldGrid g = grid_of(a, s, spacing);
      const std::string why = check_field_grid(g, kernel, rmin);
      if (!why.empty())
        throw InputError(fmt::format("fields of case \"{}\" at step {} (grid {} x {} x {} nodes, {}): {}", name, s.step,
                                     g.n[0], g.n[1], g.n[2], kernel_text(kernel), why));
      const double bytes = field_bytes(g, kernel, mpi.size());
      if (memory > 0 && bytes > 0.5 * memory)
        throw InputError(fmt::format(
            "fields of case \"{}\" at step {}: a grid of {} x {} x {} = {} nodes needs {:.3g} B of memory on every "
            "rank, more than half of the machine's {:.3g} B: give fewer cells (--cells) or a larger --spacing",
            name, s.step, g.n[0], g.n[1], g.n[2], g.nodes(), bytes, memory));
    }
  return spacing;
}

// One instant's fields, computed by every rank on its share of the particles and contacts.
struct Instant {
  FieldsResult res;
  std::optional<SnapshotInfo> prev;  // the snapshot the displacement fields start from
  double stress_error = 0;           // |integral of the contact stress - Love-Weber| / |Love-Weber|
  double mean_solid_fraction = 0;
};

Instant coarse_grain_instant(const MpiContext& mpi, const FieldsOfflineArgs& a, const std::string& name,
                             const SnapshotInfo& info, const std::vector<SnapshotInfo>& every, const FieldGrid& grid,
                             const FieldKernel& kernel, const Masses& masses, Domain& domain, GridExchange* exchange) {
  const std::size_t P = std::size_t(mpi.size()), me = std::size_t(mpi.rank());
  // Each item to the rank whose layers it lies in (any split gives the same bits: the sums are
  // exact), so that each rank's sums cover its layers and the kernel's reach around them.
  const auto mine = [&](const Vec3& x, const FieldGrid& g) { return rank_of_layer(x, g, P) == me; };
  ParticleSnapshot ps;
  ContactSnapshot cs;
  agree(mpi.comm(), [&] {
    ps = read_particle_snapshot(a.file, name, info.step);
    cs = read_contact_snapshot(a.file, name, info.step);
  });
  std::vector<CgParticle> parts;
  for (std::size_t i = 0; i < ps.id.size(); ++i) {
    if (!mine(ps.position[i], grid)) continue;
    CgParticle q;
    q.x = ps.position[i], q.v = ps.velocity[i], q.w = ps.spin[i], q.radius = ps.radius[i];
    q.mass = masses.of(ps.material[i], ps.radius[i]);
    parts.push_back(q);
  }
  // Particle-particle contacts only (a wall contact has id2 < 0), with body 1's centre.
  std::vector<CgContact> conts;
  Mat3 love_weber = Mat3::Zero();  // every rank holds every contact: the check below
  for (const ContactRecord& c : cs.contacts) {
    if (c.id2 < 0) continue;
    love_weber += c.force() * c.branch.transpose();
    const auto it = std::lower_bound(ps.id.begin(), ps.id.end(), c.id1);
    if (it == ps.id.end() || *it != c.id1)
      throw InputError(fmt::format("{}: case \"{}\" step {}: contact ({}, {}) names a particle not in the snapshot",
                                   a.file, name, info.step, c.id1, c.id2));
    const std::size_t i = std::size_t(it - ps.id.begin());
    if (mine(ps.position[i], grid)) conts.push_back({c, ps.position[i], ps.radius[i]});
  }
  FieldOptions opt;
  opt.strong_ratio = a.strong_ratio;
  Instant out;
  out.res = coarse_grain(grid, kernel, parts, conts, opt, domain, nullptr, exchange);
  // The displacement fields from the case's previous snapshot, if any.
  for (const SnapshotInfo& s : every)
    if (s.step < info.step) out.prev = s;
  if (out.prev) {
    FieldGrid g0 = grid;  // this instant's counts on the earlier cell (the reference configuration)
    g0.set_matrix(cell_of(*out.prev));
    ParticleSnapshot p0;
    agree(mpi.comm(), [&] { p0 = read_particle_snapshot(a.file, name, out.prev->step); });
    std::vector<CgMotion> motions;
    for (std::size_t i = 0; i < ps.id.size(); ++i) {
      const auto it = std::lower_bound(p0.id.begin(), p0.id.end(), ps.id[i]);
      if (it == p0.id.end() || *it != ps.id[i]) continue;  // not in both: no displacement
      const std::size_t j = std::size_t(it - p0.id.begin());
      if (!mine(p0.position[j], g0)) continue;
      motions.push_back({p0.position[j], ps.position[i], ps.radius[i]});
    }
    FieldsResult d = displacement_fields(g0, kernel, cell_of(info), motions, domain, nullptr, exchange);
    for (Field& f : d.fields) out.res.fields.push_back(std::move(f));
  }
  // The check printed: the volume integral of the contact stress against the Love-Weber sum,
  // over every rank's layers (exact sums: the same on any number of ranks).
  const Field& s = out.res.field("contact_stress");
  const Field& phi = out.res.field("solid_fraction");
  ExactSums sums(10);
  for (std::size_t v = 0; v < s.values.size(); ++v) sums.add(v % 9, s.values[v]);
  for (double v : phi.values) sums.add(9, v);
  sums.normalize();
  std::vector<std::int64_t> words(sums.words().begin(), sums.words().end());
  domain.sum_all(std::span<std::int64_t>(words));
  std::copy(words.begin(), words.end(), sums.words().begin());
  sums.normalize();
  Mat3 integral;
  for (int q = 0; q < 9; ++q) integral(q / 3, q % 3) = sums.value(std::size_t(q));
  integral *= grid.cell_volume();
  if (love_weber.norm() > 0) out.stress_error = (integral - love_weber).norm() / love_weber.norm();
  out.mean_solid_fraction = sums.value(9) / double(grid.nodes());
  return out;
}

// The group fields/<case>/<step> of 'file' (rank 0) with the instant's attributes.
h5::Group instant_group(h5::File& file, const FieldsOfflineArgs& a, const std::string& name, const SnapshotInfo& info,
                        const FieldGrid& grid, const FieldKernel& kernel, const Instant& in, bool explicit_nodes) {
  const FieldsResult& res = in.res;
  if (!file.exists("fields/" + name)) file.create_group("fields/" + name);
  h5::Group g = file.open_group("fields/" + name).create_group(layout::step_name(info.step));
  g.set_attr("step", info.step);
  g.set_attr("time", info.time);
  const std::vector<double> L(info.cell_lengths.data(), info.cell_lengths.data() + 3);
  const Vec3 h = grid.spacing(), x0 = grid.node(0, 0, 0);
  const std::vector<double> cells{double(grid.n[0]), double(grid.n[1]), double(grid.n[2])}, sp{h[0], h[1], h[2]},
      origin = grid.sheared ? std::vector<double>{x0[0], x0[1], x0[2]}
                            : std::vector<double>{0.5 * h[0], 0.5 * h[1], 0.5 * h[2]};
  g.set_attr("cell_lengths", std::span<const double>(L));
  g.set_attr("cells", std::span<const double>(cells));
  g.set_attr("spacing", std::span<const double>(sp));
  g.set_attr("origin", std::span<const double>(origin));
  g.set_attr("kernel", std::string(kernel.type == KernelType::Gaussian ? "gaussian" : "lucy"));
  g.set_attr("width", kernel.width);
  g.set_attr("cutoff", kernel.type == KernelType::Gaussian ? kernel.cutoff : 1.0);
  g.set_attr("strong_ratio", a.strong_ratio);
  g.set_attr("strong_threshold", res.strong_threshold);
  g.set_attr("particles", res.particles);
  g.set_attr("contacts", res.contacts);
  if (in.prev) {
    g.set_attr("displacement_from_step", in.prev->step);
    const std::vector<double> L0(in.prev->cell_lengths.data(), in.prev->cell_lengths.data() + 3);
    g.set_attr("displacement_reference_lengths", std::span<const double>(L0));
    if (in.prev->sheared() || grid.sheared)
      g.set_attr("displacement_reference_matrix", std::span<const double>(matrix_rows(cell_of(*in.prev))));
  }
  // A sheared grid (and every grid of a case with one): the cell matrix and the nodes' positions
  // (the XDMF's geometry).
  if (explicit_nodes) {
    g.set_attr(layout::kCellMatrix, std::span<const double>(matrix_rows(grid.matrix())));
    const std::vector<double> x = node_positions(grid, {0, grid.n[2]});
    h5::Dataset d =
        g.create_dataset(kNodePosition, h5::Type::F64, {hsize_t(grid.n[2]), hsize_t(grid.n[1]), hsize_t(grid.n[0]), 3});
    d.set_attr("unit", std::string("m"));
    d.write_rows(h5::Type::F64, 0, hsize_t(grid.n[2]), x.data(), true);
  }
  return g;
}

// Writes one instant into fields/<case>/<step> of rank 0's 'file', every rank its layers, and
// returns its XDMF entry. Collective.
FieldsXdmfEntry write_instant(const MpiContext& mpi, h5::File& file, const FieldsOfflineArgs& a,
                              const std::string& name, const SnapshotInfo& info, const FieldGrid& grid,
                              const FieldKernel& kernel, const Instant& in, bool explicit_nodes) {
  const std::string path = "fields/" + name + "/" + layout::step_name(info.step);
  h5::Group g;
  agree(mpi.comm(), [&] {
    if (mpi.rank() != 0) return;
    try {
      g = instant_group(file, a, name, info, grid, kernel, in, explicit_nodes);
    } catch (const h5::Error& e) { throw InputError(e.what()); }
  });
  const Vec3 h = grid.spacing();
  FieldsXdmfEntry e;
  e.case_name = name, e.group = "/" + path, e.step = info.step, e.time = info.time, e.cells = grid.n;
  e.spacing = {h[0], h[1], h[2]}, e.origin = {0.5 * h[0], 0.5 * h[1], 0.5 * h[2]}, e.explicit_nodes = explicit_nodes;
  write_fields(mpi, mpi.rank() == 0 ? &g : nullptr, in.res, e.quantities);
  return e;
}

// The file renamed into place, and its XDMF sidecars: as run.xmf and run_<case>.xmf, every case
// in one sidecar and each case in its own (ParaView takes the union of the cases' times as one
// time axis).
void finish_file(h5::File& file, const std::string& tmp, const std::filesystem::path& out,
                 const SnapshotsByCase& chosen, const std::vector<FieldsXdmfEntry>& entries) {
  namespace fs = std::filesystem;
  try {
    file.close();
  } catch (const h5::Error& e) { throw InputError(e.what()); }
  replace_file(tmp, out.string());
  fs::path xmf = out;
  xmf.replace_extension(".xmf");
  write_fields_xdmf(xmf.string(), out.filename().string(), entries);
  for (const auto& [name, list] : chosen) {
    std::vector<FieldsXdmfEntry> mine;
    for (const FieldsXdmfEntry& e : entries)
      if (e.case_name == name) mine.push_back(e);
    fs::path one = out;
    one.replace_filename(out.stem().string() + "_" + name + ".xmf");
    write_fields_xdmf(one.string(), out.filename().string(), mine);
  }
}

}  // namespace

int fields_offline(const MpiContext& mpi, const FieldsOfflineArgs& a) {
  namespace fs = std::filesystem;
  const bool root = mpi.rank() == 0;
  FieldKernel kernel = checked_kernel(a);
  SnapshotsByCase listed, chosen;
  choose_snapshots(mpi, a, listed, chosen);
  const double spacing = check_grids(mpi, a, chosen, kernel);
  const Masses masses = masses_of(mpi, a);

  const fs::path out = a.output.empty() ? fs::path(a.file).parent_path() / "fields.h5" : fs::path(a.output);
  const std::string tmp = out.string() + ".tmp";
  std::unique_ptr<Domain> domain;
  if (mpi.size() > 1) domain = std::make_unique<MpiDomain>(mpi.comm());
  else domain = std::make_unique<SerialDomain>();
  MpiGridExchange exchange(mpi.comm());  // each rank its share of the grid (core/grid_exchange.hpp)

  // Rank 0 writes the file, serially (its own communicator), to FILE.tmp renamed at the end.
  h5::File file;
  agree(mpi.comm(), [&] {
    if (!root) return;
    if (!out.parent_path().empty()) make_output_directory(out.parent_path().string());
    try {
      file = h5::File::create_parallel(tmp, MPI_COMM_SELF, true);
      file.set_attr(layout::kVersionAttr, std::string(kFabricaVersion));
      file.set_attr("format", std::string("fabrica-fields-1"));
      file.set_attr("source", a.file);
      file.create_group("fields");
    } catch (const h5::Error& e) { throw InputError(e.what()); }
  });
  std::vector<FieldsXdmfEntry> entries;
  std::size_t done = 0;
  for (const auto& [name, list] : chosen) {
    // A case whose cell is sheared at any of its instants: each of its grids with its nodes'
    // positions (FieldsXdmfEntry::explicit_nodes), as a run that shears its cell writes them.
    const bool explicit_nodes =
        std::any_of(list.begin(), list.end(), [](const SnapshotInfo& s) { return s.sheared(); });
    for (const SnapshotInfo& info : list) {
      const FieldGrid grid = grid_of(a, info, spacing);
      const Instant in =
          coarse_grain_instant(mpi, a, name, info, listed.at(name), grid, kernel, masses, *domain, &exchange);
      entries.push_back(write_instant(mpi, file, a, name, info, grid, kernel, in, explicit_nodes));
      agree(mpi.comm(), [&] {
        if (!root) return;
        fmt::print(
            "{} step {}: eps1 {:.4f}, {} particles, {} contacts, grid {} x {} x {} ({}), mean solid fraction "
            "{:.4f}, contact stress integral vs Love-Weber {:.1e}{}\n",
            name, info.step, info.strain[0], in.res.particles, in.res.contacts, grid.n[0], grid.n[1], grid.n[2],
            kernel_text(kernel), in.mean_solid_fraction, in.stress_error,
            in.prev ? fmt::format(", displacement from step {}", in.prev->step) : std::string());
      });
      ++done;
    }
  }
  agree(mpi.comm(), [&] {
    if (!root) return;
    finish_file(file, tmp, out, chosen, entries);
    fs::path xmf = out;
    xmf.replace_extension(".xmf");
    fmt::print("{} instant(s) coarse-grained; fields written to {} ({}, and per case {}_<case>.xmf, for ParaView)\n",
               done, out.string(), xmf.string(), (out.parent_path() / out.stem()).string());
  });
  return 0;
}

}  // namespace fabrica
