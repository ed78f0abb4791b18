#include "io/mpi/h5.hpp"

#include "core/fault.hpp"
#include "parallel/guard.hpp"

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace fabrica::h5 {
namespace {

// HDF5's innermost message (where the failure originated) and the API call, then clears the stack.
std::string error_stack_text() {
  struct Acc {
    std::string inner, outer;
  } acc;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* e, void* p) -> herr_t {
        auto* a = static_cast<Acc*>(p);
        const std::string d = e->desc ? e->desc : "";
        if (n == 0) a->inner = d;
        a->outer = std::string(e->func_name ? e->func_name : "") + (d.empty() ? "" : ": " + d);
        return 0;
      },
      &acc);
  H5Eclear2(H5E_DEFAULT);
  if (acc.inner.empty()) return acc.outer.empty() ? "HDF5 call failed" : acc.outer;
  return acc.outer.empty() || acc.outer.ends_with(acc.inner) ? acc.inner : acc.outer + " (" + acc.inner + ")";
}

constexpr unsigned kIstoreK = 2;                   // chunk-index B-tree: nodes of 2 K = 4 entries
constexpr hsize_t kChunkBytes = hsize_t(1) << 20;  // at most 1 MiB per chunk of a fixed-size dataset

Handle dataspace(std::span<const hsize_t> dims, std::span<const hsize_t> maxdims = {}) {
  return Handle(H5Screate_simple(int(dims.size()), dims.data(), maxdims.empty() ? nullptr : maxdims.data()), H5Sclose);
}

Handle string_type(std::size_t n) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), std::max<std::size_t>(n, 1));
  H5Tset_strpad(t.get(), H5T_STR_NULLPAD);
  return t;
}

// Reads a string from an attribute or dataset 'obj' of type 'type' (fixed or variable length).
template <class ReadFn>
std::string read_str(const Object& o, hid_t type, const std::string& what, ReadFn read) {
  if (H5Tget_class(type) != H5T_STRING) o.fail(what + ": not a string");
  if (H5Tis_variable_str(type) > 0) {
    Handle mt(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mt.get(), H5T_VARIABLE);
    char* s = nullptr;
    o.check(read(mt.get(), &s), "reading " + what);
    std::string r = s ? s : "";
    H5free_memory(s);
    return r;
  }
  const std::size_t n = H5Tget_size(type);
  Handle mt = string_type(n);
  std::string r(n, '\0');
  o.check(read(mt.get(), r.data()), "reading " + what);
  r.resize(r.find('\0') == std::string::npos ? n : r.find('\0'));
  return r;
}

}  // namespace

void quiet() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

namespace {
bool g_checksums = true;
}  // namespace
void set_checksums(bool on) { g_checksums = on; }
bool checksums_enabled() { return g_checksums; }

hid_t native(Type t) {
  switch (t) {
    case Type::F64:
      return H5T_NATIVE_DOUBLE;
    case Type::I64:
      return H5T_NATIVE_INT64;
    case Type::U8:
      return H5T_NATIVE_UINT8;
  }
  return H5T_NATIVE_DOUBLE;
}

void Object::fail(const std::string& what) const { throw Error(file_ + ": " + name_ + ": " + what); }

void Object::check(herr_t status, const std::string& what) const {
  if (status < 0) fail(what + ": " + error_stack_text());
}

void Object::check_all(herr_t status, const std::string& what) const {
  if (comm_ == MPI_COMM_NULL) return check(status, what);
  int rank = 0, size = 1;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &size);
  std::string msg;
  if (status < 0) msg = file_ + ": " + name_ + ": " + what + ": " + error_stack_text();
  int first = status < 0 ? rank : size;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm_);
  if (first == size) return;
  int len = int(msg.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm_);
  msg.resize(std::size_t(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, first, comm_);
  throw Error(msg);
}

// ---- attributes ----------------------------------------------------------------------------

namespace {
void write_attr(const Object& o, const std::string& attr, hid_t type, hid_t space, const void* data) {
  if (H5Aexists(o.id(), attr.c_str()) > 0) o.check(H5Adelete(o.id(), attr.c_str()), "replacing attribute " + attr);
  Handle a(H5Acreate2(o.id(), attr.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) o.check(-1, "creating attribute " + attr);
  o.check(H5Awrite(a.get(), type, data), "writing attribute " + attr);
}
}  // namespace

void Object::set_attr(const std::string& attr, double v) const {
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr(*this, attr, H5T_NATIVE_DOUBLE, s.get(), &v);
}
void Object::set_attr(const std::string& attr, std::int64_t v) const {
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr(*this, attr, H5T_NATIVE_INT64, s.get(), &v);
}
void Object::set_attr(const std::string& attr, std::span<const double> v) const {
  const std::array<hsize_t, 1> d{v.size()};
  Handle s = dataspace(d);
  write_attr(*this, attr, H5T_NATIVE_DOUBLE, s.get(), v.data());
}
void Object::set_attr(const std::string& attr, const std::string& v) const {
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  Handle t = string_type(v.size());
  std::string buf = v.empty() ? std::string(1, '\0') : v;
  write_attr(*this, attr, t.get(), s.get(), buf.data());
}

bool Object::has_attr(const std::string& attr) const { return H5Aexists(id(), attr.c_str()) > 0; }

namespace {
Handle open_attr(const Object& o, const std::string& attr) {
  if (!o.has_attr(attr)) o.fail("no attribute '" + attr + "'");
  Handle a(H5Aopen(o.id(), attr.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.valid()) o.check(-1, "opening attribute " + attr);
  return a;
}
hssize_t attr_size(const Object& o, hid_t a, const std::string& attr) {
  Handle s(H5Aget_space(a), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(s.get());
  if (n < 0) o.check(-1, "attribute " + attr);
  return n;
}
}  // namespace

double Object::attr_double(const std::string& attr) const {
  Handle a = open_attr(*this, attr);
  if (attr_size(*this, a.get(), attr) != 1) fail("attribute " + attr + " is not a scalar");
  double v = 0;
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v), "reading attribute " + attr);
  return v;
}
std::int64_t Object::attr_int(const std::string& attr) const {
  Handle a = open_attr(*this, attr);
  if (attr_size(*this, a.get(), attr) != 1) fail("attribute " + attr + " is not a scalar");
  std::int64_t v = 0;
  check(H5Aread(a.get(), H5T_NATIVE_INT64, &v), "reading attribute " + attr);
  return v;
}
std::vector<double> Object::attr_doubles(const std::string& attr) const {
  Handle a = open_attr(*this, attr);
  std::vector<double> v(std::size_t(attr_size(*this, a.get(), attr)));
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()), "reading attribute " + attr);
  return v;
}
std::string Object::attr_string(const std::string& attr) const {
  Handle a = open_attr(*this, attr);
  Handle t(H5Aget_type(a.get()), H5Tclose);
  return read_str(*this, t.get(), "attribute " + attr, [&](hid_t mt, void* buf) { return H5Aread(a.get(), mt, buf); });
}

// ---- groups --------------------------------------------------------------------------------

Group Group::create_group(const std::string& rel) const {
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle g(H5Gcreate2(id(), rel.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) check(-1, "creating group " + rel);
  return Group(std::move(g), file_, child_name(rel), comm_);
}

Group Group::open_group(const std::string& rel) const {
  if (!exists(rel)) fail("no group '" + rel + "'");
  Handle g(H5Gopen2(id(), rel.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.valid()) check(-1, "opening group " + rel);
  return Group(std::move(g), file_, child_name(rel), comm_);
}

bool Group::exists(const std::string& rel) const {
  std::string prefix;
  std::size_t pos = 0;
  while (pos <= rel.size()) {
    const std::size_t next = rel.find('/', pos);
    prefix = rel.substr(0, next);
    if (!prefix.empty() && H5Lexists(id(), prefix.c_str(), H5P_DEFAULT) <= 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    if (next == std::string::npos) break;
    pos = next + 1;
  }
  return true;
}

std::vector<std::string> Group::children() const {
  std::vector<std::string> names;
  check(H5Literate(
            id(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
            [](hid_t, const char* name, const H5L_info_t*, void* p) -> herr_t {
              static_cast<std::vector<std::string>*>(p)->emplace_back(name);
              return 0;
            },
            &names),
        "listing");
  return names;
}

void Group::remove(const std::string& rel) const {
  check(H5Ldelete(id(), rel.c_str(), H5P_DEFAULT), "removing " + rel);
}

void Group::link(const std::string& rel, const std::string& target) const {
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  check(H5Lcreate_hard(id(), target.c_str(), id(), rel.c_str(), lcpl.get(), H5P_DEFAULT),
        "linking " + rel + " to " + target);
}

Dataset Group::create_dataset(const std::string& rel, Type t, hsize_t rows, hsize_t cols, hsize_t chunk_rows) const {
  // Every dataset with data is chunked and carries HDF5's Fletcher-32 checksum of each chunk,
  // verified by every read (docs/output.md, "Checksums"). A fixed-size dataset gets chunks of
  // at most kChunkBytes; an empty fixed-size one stays contiguous (nothing to check).
  const hsize_t width = std::max<hsize_t>(cols, 1) * H5Tget_size(native(t));
  const bool extendible = chunk_rows > 0;
  const hsize_t chunk_n = extendible ? chunk_rows : rows > 0 ? std::clamp<hsize_t>(kChunkBytes / width, 1, rows) : 0;
  std::vector<hsize_t> dims{rows}, maxd{extendible ? H5S_UNLIMITED : rows}, chunk{chunk_n};
  if (cols > 0) dims.push_back(cols), maxd.push_back(cols), chunk.push_back(cols);
  Handle space = dataspace(dims, maxd);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (chunk_n > 0) {
    check(H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()), "chunking " + rel);
    if (checksums_enabled()) check(H5Pset_fletcher32(dcpl.get()), "adding the Fletcher-32 checksum to " + rel);
  }
  // No fill: every element is written (saves a pass over the file under MPI-IO).
  H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER);
  Handle d(H5Dcreate2(id(), rel.c_str(), native(t), space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!d.valid()) check(-1, "creating dataset " + rel);
  return Dataset(std::move(d), file_, child_name(rel), comm_);
}

Dataset Group::create_dataset(const std::string& rel, Type t, const std::vector<hsize_t>& dims) const {
  if (dims.empty()) fail("creating dataset " + rel + ": no dimensions");
  hsize_t width = H5Tget_size(native(t));
  for (std::size_t k = 1; k < dims.size(); ++k) width *= std::max<hsize_t>(dims[k], 1);
  std::vector<hsize_t> chunk = dims;
  chunk[0] = dims[0] > 0 ? std::clamp<hsize_t>(kChunkBytes / width, 1, dims[0]) : 0;
  Handle space = dataspace(dims, dims);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (chunk[0] > 0) {
    check(H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()), "chunking " + rel);
    if (checksums_enabled()) check(H5Pset_fletcher32(dcpl.get()), "adding the Fletcher-32 checksum to " + rel);
  }
  H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER);
  Handle d(H5Dcreate2(id(), rel.c_str(), native(t), space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), H5Dclose);
  if (!d.valid()) check(-1, "creating dataset " + rel);
  return Dataset(std::move(d), file_, child_name(rel), comm_);
}

Dataset Group::open_dataset(const std::string& rel) const {
  if (!exists(rel)) fail("no dataset '" + rel + "'");
  Handle d(H5Dopen2(id(), rel.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.valid()) check(-1, "opening dataset " + rel);
  return Dataset(std::move(d), file_, child_name(rel), comm_);
}

void Group::write_string(const std::string& rel, const std::string& text, bool writer) const {
  Handle t = string_type(text.size());
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle d(H5Dcreate2(id(), rel.c_str(), t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!d.valid()) check(-1, "creating dataset " + rel);
  Handle fs(H5Dget_space(d.get()), H5Sclose);
  Handle ms(H5Screate(H5S_SCALAR), H5Sclose);
  if (!writer) H5Sselect_none(fs.get()), H5Sselect_none(ms.get());
  std::string buf = text.empty() ? std::string(1, '\0') : text;
  check(H5Dwrite(d.get(), t.get(), ms.get(), fs.get(), H5P_DEFAULT, buf.data()), "writing " + rel);
}

std::string Group::read_string(const std::string& rel) const {
  Dataset d = open_dataset(rel);
  Handle t(H5Dget_type(d.id()), H5Tclose);
  return read_str(d, t.get(), "dataset",
                  [&](hid_t mt, void* buf) { return H5Dread(d.id(), mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf); });
}

// ---- datasets ------------------------------------------------------------------------------

std::vector<hsize_t> Dataset::shape() const {
  Handle s(H5Dget_space(id()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(s.get());
  if (rank < 0) check(-1, "shape");
  std::vector<hsize_t> d(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(s.get(), d.data(), nullptr);
  return d;
}

void Dataset::write_rows(Type t, hsize_t row0, hsize_t n, const void* data, bool collective) const {
  Handle fs(H5Dget_space(id()), H5Sclose);
  const std::vector<hsize_t> dims = shape();
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = row0, count[0] = n;
  Handle ms;
  if (n == 0) {
    H5Sselect_none(fs.get());
    const hsize_t one = 1;
    ms = Handle(H5Screate_simple(1, &one, nullptr), H5Sclose);
    H5Sselect_none(ms.get());
  } else {
    check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr),
          "selecting rows");
    ms = dataspace(count);
  }
  Handle xfer(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
  if (collective) H5Pset_dxpl_mpio(xfer.get(), H5FD_MPIO_COLLECTIVE);
  errno = 0;
  herr_t st = H5Dwrite(id(), native(t), ms.get(), fs.get(), xfer.get(), data);
  const int err = errno;
  std::string what = "cannot write the data";
  // The system's reason, when the failure was the disk's (HDF5's own text does not say).
  if (st < 0 && (err == ENOSPC || err == EFBIG || err == EDQUOT || err == EIO || err == EROFS))
    what += " (" + std::string(std::strerror(err)) + ")";
  if (st >= 0 && fault_injected("h5")) {
    H5Epush2(H5E_DEFAULT, __FILE__, __func__, __LINE__, H5E_ERR_CLS, H5E_DATASET, H5E_WRITEERROR, "%s",
             fault_text("h5").c_str());
    st = -1;
  }
  if (collective) check_all(st, what);
  else check(st, what);
}

void Dataset::extend(hsize_t rows) const {
  std::vector<hsize_t> dims = shape();
  dims[0] = rows;
  check_all(H5Dset_extent(id(), dims.data()), "extending");
}

namespace {
template <class T>
std::vector<T> read_all(const Dataset& d, hid_t type) {
  std::size_t n = 1;
  for (hsize_t k : d.shape()) n *= k;
  std::vector<T> v(n);
  if (n > 0 && H5Dread(d.id(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) d.fail_read();
  return v;
}
}  // namespace

std::size_t Dataset::verify() const {
  Handle t(H5Dget_type(id()), H5Tclose);
  Handle s(H5Dget_space(id()), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(s.get());
  if (n < 0) check(-1, "reading the data");
  const std::size_t bytes = std::size_t(n) * H5Tget_size(t.get());
  if (bytes == 0) return 0;
  std::vector<unsigned char> buf(bytes);
  if (H5Dread(id(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) fail_read();
  return bytes;
}

void Dataset::fail_read() const {
  const std::string text = error_stack_text();
  fail("the data do not match their checksum or cannot be read (" + text +
       "): the file is damaged; its other datasets may still be read");
}

bool Dataset::has_checksum() const {
  Handle p(H5Dget_create_plist(id()), H5Pclose);
  const int n = H5Pget_nfilters(p.get());
  for (int k = 0; k < n; ++k) {
    unsigned flags = 0;
    std::size_t nel = 0;
    unsigned cd[4];
    char name[64];
    unsigned config = 0;
    if (H5Pget_filter2(p.get(), unsigned(k), &flags, &nel, cd, sizeof name, name, &config) == H5Z_FILTER_FLETCHER32)
      return true;
  }
  return false;
}

std::vector<double> Dataset::read_doubles() const { return read_all<double>(*this, H5T_NATIVE_DOUBLE); }
std::vector<std::int64_t> Dataset::read_ints() const { return read_all<std::int64_t>(*this, H5T_NATIVE_INT64); }
std::vector<std::uint8_t> Dataset::read_bytes() const { return read_all<std::uint8_t>(*this, H5T_NATIVE_UINT8); }

// ---- files ---------------------------------------------------------------------------------

File File::create_parallel(const std::string& path, MPI_Comm comm, bool truncate) {
  quiet();
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fapl_mpio(fapl.get(), comm, MPI_INFO_NULL);
  // Metadata operations are collective anyway (every rank calls them); let HDF5 know, so that
  // only one rank reads metadata and writes it in one collective operation.
  H5Pset_all_coll_metadata_ops(fapl.get(), true);
  H5Pset_coll_metadata_write(fapl.get(), true);
  // Small B-tree nodes for the chunk indexes: every dataset is chunked (for its checksum), most
  // have a chunk or a few, and HDF5's default node (K = 32) reserves about 2 KB per dataset.
  Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_istore_k(fcpl.get(), kIstoreK);
  Handle f(H5Fcreate(path.c_str(), truncate ? H5F_ACC_TRUNC : H5F_ACC_EXCL, fcpl.get(), fapl.get()), H5Fclose);
  File file(std::move(f), path, "/", comm);
  file.check_all(file.valid() ? 0 : -1, "cannot create the HDF5 file");
  return file;
}

File File::open_parallel(const std::string& path, MPI_Comm comm) {
  quiet();
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_fapl_mpio(fapl.get(), comm, MPI_INFO_NULL);
  H5Pset_all_coll_metadata_ops(fapl.get(), true);
  H5Pset_coll_metadata_write(fapl.get(), true);
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()), H5Fclose);
  File file(std::move(f), path, "/", comm);
  file.check_all(file.valid() ? 0 : -1, "cannot open the HDF5 file for writing");
  return file;
}

File File::open_read(const std::string& path) {
  quiet();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": no such file");
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path + ": not a regular file");
  const htri_t is = H5Fis_hdf5(path.c_str());
  if (is == 0) {
    H5Eclear2(H5E_DEFAULT);
    throw Error(path + ": not an HDF5 file");
  }
  if (is < 0) throw Error(path + ": cannot read the file: " + error_stack_text());
  Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw Error(path + ": cannot open the HDF5 file (truncated or damaged?): " + error_stack_text());
  return File(std::move(f), path, "/");
}

void File::abandon() {
  if (!h_.valid()) return;
  h_.release();
  exit_without_finalize_on_error();  // HDF5 would close it at MPI_Finalize, and crash
}

void File::flush() const {
  errno = 0;
  const herr_t st = H5Fflush(id(), H5F_SCOPE_GLOBAL);
  const int err = errno;
  check_all(st,
            std::string("cannot flush the file to disk") +
                (st < 0 && err ? " (" + std::string(std::strerror(err)) + ")" : ""));
}

void File::close() {
  if (!h_.valid()) return;
  const herr_t s = H5Fclose(h_.release());
  check_all(s, "closing the file");
}

}  // namespace fabrica::h5
