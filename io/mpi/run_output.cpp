#include "io/mpi/run_output.hpp"

#include "core/localisation.hpp"
#include "io/mpi/layout.hpp"
#include "io/mpi/run_fields.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/mpi/snapshot_writer.hpp"
#include "io/mpi/verify.hpp"
#include "io/mpi/version.hpp"
#include "io/serial/write_check.hpp"
#include "io/mpi/xdmf.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_grid_exchange.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>
#include <type_traits>

namespace fabrica {
namespace {

using clock_type = std::chrono::steady_clock;

constexpr hsize_t kSeriesChunk = 256;   // rows per chunk of a series column
constexpr hsize_t kVertexChunk = 4096;  // rows per chunk of /xdmf/vertices

// The unit of a series column (docs/output.md): stresses in Pa, energies in J, time in s,
// everything else (strains, ratios, counts, coordination numbers) dimensionless "1".
std::string series_unit(const std::string& c) {
  if (c == "time") return "s";
  if (c == "p" || c == "q" ||
      (c.size() == 3 && c[0] == 's' && std::isdigit(static_cast<unsigned char>(c[1])) &&
       std::isdigit(static_cast<unsigned char>(c[2]))))
    return "Pa";
  if (c == "kinetic" || c.starts_with("e_") || c.starts_with("diss_") || c == "boundary_work") return "J";
  return "1";
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> r;
  std::istringstream s(line);
  for (std::string c; std::getline(s, c, ',');) {
    while (!c.empty() && (c.back() == '\n' || c.back() == '\r' || c.back() == ' ')) c.pop_back();
    r.push_back(c);
  }
  return r;
}

// The rest of a field instant's sidecar entry from its group as written: time, grid, whether its
// nodes are explicit (the dataset kNodePosition, the grid's geometry) and its fields.
void read_field_instant(const h5::Group& ig, FieldsXdmfEntry& e) {
  e.time = ig.attr_double("time");
  const std::vector<double> n = ig.attr_doubles("cells"), h = ig.attr_doubles("spacing"),
                            x0 = ig.attr_doubles("origin");
  for (int a = 0; a < 3; ++a) e.cells[a] = int(n.at(a)), e.spacing[a] = h.at(a), e.origin[a] = x0.at(a);
  e.explicit_nodes = ig.exists(kNodePosition);
  for (const std::string& d : ig.children()) {
    if (d == kNodePosition) continue;
    const std::vector<hsize_t> shape = ig.open_dataset(d).shape();
    e.quantities.emplace_back(d, shape.size() > 3 ? int(shape[3]) : 1);
  }
}

}  // namespace

std::string RunOutput::file_name(const std::string& outdir) {
  return (std::filesystem::path(outdir) / "run.h5").string();
}

RunOutput::RunOutput(MPI_Comm comm, const Scene& scene, const std::string& outdir, bool overwrite)
    : comm_(comm), outdir_(outdir), path_(file_name(outdir)), every_(scene.snapshot_every),
      strong_ratio_(scene.fabric.strong_ratio), fields_spec_(scene.fields),
      fields_strong_ratio_(scene.fabric.strong_ratio), scene_path_(scene.path),
      fields_steps_(scene.fields.enabled ? scene.fields.every * scene.output_every : 0),
      fields_explicit_(any_shears(scene.stages)) {
  const auto t0 = clock_type::now();
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
  int exists = 0;
  agree(comm, [&] {
    if (rank_ != 0) return;
    make_output_directory(outdir);
    exists = std::filesystem::exists(path_) ? 1 : 0;
  });
  MPI_Bcast(&exists, 1, MPI_INT, 0, comm);
  if (exists && !overwrite)
    throw InputError(path_ +
                     ": the output file exists already; give --overwrite to replace it "
                     "or choose another output directory");
  file_ = h5::File::create_parallel(path_, comm, overwrite);
  try {
    write_header(scene);
  } catch (...) {
    if (size_ > 1) file_.abandon();  // perhaps this rank's error alone: no collective close
    throw;
  }
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
}

RunOutput::RunOutput(MPI_Comm comm, const Scene& scene, const std::string& outdir, Restart)
    : comm_(comm), outdir_(outdir), path_(file_name(outdir)), every_(scene.snapshot_every),
      strong_ratio_(scene.fabric.strong_ratio), fields_spec_(scene.fields),
      fields_strong_ratio_(scene.fabric.strong_ratio), scene_path_(scene.path),
      fields_steps_(scene.fields.enabled ? scene.fields.every * scene.output_every : 0),
      fields_explicit_(any_shears(scene.stages)) {
  const auto t0 = clock_type::now();
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
  // Rank 0 checks the file serially, read-only, before any rank opens it for writing: a
  // damaged or foreign file is refused (on every rank alike) without being touched.
  int exists = 0;
  std::string error;
  if (rank_ == 0) {
    exists = std::filesystem::exists(path_) ? 1 : 0;
    if (exists) {
      try {
        const RunFileInfo ri = read_run_info(path_);
        if (ri.scene_text != scene.text) error = path_ + ": the output file holds another scene than " + scene.path;
        else verify_run_file(path_);  // every dataset's checksum, before anything is appended
      } catch (const std::exception& e) { error = e.what(); }
      if (!error.empty())
        error = "cannot continue the output file of the restarted run: " + error +
            "; move it aside (a new run.h5 is then written from the restart on) and run again";
    }
  }
  int len = int(error.size());
  MPI_Bcast(&exists, 1, MPI_INT, 0, comm);
  MPI_Bcast(&len, 1, MPI_INT, 0, comm);
  error.resize(std::size_t(len));
  if (len > 0) MPI_Bcast(error.data(), len, MPI_CHAR, 0, comm);
  if (!error.empty()) throw InputError(error);
  if (!exists) {
    agree(comm, [&] {
      if (rank_ == 0) make_output_directory(outdir);
    });
    created_anew_ = true;
    file_ = h5::File::create_parallel(path_, comm, false);
    try {
      write_header(scene);
    } catch (...) {
      if (size_ > 1) file_.abandon();
      throw;
    }
  } else {
    file_ = h5::File::open_parallel(path_, comm);
  }
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
}

void RunOutput::resume_after(std::int64_t step, const std::vector<std::string>& cases, std::size_t current) {
  const auto t0 = clock_type::now();
  // Every rank makes the same calls in the same order (HDF5 metadata operations are collective).
  auto order = [&](const std::string& c) {  // the case's place relative to the current one
    const auto it = std::find(cases.begin(), cases.end(), c);
    if (it == cases.end()) return -1;  // not a case of this run: left alone
    const std::size_t i = std::size_t(it - cases.begin());
    return i < current ? -1 : i == current ? 0 : 1;
  };
  series_.clear();
  h5::Group all = file_.exists("series") ? file_.open_group("series") : file_.create_group("series");
  for (const std::string& c : all.children()) {
    const int o = order(c);
    if (o < 0) continue;
    if (o > 0) {
      all.remove(c);
      continue;
    }
    h5::Group g = all.open_group(c);
    // Every rank reads the stored steps, and all take rank 0's count of rows to keep: rank 0
    // has read them before it sends the count, so before any rank shrinks the datasets below.
    // A rank that read them after another rank's shrink had filled the cut rows of the chunk
    // with zeros would count those as rows to keep, and the ranks would extend the datasets to
    // different lengths (seen under load: the continued rows written after a gap of zeros).
    std::uint64_t keep = 0;
    {
      const std::vector<std::int64_t> steps = g.open_dataset("step").read_ints();
      while (keep < steps.size() && steps[keep] <= step) ++keep;
    }
    MPI_Bcast(&keep, 1, MPI_UINT64_T, 0, comm_);
    for (const std::string& d : g.children()) g.open_dataset(d).extend(keep);
    // The buffer continues the stored series: same columns, same stage codes.
    SeriesBuffer& b = series_[c];
    b.header = g.attr_string("columns");
    for (const std::string& col : split_csv(b.header)) {
      if (col == "stage") b.has_stage = true;
      else if (col != "step") b.columns.push_back(col);
    }
    b.values.resize(b.columns.size());
    if (b.has_stage) {
      const h5::Dataset st = g.open_dataset("stage");
      if (st.has_attr("labels")) b.labels = split_csv(st.attr_string("labels"));
    }
    b.written = keep;
    b.created = true;
  }
  xmf_.clear();
  h5::Group snaps = file_.exists("snapshots") ? file_.open_group("snapshots") : file_.create_group("snapshots");
  std::vector<std::string> kept_cases = cases;
  for (const std::string& c : snaps.children())
    if (std::find(kept_cases.begin(), kept_cases.end(), c) == kept_cases.end()) kept_cases.push_back(c);
  for (const std::string& c : kept_cases) {
    if (!snaps.exists(c)) continue;
    const int o = order(c);
    if (o > 0) {
      snaps.remove(c);
      continue;
    }
    h5::Group cg = snaps.open_group(c);
    std::vector<XmfEntry> entries;
    for (const std::string& sn : cg.children()) {
      h5::Group sg = cg.open_group(sn);
      const std::int64_t s = sg.attr_int("step");
      if (o == 0 && s > step) {
        cg.remove(sn);
        continue;
      }
      // Snapshots of a file written before the contact line cells existed have no contacts/ends.
      const std::int64_t m = sg.exists("contacts/ends") ? sg.attr_int("contacts") : 0;
      // The cell as the reader takes it: diag(cell_lengths) in a file written before cell_matrix.
      const Mat3 H = snapshot_cell_matrix(sg);
      entries.push_back({c, s, sg.attr_double("time"), sg.attr_int("particles"), m, matrix_rows(H), matrix_sheared(H)});
    }
    std::sort(entries.begin(), entries.end(), [](const XmfEntry& a, const XmfEntry& b) { return a.step < b.step; });
    xmf_.insert(xmf_.end(), entries.begin(), entries.end());
  }
  // The field instants (/fields/<case>/<step>) as the snapshots: those after the checkpoint's
  // step of the current case go, and every later case's; the sidecar is rebuilt from the rest.
  fields_xmf_.clear();
  if (file_.exists("fields")) {
    h5::Group fg = file_.open_group("fields");
    std::vector<std::string> fcases = cases;
    for (const std::string& c : fg.children())
      if (std::find(fcases.begin(), fcases.end(), c) == fcases.end()) fcases.push_back(c);
    for (const std::string& c : fcases) {
      if (!fg.exists(c)) continue;
      const int o = order(c);
      if (o > 0) {
        fg.remove(c);
        continue;
      }
      h5::Group cg = fg.open_group(c);
      std::vector<FieldsXdmfEntry> entries;
      for (const std::string& sn : cg.children()) {
        h5::Group ig = cg.open_group(sn);
        FieldsXdmfEntry e;
        e.step = ig.attr_int("step");
        if (o == 0 && e.step > step) {
          cg.remove(sn);
          continue;
        }
        e.case_name = c, e.group = "/fields/" + c + "/" + sn;
        read_field_instant(ig, e);
        entries.push_back(e);
      }
      std::sort(entries.begin(), entries.end(),
                [](const FieldsXdmfEntry& a, const FieldsXdmfEntry& b) { return a.step < b.step; });
      fields_xmf_.insert(fields_xmf_.end(), entries.begin(), entries.end());
    }
  }
  if (file_.exists(layout::kVertexIndex)) vertices_ = std::int64_t(file_.open_dataset(layout::kVertexIndex).shape()[0]);
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  flush();
}

void RunOutput::write_header(const Scene& scene) {
  file_.set_attr(layout::kVersionAttr, std::string(kFabricaVersion));
  file_.set_attr("git_describe", std::string(kFabricaGitDescribe));
  file_.set_attr("format", std::string(layout::kFormat));
  file_.set_attr("mpi_ranks", std::int64_t(size_));
  unsigned maj = 0, min = 0, rel = 0;
  H5get_libversion(&maj, &min, &rel);
  file_.set_attr("hdf5_version", std::to_string(maj) + "." + std::to_string(min) + "." + std::to_string(rel));
  file_.write_string("scene", scene.text, rank_ == 0);
  {
    h5::Dataset s = file_.open_dataset("scene");
    s.set_attr("path", scene.path);
    s.set_attr("unit", std::string("text"));
    // The scene's contact law as run, one attribute per field of its one list
    // (core/contact/params.hpp law_fields), and the model by name.
    struct AttrWriter {
      const h5::Dataset& d;
      void field(const char* name, std::uint8_t v) const { d.set_attr(name, std::int64_t(v)); }
      void field(const char* name, double v) const { d.set_attr(name, v); }
    } w{s};
    law_fields(w, scene.law);
    s.set_attr("law.model_name", std::string(model_name(scene.law.model)));
    s.set_attr("law.rolling_model_name", std::string(rolling_model_name(scene.law.rolling_model)));
  }
  file_.create_group("snapshots");
  file_.create_group("series");
  file_.create_group("xdmf");
  file_.create_dataset(layout::kVertexIndex, h5::Type::I64, 0, 0, kVertexChunk).set_attr("unit", std::string("1"));
  file_.flush();
  agree(comm_, [&] {
    if (rank_ == 0) write_xmf();
  });
}

RunOutput::~RunOutput() {
  if (std::uncaught_exceptions() > 0) {
    if (size_ > 1) file_.abandon();
    else close_after_error();
    return;
  }
  try {
    close();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fabrica: error closing %s: %s\n", path_.c_str(), e.what());
  }
}

void RunOutput::series_row(const std::string& case_name, const std::string& csv_header, const std::string& stage,
                           std::int64_t step, std::span<const double> values) {
  SeriesBuffer& b = series_[case_name];
  if (b.header.empty()) {
    for (const std::string& c : split_csv(csv_header)) {
      b.header += (b.header.empty() ? "" : ",") + c;
      if (c == "stage") b.has_stage = true;
      else if (c != "step") b.columns.push_back(c);
    }
    b.values.resize(b.columns.size());
  }
  if (values.size() != b.columns.size())
    throw std::logic_error("RunOutput::series_row: " + std::to_string(values.size()) + " values for " +
                           std::to_string(b.columns.size()) + " columns");
  b.step.push_back(step);
  if (b.has_stage) {
    auto it = std::find(b.labels.begin(), b.labels.end(), stage);
    if (it == b.labels.end()) b.labels.push_back(stage), it = b.labels.end() - 1;
    b.stage.push_back(std::uint8_t(it - b.labels.begin()));
  }
  for (std::size_t c = 0; c < values.size(); ++c) b.values[c].push_back(values[c]);
  if (b.step.size() >= 256) {  // every rank has the same count: the flush is collective
    const auto t0 = clock_type::now();
    mark_failure([&] { flush_series(); });
    seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  }
}

void RunOutput::flush_series() {
  // Collective: every rank extends every dataset; rank 0 alone selects rows to write.
  const bool w = rank_ == 0;
  for (auto& [name, b] : series_) {
    const hsize_t n = b.step.size();
    if (n == 0) continue;
    const std::string gp = "series/" + name;
    h5::Group g = b.created ? file_.open_group(gp) : file_.create_group(gp);
    if (!b.created) {
      g.set_attr("columns", b.header);
      g.create_dataset("step", h5::Type::I64, 0, 0, kSeriesChunk).set_attr("unit", std::string("1"));
      if (b.has_stage)
        g.create_dataset("stage", h5::Type::U8, 0, 0, kSeriesChunk).set_attr("unit", std::string("code"));
      for (const std::string& c : b.columns)
        g.create_dataset(c, h5::Type::F64, 0, 0, kSeriesChunk).set_attr("unit", series_unit(c));
      b.created = true;
    }
    const hsize_t rows = b.written + n;
    agree(comm_, [&] {  // as for a snapshot (write_snapshot): room first, for the new chunks
      const double new_chunks = std::ceil(double(rows) / kSeriesChunk) - std::ceil(double(b.written) / kSeriesChunk);
      if (rank_ == 0) check_room(path_, new_chunks * kSeriesChunk * 8.0 * double(b.columns.size() + 2) + 32768);
    });
    auto append = [&](const std::string& c, h5::Type t, const void* data) {
      h5::Dataset d = g.open_dataset(c);
      d.extend(rows);
      d.write_rows(t, b.written, w ? n : 0, data, true);
    };
    append("step", h5::Type::I64, b.step.data());
    if (b.has_stage) {
      append("stage", h5::Type::U8, b.stage.data());
      std::string labels;
      for (const std::string& l : b.labels) labels += (labels.empty() ? "" : ",") + l;
      g.open_dataset("stage").set_attr("labels", labels);
    }
    for (std::size_t c = 0; c < b.columns.size(); ++c) append(b.columns[c], h5::Type::F64, b.values[c].data());
    bytes_ += double(n) * (8.0 * double(b.columns.size() + 1) + (b.has_stage ? 1 : 0));
    b.written = rows;
    b.step.clear(), b.stage.clear();
    for (auto& v : b.values) v.clear();
  }
}

void RunOutput::snapshot(const std::string& case_name, const Simulation& sim, const Vec3& strain) {
  mark_failure([&] { write_snapshot(case_name, sim, strain); });
}

void RunOutput::write_snapshot(const std::string& case_name, const Simulation& sim, const Vec3& strain) {
  const auto t0 = clock_type::now();
  const std::string gp = layout::snapshot_path(case_name, sim.step_count());
  if (file_.exists(gp)) return;  // same answer on every rank
  const SnapshotWriter writer(comm_, sim, strong_ratio_);
  const hsize_t np = hsize_t(writer.particles()), nc = hsize_t(writer.contacts());
  // Room on the disk for the snapshot first (data, HDF5's objects for it, the file's metadata
  // flushed after it): a write that fails part-way would leave run.h5 unreadable (its superblock
  // would name an end of file that never reached the disk), so a snapshot that cannot fit is
  // refused before anything of it is written, and the file keeps every earlier snapshot.
  // The XDMF connectivity grows by whole chunks of kVertexChunk rows of 8 bytes.
  const auto chunks = [](double rows, double per) { return std::ceil(rows / per); };
  const double vertex_bytes = std::int64_t(np) > vertices_
      ? (chunks(double(np), kVertexChunk) - chunks(double(vertices_), kVertexChunk)) * kVertexChunk * 8
      : 0.0;
  agree(comm_, [&] {
    if (rank_ == 0) check_room(path_, 1.25 * (double(np) * 112 + double(nc) * 130) + vertex_bytes + 24576);
  });
  h5::Group g = file_.create_group(gp);
  const Vec3 L = sim.cell().lengths();
  const double Ld[3] = {L[0], L[1], L[2]}, ed[3] = {strain[0], strain[1], strain[2]};
  const Mat3 H = sim.cell().matrix();  // orthorhombic: diag(L)
  const std::array<double, 9> h = matrix_rows(H);
  g.set_attr("step", std::int64_t(sim.step_count()));
  g.set_attr("time", double(sim.time()));
  g.set_attr("cell_lengths", std::span<const double>(Ld, 3));
  g.set_attr(layout::kCellMatrix, std::span<const double>(h));
  g.set_attr("strain", std::span<const double>(ed, 3));
  g.set_attr("particles", std::int64_t(np));
  g.set_attr("contacts", std::int64_t(nc));
  // Of the contacts' rows, those with a wall (id2 < 0); and where the walls are at this step
  // (a moving or servo-controlled wall has moved since the scene): each wall's point and unit
  // normal, wall k at 3k .. 3k + 2 (the same on every rank).
  if (const std::vector<Wall>& walls = sim.params().walls; !walls.empty()) {
    g.set_attr("wall_contacts", writer.wall_contacts());
    std::vector<double> points, normals;
    for (const Wall& w : walls)
      for (int k = 0; k < 3; ++k) points.push_back(w.point[k]), normals.push_back(w.normal[k]);
    g.set_attr("wall_points", std::span<const double>(points));
    g.set_attr("wall_normals", std::span<const double>(normals));
  }

  double bytes = writer.write(g);
  const std::int64_t need = std::max(std::int64_t(np), 2 * std::int64_t(nc));
  if (need > vertices_) {  // same on every rank: extend the XDMF connectivity
    h5::Dataset vd = file_.open_dataset(layout::kVertexIndex);
    vd.extend(hsize_t(need));
    // Rank 0 writes the new values 0, 1, 2, ... in blocks of a bounded size (every rank takes
    // part in each collective write, the others with no rows).
    constexpr std::int64_t kBlock = std::int64_t(1) << 18;
    std::vector<std::int64_t> idx;
    for (std::int64_t first = vertices_; first < need; first += kBlock) {
      const std::int64_t n = std::min(kBlock, need - first);
      idx.assign(rank_ == 0 ? std::size_t(n) : 1, 0);  // a valid pointer for the empty selections
      if (rank_ == 0)
        for (std::int64_t k = 0; k < n; ++k) idx[std::size_t(k)] = first + k;
      vd.write_rows(h5::Type::I64, hsize_t(first), rank_ == 0 ? hsize_t(n) : 0, idx.data(), true);
    }
    bytes += double(need - vertices_) * double(sizeof(std::int64_t));
    vertices_ = need;
  }
  bytes_ += bytes;
  xmf_.push_back(
      {case_name, sim.step_count(), double(sim.time()), std::int64_t(np), std::int64_t(nc), h, matrix_sheared(H)});
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  flush();
}

double RunOutput::fields(const std::string& case_name, Simulation& sim) {
  double index = std::numeric_limits<double>::quiet_NaN();
  mark_failure([&] { index = write_fields(case_name, sim); });
  return index;
}

double RunOutput::write_fields(const std::string& case_name, Simulation& sim) {
  const auto t0 = clock_type::now();
  const std::string name = layout::step_name(sim.step_count());
  const std::string gp = "fields/" + case_name + "/" + name;
  double index = std::numeric_limits<double>::quiet_NaN();
  if (file_.exists(gp)) return index;  // same answer on every rank
  // Each rank its share of the grid (core/grid_exchange.hpp): the z-layers it writes below.
  MpiGridExchange exchange(comm_);
  FieldsResult r = run_fields(fields_spec_, fields_strong_ratio_, scene_path_, sim, &spare_fields_, &exchange);
  // The displacement fields need the previous instant's positions (io/mpi/field_history.hpp):
  // nothing is exchanged or kept unless [fields] keeps one of them.
  std::optional<FieldHistory::Instant> from;
  if (fields_spec_.displacement())
    from = run_displacement_fields(fields_spec_, comm_, history_, case_name, sim, r, scene_path_, &spare_fields_,
                                   &exchange);
  for (const Field& f : r.fields)
    if (f.name == "strain_increment") index = run_localisation_index(comm_, f.values);
  const FieldGrid& grid = r.grid;
  double values = 0;  // over the whole grid
  for (const Field& f : r.fields) values += double(grid.nodes()) * f.components;
  // A sheared grid, or one of a run whose cell shears: the nodes' positions and the cell matrix.
  const bool explicit_nodes = grid.sheared || fields_explicit_ || sim.cell().sheared();
  if (explicit_nodes) values += 3.0 * double(grid.nodes());
  agree(comm_, [&] {  // room first, as for a snapshot (chunking and checksums: a quarter more)
    if (rank_ == 0) check_room(path_, 1.25 * 8 * values + 16384);
  });
  h5::Group g = file_.create_group(gp);
  const Vec3 L = grid.lengths, h = grid.spacing(), x0 = grid.sheared ? grid.node(0, 0, 0) : Vec3(0.5 * h);
  const double Ld[3] = {L[0], L[1], L[2]}, cells[3] = {double(grid.n[0]), double(grid.n[1]), double(grid.n[2])},
               sp[3] = {h[0], h[1], h[2]}, origin[3] = {x0[0], x0[1], x0[2]};
  // The attributes of `fabrica fields` (docs/fields.md, "Layout of the fields file").
  g.set_attr("step", std::int64_t(sim.step_count()));
  g.set_attr("time", double(sim.time()));
  g.set_attr("cell_lengths", std::span<const double>(Ld, 3));
  g.set_attr("cells", std::span<const double>(cells, 3));
  g.set_attr("spacing", std::span<const double>(sp, 3));
  g.set_attr("origin", std::span<const double>(origin, 3));
  g.set_attr("kernel", std::string(r.kernel.type == KernelType::Gaussian ? "gaussian" : "lucy"));
  g.set_attr("width", double(r.kernel.width));
  g.set_attr("cutoff", r.kernel.type == KernelType::Gaussian ? double(r.kernel.cutoff) : 1.0);
  g.set_attr("strong_ratio", fields_strong_ratio_);
  g.set_attr("strong_threshold", double(r.strong_threshold));
  g.set_attr("particles", r.particles);
  g.set_attr("contacts", r.contacts);
  if (from) {
    const double L0[3] = {from->lengths[0], from->lengths[1], from->lengths[2]};
    g.set_attr("displacement_from_step", from->step);
    g.set_attr("displacement_reference_lengths", std::span<const double>(L0, 3));
    if (grid.sheared || matrix_sheared(from->cell_matrix()))
      g.set_attr("displacement_reference_matrix", std::span<const double>(matrix_rows(from->cell_matrix())));
  }
  if (explicit_nodes) g.set_attr(layout::kCellMatrix, std::span<const double>(matrix_rows(grid.matrix())));
  FieldsXdmfEntry e;
  e.case_name = case_name, e.group = "/" + gp, e.step = sim.step_count(), e.time = double(sim.time());
  e.cells = grid.n, e.spacing = {sp[0], sp[1], sp[2]}, e.origin = {origin[0], origin[1], origin[2]};
  e.explicit_nodes = explicit_nodes;
  // Rank k writes its share of the z-layers, the layers it holds (one collective write per
  // dataset, every rank taking part).
  const hsize_t nz = hsize_t(grid.n[2]), layer = hsize_t(grid.n[0]) * hsize_t(grid.n[1]);
  const hsize_t z0 = nz * hsize_t(rank_) / hsize_t(size_), z1 = nz * hsize_t(rank_ + 1) / hsize_t(size_);
  if (z0 < hsize_t(r.layers.first) || z1 > hsize_t(r.layers.end))
    throw std::logic_error("RunOutput: the fields do not hold this rank's layers");
  for (const Field& f : r.fields) {
    std::vector<hsize_t> dims{nz, hsize_t(grid.n[1]), hsize_t(grid.n[0])};
    if (f.components > 1) dims.push_back(hsize_t(f.components));
    const h5::Dataset d = g.create_dataset(f.name, h5::Type::F64, dims);
    d.set_attr("unit", f.unit);
    // (A rank without layers, fewer layers than ranks, passes a valid pointer for its empty selection.)
    static const double none = 0;
    d.write_rows(h5::Type::F64, z0, z1 - z0,
                 z1 > z0 ? f.values.data() + (z0 - hsize_t(r.layers.first)) * layer * hsize_t(f.components) : &none,
                 true);
    e.quantities.emplace_back(f.name, f.components);
  }
  if (explicit_nodes) {  // the nodes' positions, the XDMF's geometry (each rank its layers)
    const std::vector<double> x = node_positions(grid, {int(z0), int(z1)});
    const h5::Dataset d =
        g.create_dataset(kNodePosition, h5::Type::F64, {nz, hsize_t(grid.n[1]), hsize_t(grid.n[0]), 3});
    d.set_attr("unit", std::string("m"));
    static const double none = 0;
    d.write_rows(h5::Type::F64, z0, z1 - z0, z1 > z0 ? x.data() : &none, true);
  }
  // In name order, as a restart lists them back from the file (resume_after): the same sidecar.
  std::sort(e.quantities.begin(), e.quantities.end());
  bytes_ += 8 * values;
  fields_xmf_.push_back(e);
  spare_fields_ = std::move(r);
  fields_seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  flush();
  return index;
}

void RunOutput::link_snapshots(const std::string& source_case, const std::string& case_name, std::int64_t first_step,
                               std::int64_t last_step) {
  const auto t0 = clock_type::now();
  mark_failure([&] {
    std::vector<XmfEntry> linked;
    for (const XmfEntry& x : xmf_)
      if (x.case_name == source_case && x.step > first_step && x.step <= last_step) {
        const std::string gp = layout::snapshot_path(case_name, x.step);
        if (file_.exists(gp)) continue;  // same answer on every rank
        file_.link(gp, "/" + layout::snapshot_path(source_case, x.step));
        linked.push_back(x);
        linked.back().case_name = case_name;
      }
    xmf_.insert(xmf_.end(), linked.begin(), linked.end());
  });
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  flush();
}

void RunOutput::link_fields(const std::string& source_case, const std::string& case_name, std::int64_t first_step,
                            std::int64_t last_step) {
  const auto t0 = clock_type::now();
  bool any = false;  // the same on every rank (fields_xmf_ is)
  mark_failure([&] {
    std::vector<FieldsXdmfEntry> linked;
    for (const FieldsXdmfEntry& x : fields_xmf_)
      if (x.case_name == source_case && x.step > first_step && x.step <= last_step) {
        const std::string gp = "fields/" + case_name + "/" + layout::step_name(x.step);
        if (file_.exists(gp)) continue;  // same answer on every rank
        file_.link(gp, x.group);
        linked.push_back(x);
        linked.back().case_name = case_name;
        linked.back().group = "/" + gp;
      }
    any = !linked.empty();
    fields_xmf_.insert(fields_xmf_.end(), linked.begin(), linked.end());
  });
  fields_seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  if (any) flush();  // a run without field instants flushes no more than before
}

void RunOutput::flush() {
  mark_failure([&] { flush_all(); });
}

void RunOutput::flush_all() {
  const auto t0 = clock_type::now();
  flush_series();
  file_.flush();
  agree(comm_, [&] {
    if (rank_ == 0) write_xmf();
  });
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
}

void RunOutput::close() {
  if (!file_.valid()) return;
  flush();
  file_.close();
}

void RunOutput::mark_failure(const std::function<void()>& f) {
  try {
    f();
  } catch (...) {
    failed_ = true;
    throw;
  }
}

void RunOutput::close_after_error() {
  // After a failed write of the file itself, nothing more is written to it: a flush now would
  // record in the superblock data that never reached the disk. The file keeps what the last
  // successful flush wrote.
  if (failed_) return file_.abandon();
  try {
    close();
  } catch (const std::exception&) {  // the error being reported is the earlier one
    file_.abandon();
  }
}

void RunOutput::write_cell_xmf(const std::vector<std::string>& cases) const {
  // The cell's sidecar once any snapshot's cell is sheared (then of every snapshot, so that its
  // time axis is run.xmf's); none for a run of orthorhombic cells, whose outputs stay as before
  // (a restart to before the shear removes the one it wrote).
  const std::filesystem::path dir(outdir_);
  if (std::none_of(xmf_.begin(), xmf_.end(), [](const XmfEntry& x) { return x.sheared; })) {
    std::error_code ec;
    std::filesystem::remove(dir / "run_cell.xmf", ec);
    for (const std::string& c : cases) std::filesystem::remove(dir / ("run_" + c + "_cell.xmf"), ec);
    return;
  }
  std::vector<CellXdmfEntry> all;
  for (const XmfEntry& x : xmf_) all.push_back({x.case_name, x.step, x.time, x.h});
  write_cell_xdmf((dir / "run_cell.xmf").string(), all);
  if (cases.size() > 1)
    for (const std::string& c : cases) {
      std::vector<CellXdmfEntry> one;
      for (const CellXdmfEntry& x : all)
        if (x.case_name == c) one.push_back(x);
      write_cell_xdmf((dir / ("run_" + c + "_cell.xmf")).string(), one);
    }
}

void RunOutput::write_xmf() const {
  std::vector<XdmfEntry> e, ce;
  std::vector<std::string> cases;
  for (const XmfEntry& x : xmf_) {
    e.emplace_back(x.case_name, x.step, x.time, x.particles);
    if (x.contacts > 0) ce.emplace_back(x.case_name, x.step, x.time, x.contacts);
    if (std::find(cases.begin(), cases.end(), x.case_name) == cases.end()) cases.push_back(x.case_name);
  }
  const std::filesystem::path dir(outdir_);
  write_xdmf((dir / "run.xmf").string(), "run.h5", e, vertices_);
  write_contacts_xdmf((dir / "run_contacts.xmf").string(), "run.h5", ce, vertices_);
  write_cell_xmf(cases);
  // The fields' sidecar (docs/fields.md): every case in run_fields.xmf, and with several cases
  // each in run_fields_<case>.xmf (ParaView merges the time axes of the cases of one file).
  if (!fields_xmf_.empty()) {
    write_fields_xdmf((dir / "run_fields.xmf").string(), "run.h5", fields_xmf_);
    std::vector<std::string> fcases;
    for (const FieldsXdmfEntry& x : fields_xmf_)
      if (std::find(fcases.begin(), fcases.end(), x.case_name) == fcases.end()) fcases.push_back(x.case_name);
    if (fcases.size() > 1)
      for (const std::string& c : fcases) {
        std::vector<FieldsXdmfEntry> one;
        for (const FieldsXdmfEntry& x : fields_xmf_)
          if (x.case_name == c) one.push_back(x);
        write_fields_xdmf((dir / ("run_fields_" + c + ".xmf")).string(), "run.h5", one);
      }
  }
  // The cases of a triaxial test overlap in time (every case of the sweep starts from the end of
  // the consolidation): in run.xmf ParaView shows them superimposed and merges their time steps,
  // so each case gets its own file as well.
  if (cases.size() > 1)
    for (const std::string& c : cases) {
      std::vector<XdmfEntry> ec;
      for (const auto& t : e)
        if (std::get<0>(t) == c) ec.push_back(t);
      write_xdmf((dir / ("run_" + c + ".xmf")).string(), "run.h5", ec, vertices_);
      std::vector<XdmfEntry> cc;
      for (const auto& t : ce)
        if (std::get<0>(t) == c) cc.push_back(t);
      write_contacts_xdmf((dir / ("run_" + c + "_contacts.xmf")).string(), "run.h5", cc, vertices_);
    }
}

}  // namespace fabrica
