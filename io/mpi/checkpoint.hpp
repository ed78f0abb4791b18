// Checkpoints: the complete state of a run in one file, written collectively with MPI-IO and
// readable on any number of ranks (docs/checkpoint.md).
//
// File layout (docs/checkpoint.md#format; every value little-endian whatever the machine):
//   header (kHeaderBytes): its fields and the section table, io/mpi/checkpoint_format.hpp;
//   sections, one after the other, of three kinds: "global" (bytes every rank knows
//     identically, written by rank 0: named, typed fields with their layout, io/mpi/fields.hpp;
//     a simulation's, io/mpi/simulation_fields.hpp), "per-rank" (one record per writer rank,
//     in rank order) and "distributed" (fixed-size records, each rank's in rank order:
//     particles and contacts, io/mpi/state_fields.hpp);
//   trailer: "FABREND" and a position-weighted checksum of every byte before it.
// The file itself, through MPI-IO: io/mpi/checkpoint_file.hpp (written as DIR/name.tmp and
// renamed, so that a run killed at any moment leaves the previous complete checkpoint in
// place). A reader on any number of ranks reads the header and the small sections on every
// rank and only its own range of the distributed records, so no rank holds the whole specimen.
// Files of earlier formats: io/mpi/checkpoint_older.hpp. When to take one, and the CSV series
// of a restart: io/mpi/checkpoint_schedule.hpp.
#pragma once
#include "core/simulation.hpp"
#include "io/mpi/checkpoint_file.hpp"
#include "io/mpi/checkpoint_format.hpp"
#include "io/mpi/checkpoint_schedule.hpp"
#include "io/mpi/fields.hpp"

#include <mpi.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <functional>
#include <string>
#include <vector>

namespace fabrica {

// Appends plain values to a byte string, as their bytes (the applications' cursors; prefer
// FieldWriter and CheckpointWriter::add_fields for anything new).
class Bytes {
 public:
  template <class T>
  Bytes& put(const T& v) {
    const char* c = reinterpret_cast<const char*>(&v);
    s_.append(c, sizeof(T));
    return *this;
  }
  Bytes& put_string(const std::string& v) {
    put(std::uint64_t(v.size()));
    s_ += v;
    return *this;
  }
  const std::string& str() const { return s_; }

 private:
  std::string s_;
};

// Reads them back; throws InputError naming the file and the section if they run short.
class BytesIn {
 public:
  BytesIn(std::string data, std::string where) : s_(std::move(data)), where_(std::move(where)) {}
  template <class T>
  T get() {
    T v;
    need(sizeof(T));
    std::memcpy(static_cast<void*>(&v), s_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string get_string();
  bool done() const { return pos_ == s_.size(); }

 private:
  void need(std::size_t n) const;
  std::string s_, where_;
  std::size_t pos_ = 0;
};

// Stages the sections of one checkpoint, then writes it. Every rank of 'comm' makes the same
// calls in the same order (collective).
class CheckpointWriter {
 public:
  CheckpointWriter(MPI_Comm comm, std::uint64_t scene_fingerprint, std::string app, bool blowup = false);

  // The state of 'sim' under sections "<prefix>.global", ".particles", ".contacts",
  // ".dissipation". The step and time of the header are those of the first simulation added.
  // The particle and contact records are made by write(), in blocks of kBlockRecords: 'sim'
  // must outlive it, unchanged.
  void add_simulation(const std::string& prefix, const Simulation& sim);
  // Bytes every rank knows identically (written by rank 0).
  void add_global(const std::string& name, std::string bytes);
  // Fields every rank knows identically, with their layout (read with Checkpoint::fields).
  void add_fields(const std::string& name, const FieldWriter& fields);
  // A distributed section of this rank's records, 'record_bytes' each, already encoded (read
  // with Checkpoint::records; any rank count reads its range of them).
  void add_records(const std::string& name, std::uint32_t record_bytes, std::string records);

  static constexpr std::uint64_t kBlockRecords = std::uint64_t(1) << 16;
  // Records per block (tests: many blocks from a small specimen; the file is the same).
  void set_block_records(std::uint64_t n) { block_records_ = n > 0 ? n : 1; }

  // Writes 'path' atomically (path.tmp, sync, rename). Collective; throws CollectiveError on
  // an I/O failure (the same on every rank). Returns the file size in bytes.
  std::uint64_t write(const std::string& path);

 private:
  struct Staged {
    std::string name;
    SectionKind kind;
    std::uint32_t record_bytes;  // 0: a global section
    std::string local;           // this rank's block, or the whole (global) section
    // Distributed records made at write time, a block at a time, instead of 'local', so that a
    // rank never holds its whole share of the file: 'records' here, and produce(first, n, out)
    // appends records [first, first + n) of this rank to out.
    std::uint64_t records = 0;
    std::function<void(std::uint64_t, std::uint64_t, std::string&)> produce = {};
    std::uint64_t bytes() const { return produce ? records * record_bytes : local.size(); }
  };
  // The section table and this rank's offset of each section (collective).
  std::vector<std::uint64_t> lay_out();
  // Writes section s at this rank's 'offset' (collective); adds its bytes' checksum to 'part'.
  void write_section(CheckpointOutFile& file, const Staged& s, std::uint64_t offset, std::uint64_t& part);
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  CheckpointHeader head_;
  std::vector<Staged> staged_;
  bool have_step_ = false;
  std::uint64_t block_records_ = kBlockRecords;
};

// A checkpoint read and checked: magic, format version, size, section table, checksum, and
// (when 'scene_text' is given) the scene fingerprint. Collective: every rank reads the header
// and the small sections, and its own range of the distributed records (1/P of them); the
// checksum is summed over the ranks. Every error is an InputError naming the file and what is
// wrong, thrown on every rank alike (the lowest rank's message when they differ).
class Checkpoint {
 public:
  struct Expect {
    const std::string* scene_text = nullptr;  // refuse a checkpoint of another scene
    std::string app;                          // refuse another application ("" = any)
    bool allow_blowup = false;                // refuse a blow-up checkpoint unless set
  };
  static Checkpoint read(MPI_Comm comm, const std::string& path, const Expect& expect);

  const CheckpointHeader& header() const { return head_; }
  const std::string& path() const { return path_; }
  bool has(const std::string& name) const;
  std::string section(const std::string& name) const;  // the bytes of a global section
  // The fields of a section written with CheckpointWriter::add_fields (valid while this lives).
  FieldReader fields(const std::string& name) const;
  // This rank's range of the records of a section written with CheckpointWriter::add_records
  // (rank r of P: records n r / P to n (r + 1) / P); an InputError if its records are not of
  // 'record_bytes' bytes.
  const std::string& records(const std::string& name, std::uint32_t record_bytes) const;
  // The snapshot of a simulation saved under 'prefix': this rank's range of the particles and
  // contacts (holding = Share: Simulation's constructor sends them to their owners); the
  // dissipation accumulators go to the same ranks when the rank count is unchanged, else their
  // sum goes to rank 0.
  SimulationSnapshot simulation(const std::string& prefix, MPI_Comm comm) const;
  // The cell of the simulation saved under 'prefix' (from its global section alone).
  PeriodicCell cell(const std::string& prefix) const;

 private:
  const CheckpointSection& find(const std::string& name) const;
  // Reads and checks the header and this rank's parts of the sections; returns what is wrong.
  std::string load(const CheckpointInFile& file, MPI_Comm comm);
  // The refusals of 'expect' (another scene, another application, a blow-up state).
  void check(const Expect& expect) const;
  // The dissipation and gravity work of 'prefix' into 'snap' (rank of size ranks).
  void read_per_rank(const std::string& prefix, const std::string& where, int rank, int size,
                     SimulationSnapshot& snap) const;
  struct Chunk {
    std::uint64_t first = 0;  // this rank's first record
    std::string bytes;
  };
  std::string path_;
  CheckpointHeader head_;
  std::map<std::string, std::string> small_;  // global and per-rank sections
  std::map<std::string, Chunk> chunks_;       // this rank's records of the distributed ones
};

}  // namespace fabrica
