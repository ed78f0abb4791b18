// A thin RAII layer over the HDF5 C API: every handle closes itself, and every failing call
// throws h5::Error naming the file, the object and HDF5's own innermost message (HDF5's
// automatic printing of its error stack is switched off). Used by io/mpi/run_output (parallel,
// collective, MPI-IO) and io/mpi/snapshot (serial reader). See docs/output.md for the file layout.
#pragma once
#include <hdf5.h>
#include <mpi.h>

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace fabrica::h5 {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One open HDF5 identifier and the function that closes it; move-only.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() { reset(); }
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_, close_ = o.close_;
      o.id_ = H5I_INVALID_HID;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  hid_t release() {
    const hid_t id = id_;
    id_ = H5I_INVALID_HID;
    return id;
  }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = H5I_INVALID_HID;
  }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

// The element types stored by Fabrica.
enum class Type { F64, I64, U8 };
hid_t native(Type t);

// A group, a dataset or the file itself, with the file's path and the object's name for messages.
class Object {
 public:
  Object() = default;
  Object(Handle h, std::string file, std::string name, MPI_Comm comm = MPI_COMM_NULL)
      : h_(std::move(h)), file_(std::move(file)), name_(std::move(name)), comm_(comm) {}
  hid_t id() const { return h_.get(); }
  bool valid() const { return h_.valid(); }
  const std::string& file() const { return file_; }
  const std::string& name() const { return name_; }  // absolute path in the file
  std::string child_name(const std::string& rel) const { return name_ == "/" ? "/" + rel : name_ + "/" + rel; }
  // Throws Error("<file>: <object>: <what>: <HDF5 message>") if status < 0.
  void check(herr_t status, const std::string& what) const;
  [[noreturn]] void fail(const std::string& what) const;
  // For a collective call of a file opened over a communicator: the ranks agree on 'status';
  // if it failed on any rank, every rank throws the Error of the lowest such rank. Serially,
  // check(). A write that fails on one rank (its part of a full disk) so ends every rank alike.
  void check_all(herr_t status, const std::string& what) const;
  MPI_Comm comm() const { return comm_; }  // MPI_COMM_NULL: a serial file

  // Attributes (scalars, 1-D arrays, strings), on this object.
  void set_attr(const std::string& attr, double v) const;
  void set_attr(const std::string& attr, std::int64_t v) const;
  void set_attr(const std::string& attr, std::span<const double> v) const;
  void set_attr(const std::string& attr, const std::string& v) const;
  bool has_attr(const std::string& attr) const;
  double attr_double(const std::string& attr) const;
  std::int64_t attr_int(const std::string& attr) const;
  std::vector<double> attr_doubles(const std::string& attr) const;
  std::string attr_string(const std::string& attr) const;

 protected:
  Handle h_;
  std::string file_, name_;
  MPI_Comm comm_ = MPI_COMM_NULL;
};

class Dataset;

class Group : public Object {
 public:
  using Object::Object;
  Group create_group(const std::string& rel) const;
  Group open_group(const std::string& rel) const;
  // True if every component of the relative path 'rel' exists.
  bool exists(const std::string& rel) const;
  std::vector<std::string> children() const;  // names of the links, in name order
  void remove(const std::string& rel) const;  // unlinks 'rel' (H5Ldelete; collective under MPI-IO)
  // A second name 'rel' (intermediate groups created) for the object at the absolute path
  // 'target' of the same file (H5Lcreate_hard: the object is stored once; collective under MPI-IO).
  void link(const std::string& rel, const std::string& target) const;

  // A dataset of 'rows' x 'cols' elements (cols = 0: one-dimensional). With chunk_rows > 0 it is
  // chunked and extendible along the rows (for appending).
  Dataset create_dataset(const std::string& rel, Type t, hsize_t rows, hsize_t cols, hsize_t chunk_rows = 0) const;
  // A fixed-size dataset of any rank 'dims' (chunked along the first dimension, checksummed like
  // the others): the coarse-grained fields (nz, ny, nx[, components]). Written with write_rows.
  Dataset create_dataset(const std::string& rel, Type t, const std::vector<hsize_t>& dims) const;
  Dataset open_dataset(const std::string& rel) const;
  // A scalar dataset holding a string (any length).
  void write_string(const std::string& rel, const std::string& text, bool writer) const;
  std::string read_string(const std::string& rel) const;
};

class Dataset : public Object {
 public:
  using Object::Object;
  std::vector<hsize_t> shape() const;
  // Writes rows [row0, row0 + n) of a dataset with 'cols' columns per row (0 = 1-D) from 'data'
  // (n * max(cols, 1) elements). Collective transfer when 'collective' (every rank of the file's
  // communicator calls, n = 0 allowed), independent otherwise.
  void write_rows(Type t, hsize_t row0, hsize_t n, const void* data, bool collective) const;
  void extend(hsize_t rows) const;  // sets the number of rows (grows or shrinks); collective under MPI-IO
  // The whole dataset, converted to the requested type.
  std::vector<double> read_doubles() const;
  std::vector<std::int64_t> read_ints() const;
  std::vector<std::uint8_t> read_bytes() const;
  // Reads every element (in the file's own type, discarded), so that HDF5 verifies each chunk's
  // Fletcher-32 checksum; throws Error naming the dataset on a mismatch. Returns the bytes read.
  std::size_t verify() const;
  bool has_checksum() const;            // the dataset carries the Fletcher-32 filter
  [[noreturn]] void fail_read() const;  // after a failed H5Dread: Error naming the dataset
};

class File : public Group {
 public:
  File() = default;
  // Creates 'path' collectively over 'comm' with MPI-IO; refuses an existing file unless
  // 'truncate'.
  static File create_parallel(const std::string& path, MPI_Comm comm, bool truncate);
  // Opens an existing 'path' read-write, collectively over 'comm' with MPI-IO (a restart).
  static File open_parallel(const std::string& path, MPI_Comm comm);
  // Opens 'path' read-only, serially (the reader and `fabrica info`).
  static File open_read(const std::string& path);
  void flush() const;  // H5Fflush of the whole file (collective under MPI-IO)
  void close();        // closes the file; idempotent
  // Forgets the file without closing it: for a rank that unwinds from an error the other ranks
  // do not share (closing is collective under MPI-IO and would wait for them forever); the
  // process then ends through MPI_Abort (parallel/guard.hpp).
  void abandon();

 private:
  using Group::Group;
};

// Switches off HDF5's printing of its error stack (the messages go into h5::Error instead).
void quiet();

// Whether datasets created from now on carry the Fletcher-32 checksum (default: yes). Only
// benchmarks/bench_io switches it off, to measure what the checksum costs.
void set_checksums(bool on);
bool checksums_enabled();

}  // namespace fabrica::h5
