#include "io/mpi/snapshot.hpp"

#include "core/fault.hpp"

#include "io/mpi/h5.hpp"
#include "io/mpi/layout.hpp"

#include <algorithm>
#include <sstream>

namespace fabrica {
namespace {

// Opens a Fabrica run file; every HDF5 failure becomes an InputError naming the file.
h5::File open_run(const std::string& path) {
  h5::File f;
  try {
    f = h5::File::open_read(path);
  } catch (const h5::Error& e) { throw InputError(e.what()); }
  if (!f.has_attr(layout::kVersionAttr))
    throw InputError(path + ": not a Fabrica output file (HDF5 without the attribute '" +
                     std::string(layout::kVersionAttr) + "' at /)");
  return f;
}

template <class Fn>
auto guarded(Fn fn) {
  try {
    return fn();
  } catch (const h5::Error& e) { throw InputError(e.what()); }
}

std::vector<Vec3> vec3s(const h5::Dataset& d, std::size_t n) {
  const std::vector<double> v = d.read_doubles();
  if (v.size() != 3 * n) d.fail("expected " + std::to_string(n) + " x 3 values");
  std::vector<Vec3> r(n);
  for (std::size_t i = 0; i < n; ++i) r[i] = Vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
  return r;
}

Vec3 attr_vec3(const h5::Object& o, const std::string& name) {
  const std::vector<double> v = o.attr_doubles(name);
  if (v.size() != 3) o.fail("attribute " + name + " must hold 3 values");
  return Vec3(v[0], v[1], v[2]);
}

SnapshotInfo info_of(const h5::Group& g, const std::string& case_name) {
  SnapshotInfo s;
  s.case_name = case_name;
  s.step = g.attr_int("step");
  s.time = g.attr_double("time");
  s.cell_lengths = attr_vec3(g, "cell_lengths");
  s.cell_matrix = snapshot_cell_matrix(g);
  s.strain = attr_vec3(g, "strain");
  s.particles = g.attr_int("particles");
  s.contacts = g.attr_int("contacts");
  return s;
}

h5::Group open_snapshot(const h5::File& f, const std::string& case_name, std::int64_t step) {
  const std::string p = layout::snapshot_path(case_name, step);
  if (!f.exists(p))
    throw InputError(f.file() + ": no snapshot of case '" + case_name + "' at step " + std::to_string(step) +
                     " (no group /" + p + ")");
  return f.open_group(p);
}

}  // namespace

bool matrix_sheared(const Mat3& h) {
  Mat3 off = h;
  off.diagonal().setZero();
  return !off.isZero(0);
}

std::array<double, 9> matrix_rows(const Mat3& h) {
  std::array<double, 9> out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[std::size_t(3 * r + c)] = h(r, c);
  return out;
}

Mat3 snapshot_cell_matrix(const h5::Object& g) {
  if (!g.has_attr(layout::kCellMatrix)) return Mat3(attr_vec3(g, "cell_lengths").asDiagonal());
  const std::vector<double> v = g.attr_doubles(layout::kCellMatrix);
  if (v.size() != 9) g.fail(std::string("attribute ") + layout::kCellMatrix + " must hold 9 values");
  Mat3 h;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h(r, c) = v[std::size_t(3 * r + c)];
  return h;
}

const std::vector<double>& Series::column(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  if (it == columns.end()) throw InputError("series has no column '" + name + "'");
  return values[std::size_t(it - columns.begin())];
}

RunFileInfo read_run_info(const std::string& path) {
  h5::File f = open_run(path);
  return guarded([&] {
    RunFileInfo r;
    r.version = f.attr_string(layout::kVersionAttr);
    r.git_describe = f.attr_string("git_describe");
    r.ranks = f.attr_int("mpi_ranks");
    h5::Dataset scene = f.open_dataset("scene");
    r.scene_path = scene.attr_string("path");
    r.scene_text = f.read_string("scene");
    return r;
  });
}

std::vector<SnapshotInfo> list_snapshots(const std::string& path) {
  h5::File f = open_run(path);
  return guarded([&] {
    std::vector<SnapshotInfo> r;
    if (!f.exists("snapshots")) return r;
    h5::Group all = f.open_group("snapshots");
    for (const std::string& c : all.children()) {
      h5::Group cg = all.open_group(c);
      for (const std::string& s : cg.children()) r.push_back(info_of(cg.open_group(s), c));
    }
    return r;
  });
}

std::vector<std::string> list_series(const std::string& path) {
  h5::File f = open_run(path);
  return guarded([&] { return f.exists("series") ? f.open_group("series").children() : std::vector<std::string>{}; });
}

ContactSnapshot read_contact_snapshot(const std::string& path, const std::string& case_name, std::int64_t step) {
  h5::File f = open_run(path);
  if (fault_injected("snapshot"))
    throw InputError(path + ": cannot read the snapshot of case \"" + case_name + "\" at step " + std::to_string(step) +
                     " (" + fault_text("snapshot") + ")");
  return guarded([&] {
    h5::Group g = open_snapshot(f, case_name, step);
    ContactSnapshot r;
    r.info = info_of(g, case_name);
    h5::Group c = g.open_group("contacts");
    const std::vector<std::int64_t> id1 = c.open_dataset("id1").read_ints();
    const std::size_t n = id1.size();
    const std::vector<std::int64_t> id2 = c.open_dataset("id2").read_ints();
    const std::vector<Vec3> normal = vec3s(c.open_dataset("normal"), n);
    const std::vector<Vec3> branch = vec3s(c.open_dataset("branch"), n);
    const std::vector<double> overlap = c.open_dataset("overlap").read_doubles();
    const std::vector<double> fn = c.open_dataset("fn").read_doubles();
    const std::vector<Vec3> ft = vec3s(c.open_dataset("ft"), n);
    const std::vector<Vec3> mr = vec3s(c.open_dataset("mr"), n);
    const std::vector<std::uint8_t> sliding = c.open_dataset("sliding").read_bytes();
    const std::vector<std::uint8_t> rolling = c.open_dataset("rolling").read_bytes();
    if (id2.size() != n || overlap.size() != n || fn.size() != n || sliding.size() != n || rolling.size() != n ||
        std::int64_t(n) != r.info.contacts)
      c.fail("datasets of different lengths");
    r.contacts.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      ContactRecord& k = r.contacts[i];
      k.id1 = id1[i], k.id2 = id2[i], k.normal = normal[i], k.branch = branch[i];
      k.overlap = overlap[i], k.fn = fn[i], k.ft = ft[i], k.mr = mr[i];
      k.sliding = sliding[i] != 0, k.rolling = rolling[i] != 0;
    }
    return r;
  });
}

ParticleSnapshot read_particle_snapshot(const std::string& path, const std::string& case_name, std::int64_t step) {
  h5::File f = open_run(path);
  return guarded([&] {
    h5::Group g = open_snapshot(f, case_name, step);
    ParticleSnapshot r;
    r.info = info_of(g, case_name);
    h5::Group p = g.open_group("particles");
    r.id = p.open_dataset("id").read_ints();
    const std::size_t n = r.id.size();
    r.position = vec3s(p.open_dataset("position"), n);
    r.velocity = vec3s(p.open_dataset("velocity"), n);
    r.spin = vec3s(p.open_dataset("spin"), n);
    r.radius = p.open_dataset("radius").read_doubles();
    r.material = p.exists("material") ? p.open_dataset("material").read_bytes() : std::vector<std::uint8_t>(n, 0);
    if (r.radius.size() != n || r.material.size() != n || std::int64_t(n) != r.info.particles)
      p.fail("datasets of different lengths");
    return r;
  });
}

Series read_series(const std::string& path, const std::string& case_name) {
  h5::File f = open_run(path);
  const std::string gp = "series/" + case_name;
  if (!f.exists(gp)) throw InputError(path + ": no series of case '" + case_name + "' (no group /" + gp + ")");
  return guarded([&] {
    Series s;
    h5::Group g = f.open_group(gp);
    s.step = g.open_dataset("step").read_ints();
    std::istringstream cols(g.attr_string("columns"));
    for (std::string c; std::getline(cols, c, ',');) {
      if (c == "stage" || c == "step") continue;
      s.columns.push_back(c);
      s.values.push_back(g.open_dataset(c).read_doubles());
      if (s.values.back().size() != s.step.size()) g.fail("column " + c + ": length differs from step");
    }
    if (g.exists("stage")) {
      h5::Dataset st = g.open_dataset("stage");
      std::vector<std::string> labels;
      std::istringstream ls(st.attr_string("labels"));
      for (std::string l; std::getline(ls, l, ',');) labels.push_back(l);
      for (std::uint8_t code : st.read_bytes()) {
        if (code >= labels.size()) st.fail("stage code " + std::to_string(code) + " has no label");
        s.stage.push_back(labels[code]);
      }
      if (s.stage.size() != s.step.size()) st.fail("length differs from step");
    }
    return s;
  });
}

}  // namespace fabrica
