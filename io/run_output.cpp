#include "io/run_output.hpp"

#include "core/contact_snapshot.hpp"
#include "core/exact_sum.hpp"
#include "io/layout.hpp"
#include "io/snapshot.hpp"
#include "io/verify.hpp"
#include "io/version.hpp"
#include "io/write_check.hpp"
#include "parallel/guard.hpp"

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
  if (c == "p" || c == "q" || (c.size() == 3 && c[0] == 's' && std::isdigit(static_cast<unsigned char>(c[1])) &&
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

// Plain records for the MPI exchange (Eigen vectors are not trivially copyable).
struct PartRec {
  std::int64_t id;
  double x[3], v[3], w[3], r;
};
struct ContRec {
  std::int64_t id1, id2;
  double normal[3], branch[3], overlap, fn, ft[3], mr[3];
  std::uint8_t sliding, rolling;
  double x1[3];  // centre of body 1, filled after the exchange (for the XDMF line cells)
};

void put(double* d, const Vec3& v) { d[0] = v[0], d[1] = v[1], d[2] = v[2]; }

// Sends each record to the rank that owns its key's slice of [lo, hi] (one MPI_Alltoallv of
// bytes). Before: any distribution. After: this rank holds every record whose key falls in
// its slice, in no particular order.
template <class Rec, class Key>
std::vector<Rec> redistribute(MPI_Comm comm, int size, const std::vector<Rec>& recs, std::int64_t lo,
                              std::int64_t hi, Key key) {
  const double span = double(hi - lo + 1);
  auto dest = [&](std::int64_t k) {
    return std::min(size - 1, int(double(k - lo) * size / span));
  };
  std::vector<int> scount(size, 0), rcount(size), sdisp(size, 0), rdisp(size, 0);
  for (const Rec& r : recs) scount[dest(key(r))] += int(sizeof(Rec));
  MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, comm);
  for (int k = 1; k < size; ++k) {
    sdisp[k] = sdisp[k - 1] + scount[k - 1];
    rdisp[k] = rdisp[k - 1] + rcount[k - 1];
  }
  std::vector<Rec> send(recs.size());
  std::vector<int> fill = sdisp;
  for (const Rec& r : recs) {
    const int d = dest(key(r));
    std::memcpy(reinterpret_cast<char*>(send.data()) + fill[d], &r, sizeof(Rec));
    fill[d] += int(sizeof(Rec));
  }
  std::vector<Rec> recv(std::size_t(rdisp[size - 1] + rcount[size - 1]) / sizeof(Rec));
  MPI_Alltoallv(send.data(), scount.data(), sdisp.data(), MPI_BYTE, recv.data(), rcount.data(),
                rdisp.data(), MPI_BYTE, comm);
  return recv;
}

// This rank's first row and the total number of rows, for 'n' rows here (ranks in order).
std::pair<hsize_t, hsize_t> slab(MPI_Comm comm, std::size_t n) {
  long long mine = (long long)n, before = 0, total = 0;
  MPI_Exscan(&mine, &before, 1, MPI_LONG_LONG, MPI_SUM, comm);
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) before = 0;  // MPI_Exscan leaves rank 0's result undefined
  MPI_Allreduce(&mine, &total, 1, MPI_LONG_LONG, MPI_SUM, comm);
  return {hsize_t(before), hsize_t(total)};
}

// Writes one column of records (rows [row0, row0 + n) of 'total') as a new dataset of T.
template <class T>
h5::Type type_of() {
  if constexpr (std::is_same_v<T, double>) return h5::Type::F64;
  else if constexpr (std::is_same_v<T, std::int64_t>) return h5::Type::I64;
  else return h5::Type::U8;
}
template <class T, class Rec, class Get>
double write_column(const h5::Group& g, const std::string& name, const std::string& unit, hsize_t cols,
                    const std::vector<Rec>& recs, hsize_t row0, hsize_t total, Get get) {
  h5::Dataset d = g.create_dataset(name, type_of<T>(), total, cols);
  d.set_attr("unit", unit);
  const std::size_t w = std::max<hsize_t>(cols, 1);
  std::vector<T> buf(recs.size() * w);
  for (std::size_t i = 0; i < recs.size(); ++i) get(recs[i], &buf[i * w]);
  if (total > 0) d.write_rows(type_of<T>(), row0, recs.size(), buf.data(), true);  // same on all ranks
  return double(total * w * sizeof(T));
}

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '&') r += "&amp;";
    else if (c == '<') r += "&lt;";
    else if (c == '>') r += "&gt;";
    else if (c == '"') r += "&quot;";
    else r += c;
  }
  return r;
}

}  // namespace

std::string RunOutput::file_name(const std::string& outdir) {
  return (std::filesystem::path(outdir) / "run.h5").string();
}

RunOutput::RunOutput(MPI_Comm comm, const Scene& scene, const std::string& outdir, bool overwrite)
    : comm_(comm), outdir_(outdir), path_(file_name(outdir)), every_(scene.snapshot_every),
      strong_ratio_(scene.fabric.strong_ratio) {
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
    throw InputError(path_ + ": the output file exists already; give --overwrite to replace it "
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
      strong_ratio_(scene.fabric.strong_ratio) {
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
        if (ri.scene_text != scene.text)
          error = path_ + ": the output file holds another scene than " + scene.path;
        else
          verify_run_file(path_);  // every dataset's checksum, before anything is appended
      } catch (const std::exception& e) {
        error = e.what();
      }
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

void RunOutput::resume_after(std::int64_t step, const std::vector<std::string>& cases,
                             std::size_t current) {
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
      entries.push_back({c, s, sg.attr_double("time"), sg.attr_int("particles"), m});
    }
    std::sort(entries.begin(), entries.end(),
              [](const XmfEntry& a, const XmfEntry& b) { return a.step < b.step; });
    xmf_.insert(xmf_.end(), entries.begin(), entries.end());
  }
  if (file_.exists(layout::kVertexIndex))
    vertices_ = std::int64_t(file_.open_dataset(layout::kVertexIndex).shape()[0]);
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

void RunOutput::series_row(const std::string& case_name, const std::string& csv_header,
                           const std::string& stage, std::int64_t step, std::span<const double> values) {
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
    throw std::logic_error("RunOutput::series_row: " + std::to_string(values.size()) +
                           " values for " + std::to_string(b.columns.size()) + " columns");
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
      if (b.has_stage) g.create_dataset("stage", h5::Type::U8, 0, 0, kSeriesChunk).set_attr("unit", std::string("code"));
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
  const Particles& p = sim.particles();
  std::vector<PartRec> parts(p.n_owned());
  std::int64_t lo = std::numeric_limits<std::int64_t>::max(), hi = std::numeric_limits<std::int64_t>::min();
  for (std::size_t i = 0; i < p.n_owned(); ++i) {
    PartRec& r = parts[i];
    r.id = p.id[i];
    put(r.x, p.x[i]), put(r.v, p.v[i]), put(r.w, p.w[i]);
    r.r = p.radius[i];
    lo = std::min(lo, r.id), hi = std::max(hi, r.id);
  }
  MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_INT64_T, MPI_MIN, comm_);
  MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_INT64_T, MPI_MAX, comm_);
  if (hi < lo) lo = hi = 0;  // no particles at all
  std::vector<ContRec> conts;
  // The particle contacts, then the wall contacts (id2 = -1 - wall index; their line cell runs
  // from the sphere's centre to the contact point), in one table (docs/output.md).
  std::vector<ContactRecord> records = contact_records(p, sim.cell(), sim.params().law, sim.pairs());
  if (!sim.params().walls.empty()) {
    const std::vector<ContactRecord> w =
        wall_contact_records(p, sim.params().law, sim.params().walls, sim.wall_contacts());
    records.insert(records.end(), w.begin(), w.end());
  }
  for (const ContactRecord& c : records) {
    ContRec r{};
    r.id1 = c.id1, r.id2 = c.id2;
    put(r.normal, c.normal), put(r.branch, c.branch), put(r.ft, c.ft), put(r.mr, c.mr);
    r.overlap = c.overlap, r.fn = c.fn;
    r.sliding = c.sliding, r.rolling = c.rolling;
    conts.push_back(r);
  }
  if (size_ > 1) {
    parts = redistribute(comm_, size_, parts, lo, hi, [](const PartRec& r) { return r.id; });
    conts = redistribute(comm_, size_, conts, lo, hi, [](const ContRec& r) { return r.id1; });
  }
  std::sort(parts.begin(), parts.end(), [](const PartRec& a, const PartRec& b) { return a.id < b.id; });
  std::sort(conts.begin(), conts.end(), [](const ContRec& a, const ContRec& b) {
    return a.id1 != b.id1 ? a.id1 < b.id1 : a.id2 < b.id2;
  });
  // Body 1 of every contact is here: particles and contacts went by the same id slices (by id
  // and id1). Its centre is the first end of the contact's line cell in the XDMF sidecar.
  for (ContRec& r : conts) {
    const auto it = std::lower_bound(parts.begin(), parts.end(), r.id1,
                                     [](const PartRec& a, std::int64_t id) { return a.id < id; });
    if (it == parts.end() || it->id != r.id1)
      throw std::logic_error("RunOutput::snapshot: body 1 of a contact is not on its rank");
    std::copy(it->x, it->x + 3, r.x1);
  }
  // Strong contacts: f_n > strong_ratio x the mean f_n of all contacts, the threshold of the
  // fabric analysis (core/fabric.cpp), with the same exact sum, so the same on any number of ranks.
  double strong_threshold = 0;
  {
    ExactSums s(1);
    std::int64_t particle_contacts = 0;  // walls are not part of the fabric's threshold
    for (const ContRec& r : conts)
      if (r.id2 >= 0) s.add(0, r.fn), ++particle_contacts;
    s.normalize();
    std::vector<std::int64_t> buf(s.words().begin(), s.words().end());
    buf.push_back(particle_contacts);
    MPI_Allreduce(MPI_IN_PLACE, buf.data(), int(buf.size()), MPI_INT64_T, MPI_SUM, comm_);
    std::copy(buf.begin(), buf.end() - 1, s.words().begin());
    s.normalize();
    if (buf.back() > 0) strong_threshold = strong_ratio_ * (s.value(0) / double(buf.back()));
  }

  const auto [p0, np] = slab(comm_, parts.size());
  const auto [c0, nc] = slab(comm_, conts.size());
  // Room on the disk for the snapshot first (data, HDF5's objects for it, the file's metadata
  // flushed after it): a write that fails part-way would leave run.h5 unreadable (its superblock
  // would name an end of file that never reached the disk), so a snapshot that cannot fit is
  // refused before anything of it is written, and the file keeps every earlier snapshot.
  // The XDMF connectivity grows by whole chunks of kVertexChunk rows of 8 bytes.
  const auto chunks = [](double rows, double per) { return std::ceil(rows / per); };
  const double vertex_bytes =
      std::int64_t(np) > vertices_
          ? (chunks(double(np), kVertexChunk) - chunks(double(vertices_), kVertexChunk)) * kVertexChunk * 8
          : 0.0;
  agree(comm_, [&] {
    if (rank_ == 0)
      check_room(path_, 1.25 * (double(np) * 112 + double(nc) * 130) + vertex_bytes + 24576);
  });
  h5::Group g = file_.create_group(gp);
  const Vec3 L = sim.cell().lengths();
  const double Ld[3] = {L[0], L[1], L[2]}, ed[3] = {strain[0], strain[1], strain[2]};
  g.set_attr("step", std::int64_t(sim.step_count()));
  g.set_attr("time", double(sim.time()));
  g.set_attr("cell_lengths", std::span<const double>(Ld, 3));
  g.set_attr("strain", std::span<const double>(ed, 3));
  g.set_attr("particles", std::int64_t(np));
  g.set_attr("contacts", std::int64_t(nc));
  if (!sim.params().walls.empty()) {  // of the contacts' rows, those with a wall (id2 < 0)
    std::int64_t nw = 0;
    for (const ContRec& r : conts) nw += r.id2 < 0;
    MPI_Allreduce(MPI_IN_PLACE, &nw, 1, MPI_INT64_T, MPI_SUM, comm_);
    g.set_attr("wall_contacts", nw);
  }

  h5::Group pg = g.create_group("particles");
  double bytes = 0;
  bytes += write_column<std::int64_t>(pg, "id", "1", 0, parts, p0, np, [](const PartRec& r, std::int64_t* d) { *d = r.id; });
  bytes += write_column<double>(pg, "position", "m", 3, parts, p0, np,
                        [](const PartRec& r, double* d) { std::copy(r.x, r.x + 3, d); });
  bytes += write_column<double>(pg, "velocity", "m/s", 3, parts, p0, np,
                        [](const PartRec& r, double* d) { std::copy(r.v, r.v + 3, d); });
  bytes += write_column<double>(pg, "spin", "rad/s", 3, parts, p0, np,
                        [](const PartRec& r, double* d) { std::copy(r.w, r.w + 3, d); });
  bytes += write_column<double>(pg, "radius", "m", 0, parts, p0, np, [](const PartRec& r, double* d) { *d = r.r; });

  h5::Group cg = g.create_group("contacts");
  bytes += write_column<std::int64_t>(cg, "id1", "1", 0, conts, c0, nc, [](const ContRec& r, std::int64_t* d) { *d = r.id1; });
  bytes += write_column<std::int64_t>(cg, "id2", "1", 0, conts, c0, nc, [](const ContRec& r, std::int64_t* d) { *d = r.id2; });
  bytes += write_column<double>(cg, "normal", "1", 3, conts, c0, nc,
                        [](const ContRec& r, double* d) { std::copy(r.normal, r.normal + 3, d); });
  bytes += write_column<double>(cg, "branch", "m", 3, conts, c0, nc,
                        [](const ContRec& r, double* d) { std::copy(r.branch, r.branch + 3, d); });
  bytes += write_column<double>(cg, "overlap", "m", 0, conts, c0, nc, [](const ContRec& r, double* d) { *d = r.overlap; });
  bytes += write_column<double>(cg, "fn", "N", 0, conts, c0, nc, [](const ContRec& r, double* d) { *d = r.fn; });
  bytes += write_column<double>(cg, "ft", "N", 3, conts, c0, nc,
                        [](const ContRec& r, double* d) { std::copy(r.ft, r.ft + 3, d); });
  bytes += write_column<double>(cg, "mr", "N m", 3, conts, c0, nc,
                        [](const ContRec& r, double* d) { std::copy(r.mr, r.mr + 3, d); });
  bytes += write_column<std::uint8_t>(cg, "sliding", "bool", 0, conts, c0, nc, [](const ContRec& r, std::uint8_t* d) { *d = r.sliding; });
  bytes += write_column<std::uint8_t>(cg, "rolling", "bool", 0, conts, c0, nc, [](const ContRec& r, std::uint8_t* d) { *d = r.rolling; });
  // For the contacts' XDMF sidecar (line cells): the strong flag, |f_t|, |m_r| and both ends.
  bytes += write_column<std::uint8_t>(cg, "strong", "bool", 0, conts, c0, nc,
                        [&](const ContRec& r, std::uint8_t* d) { *d = r.id2 >= 0 && r.fn > strong_threshold; });
  bytes += write_column<double>(cg, "ft_norm", "N", 0, conts, c0, nc,
                        [](const ContRec& r, double* d) { *d = std::sqrt(r.ft[0] * r.ft[0] + r.ft[1] * r.ft[1] + r.ft[2] * r.ft[2]); });
  bytes += write_column<double>(cg, "mr_norm", "N m", 0, conts, c0, nc,
                        [](const ContRec& r, double* d) { *d = std::sqrt(r.mr[0] * r.mr[0] + r.mr[1] * r.mr[1] + r.mr[2] * r.mr[2]); });
  bytes += write_column<double>(cg, "ends", "m", 6, conts, c0, nc, [](const ContRec& r, double* d) {
    for (int k = 0; k < 3; ++k) d[k] = r.x1[k], d[3 + k] = r.x1[k] + r.branch[k];
  });
  const std::int64_t need = std::max(std::int64_t(np), 2 * std::int64_t(nc));
  if (need > vertices_) {  // same on every rank: extend the XDMF connectivity
    h5::Dataset vd = file_.open_dataset(layout::kVertexIndex);
    vd.extend(hsize_t(need));
    std::vector<std::int64_t> idx;
    if (rank_ == 0)
      for (std::int64_t k = vertices_; k < need; ++k) idx.push_back(k);
    std::int64_t none = 0;  // a valid pointer for the empty selections
    vd.write_rows(h5::Type::I64, hsize_t(vertices_), idx.size(), idx.empty() ? &none : idx.data(), true);
    bytes += double(idx.size() * sizeof(std::int64_t));
    vertices_ = need;
  }
  bytes_ += bytes;
  xmf_.push_back({case_name, sim.step_count(), double(sim.time()), std::int64_t(np), std::int64_t(nc)});
  seconds_ += std::chrono::duration<double>(clock_type::now() - t0).count();
  flush();
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

void RunOutput::write_xmf() const {
  std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>> e, ce;
  std::vector<std::string> cases;
  for (const XmfEntry& x : xmf_) {
    e.emplace_back(x.case_name, x.step, x.time, x.particles);
    if (x.contacts > 0) ce.emplace_back(x.case_name, x.step, x.time, x.contacts);
    if (std::find(cases.begin(), cases.end(), x.case_name) == cases.end()) cases.push_back(x.case_name);
  }
  const std::filesystem::path dir(outdir_);
  write_xdmf((dir / "run.xmf").string(), "run.h5", e, vertices_);
  write_contacts_xdmf((dir / "run_contacts.xmf").string(), "run.h5", ce, vertices_);
  // The cases of a triaxial test overlap in time (every case of the sweep starts from the end of
  // the consolidation): in run.xmf ParaView shows them superimposed and merges their time steps,
  // so each case gets its own file as well.
  if (cases.size() > 1)
    for (const std::string& c : cases) {
      std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>> ec;
      for (const auto& t : e)
        if (std::get<0>(t) == c) ec.push_back(t);
      write_xdmf((dir / ("run_" + c + ".xmf")).string(), "run.h5", ec, vertices_);
      std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>> cc;
      for (const auto& t : ce)
        if (std::get<0>(t) == c) cc.push_back(t);
      write_contacts_xdmf((dir / ("run_" + c + "_contacts.xmf")).string(), "run.h5", cc, vertices_);
    }
}

namespace {
// The XML prologue of a sidecar into x (full precision for the times); returns the cases of
// 'entries' in their first-seen order.
std::vector<std::string> xdmf_begin(
    std::ostringstream& x,
    const std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>>& entries) {
  x.precision(17);
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
       "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n";
  std::vector<std::string> cases;
  for (const auto& e : entries)
    if (std::find(cases.begin(), cases.end(), std::get<0>(e)) == cases.end()) cases.push_back(std::get<0>(e));
  return cases;
}

// An HDF DataItem of 'rows' (x 'cols' when non-zero) values at 'dataset' (file:/path).
std::string hdf_item(const std::string& dataset, std::int64_t rows, int cols, const char* type,
                     int prec) {
  std::ostringstream d;
  d << "<DataItem Dimensions=\"" << rows;
  if (cols) d << ' ' << cols;
  d << "\" NumberType=\"" << type << "\" Precision=\"" << prec << "\" Format=\"HDF\">"
    << xml_escape(dataset) << "</DataItem>";
  return d.str();
}
}  // namespace

void write_xdmf(const std::string& path, const std::string& h5file,
                const std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>>& entries,
                std::int64_t vertices) {
  std::ostringstream x;
  const std::vector<std::string> cases = xdmf_begin(x, entries);
  for (const std::string& c : cases) {
    x << "    <Grid Name=\"" << xml_escape(c) << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const auto& [cn, step, time, n] : entries) {
      if (cn != c) continue;
      const std::string base = h5file + ":/" + layout::snapshot_path(cn, step) + "/particles/";
      auto item = [&](const std::string& ds, int cols, const char* type, int prec) {
        return hdf_item(base + ds, n, cols, type, prec);
      };
      x << "      <Grid Name=\"" << xml_escape(c) << "_" << layout::step_name(step) << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << time << "\"/>\n"
        << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n"
        << "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"" << n << "\" Type=\"HyperSlab\">\n"
        << "            <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 " << n << "</DataItem>\n"
        << "            <DataItem Dimensions=\"" << vertices << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
        << xml_escape(h5file + ":/" + layout::kVertexIndex) << "</DataItem>\n"
        << "          </DataItem>\n        </Topology>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n          " << item("position", 3, "Float", 8) << "\n        </Geometry>\n"
        << "        <Attribute Name=\"radius\" AttributeType=\"Scalar\" Center=\"Node\">\n          "
        << item("radius", 0, "Float", 8) << "\n        </Attribute>\n"
        << "        <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">\n          "
        << item("velocity", 3, "Float", 8) << "\n        </Attribute>\n"
        << "        <Attribute Name=\"spin\" AttributeType=\"Vector\" Center=\"Node\">\n          "
        << item("spin", 3, "Float", 8) << "\n        </Attribute>\n"
        << "        <Attribute Name=\"id\" AttributeType=\"Scalar\" Center=\"Node\">\n          "
        << item("id", 0, "Int", 8) << "\n        </Attribute>\n"
        << "      </Grid>\n";
    }
    x << "    </Grid>\n";
  }
  x << "  </Domain>\n</Xdmf>\n";
  // Written to a temporary file, checked, synced and renamed (io/write_check.hpp): a reader (or
  // a crash, or a full disk) never sees half a file, and a failed write keeps the previous one.
  write_file_atomic(path, x.str(), "xdmf");
}

void write_contacts_xdmf(const std::string& path, const std::string& h5file,
                         const std::vector<std::tuple<std::string, std::int64_t, double, std::int64_t>>& entries,
                         std::int64_t vertices) {
  std::ostringstream x;
  const std::vector<std::string> cases = xdmf_begin(x, entries);
  for (const std::string& c : cases) {
    x << "    <Grid Name=\"" << xml_escape(c) << "_contacts\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const auto& [cn, step, time, m] : entries) {
      if (cn != c) continue;
      const std::string base = h5file + ":/" + layout::snapshot_path(cn, step) + "/contacts/";
      auto item = [&](const std::string& ds, int cols, const char* type, int prec) {
        return hdf_item(base + ds, m, cols, type, prec);
      };
      auto attribute = [&](const char* name, const std::string& ds, const char* type, int prec) {
        return std::string("        <Attribute Name=\"") + name +
               "\" AttributeType=\"Scalar\" Center=\"Cell\">\n          " + item(ds, 0, type, prec) +
               "\n        </Attribute>\n";
      };
      // M two-node line cells over 2M points: the ends (x1, x1 + branch) of every contact,
      // connectivity 0, 1, ..., 2M-1 (the first 2M values of the vertex index).
      x << "      <Grid Name=\"" << xml_escape(c) << "_contacts_" << layout::step_name(step) << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << time << "\"/>\n"
        << "        <Topology TopologyType=\"Polyline\" NumberOfElements=\"" << m << "\" NodesPerElement=\"2\">\n"
        << "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"" << m << " 2\" Type=\"HyperSlab\">\n"
        << "            <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 " << 2 * m << "</DataItem>\n"
        << "            <DataItem Dimensions=\"" << vertices << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
        << xml_escape(h5file + ":/" + layout::kVertexIndex) << "</DataItem>\n"
        << "          </DataItem>\n        </Topology>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n          " << item("ends", 6, "Float", 8) << "\n        </Geometry>\n"
        << attribute("fn", "fn", "Float", 8) << attribute("ft_norm", "ft_norm", "Float", 8)
        << attribute("mr_norm", "mr_norm", "Float", 8) << attribute("sliding", "sliding", "UChar", 1)
        << attribute("rolling", "rolling", "UChar", 1) << attribute("strong", "strong", "UChar", 1)
        << attribute("id1", "id1", "Int", 8) << attribute("id2", "id2", "Int", 8)
        << "      </Grid>\n";
    }
    x << "    </Grid>\n";
  }
  x << "  </Domain>\n</Xdmf>\n";
  // Written to a temporary file, checked, synced and renamed (io/write_check.hpp): a reader (or
  // a crash, or a full disk) never sees half a file, and a failed write keeps the previous one.
  write_file_atomic(path, x.str(), "xdmf");
}

}  // namespace fabrica
