#include "io/mpi/checkpoint.hpp"

#include "core/fault.hpp"
#include "io/serial/write_check.hpp"

#include "core/errors.hpp"
#include "io/mpi/fields.hpp"
#include "io/mpi/state_fields.hpp"
#include "parallel/mpi_context.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#ifndef FABRICA_VERSION
#define FABRICA_VERSION "unknown"
#endif

namespace fabrica {
namespace {

constexpr char kMagic[8] = {'F', 'A', 'B', 'R', 'C', 'K', 'P', 'T'};
constexpr char kEndMagic[8] = {'F', 'A', 'B', 'R', 'E', 'N', 'D', '\0'};
constexpr std::size_t kTrailerBytes = 16;
constexpr std::size_t kNameBytes = 24;
constexpr std::size_t kEntryBytes = kNameBytes + 32;  // name, offset, bytes, records, record size, kind
constexpr std::size_t kTableFirst = 128;              // the section table starts here in the header
constexpr std::size_t kMaxSections = (kHeaderBytes - kTableFirst) / kEntryBytes;
constexpr std::uint32_t kFlagBlowup = 1;
constexpr std::uint64_t kChunk = std::uint64_t(1) << 30;  // bytes per MPI-IO call at most

// Position-weighted sum of the bytes, each with an odd weight: a changed byte always changes it.
// Sums of disjoint ranges add up (unsigned wrap-around), so ranks checksum their own blocks.
std::uint64_t checksum(const char* data, std::size_t n, std::uint64_t offset) {
  std::uint64_t s = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint64_t w = ((offset + k + 1) * 0x9E3779B97F4A7C15ull) | 1ull;
    s += (std::uint64_t(static_cast<unsigned char>(data[k])) + 1) * w;
  }
  return s;
}

void fixed_string(std::string& out, std::size_t at, const std::string& s, std::size_t width) {
  for (std::size_t k = 0; k < width; ++k) out[at + k] = k < s.size() && k + 1 < width ? s[k] : '\0';
}
std::string read_fixed(const char* at, std::size_t width) {
  std::size_t n = 0;
  while (n < width && at[n]) ++n;
  return std::string(at, n);
}
// Header values, little-endian at fixed offsets.
void poke(std::string& out, std::size_t at, std::uint64_t v, int bytes) {
  std::string b;
  put_le(b, v, bytes);
  out.replace(at, std::size_t(bytes), b);
}
std::uint64_t peek(const std::string& in, std::size_t at, int bytes) { return get_le(in.data() + at, bytes); }
std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, 8);
  return b;
}
double from_bits(std::uint64_t b) {
  double v;
  std::memcpy(&v, &b, 8);
  return v;
}

std::string encode_header(const CheckpointHeader& h) {
  std::string out(kHeaderBytes, '\0');
  std::memcpy(out.data(), kMagic, 8);
  poke(out, 8, h.format, 4);
  poke(out, 12, kHeaderBytes, 4);
  fixed_string(out, 16, h.software, 16);
  poke(out, 32, h.scene_fingerprint, 8);
  poke(out, 40, std::uint32_t(h.ranks), 4);
  poke(out, 44, h.blowup ? kFlagBlowup : 0, 4);
  poke(out, 48, std::uint64_t(h.step), 8);
  poke(out, 56, bits(h.time), 8);
  fixed_string(out, 64, h.app, 16);
  poke(out, 80, h.file_bytes, 8);
  poke(out, 88, h.sections.size(), 4);
  std::size_t at = kTableFirst;
  for (const CheckpointSection& s : h.sections) {
    fixed_string(out, at, s.name, kNameBytes);
    poke(out, at + kNameBytes, s.offset, 8);
    poke(out, at + kNameBytes + 8, s.bytes, 8);
    poke(out, at + kNameBytes + 16, s.records, 8);
    poke(out, at + kNameBytes + 24, s.record_bytes, 4);
    poke(out, at + kNameBytes + 28, std::uint32_t(s.kind), 4);
    at += kEntryBytes;
  }
  return out;
}

// The checks that need only the header; returns what is wrong ("" if nothing).
std::string decode_header(const std::string& in, CheckpointHeader& h) {
  if (in.size() < 8 || std::memcmp(in.data(), kMagic, 8) != 0)
    return "not a Fabrica checkpoint (no FABRCKPT magic at the start)";
  if (in.size() < kHeaderBytes)
    return "truncated: " + std::to_string(in.size()) + " bytes, shorter than the header (" +
        std::to_string(kHeaderBytes) + " bytes)";
  h.format = std::uint32_t(peek(in, 8, 4));
  if (h.format < kOldestCheckpointFormat || h.format > kCheckpointFormat)
    return "checkpoint format version " + std::to_string(h.format) + ", this build of Fabrica (" + FABRICA_VERSION +
        ") reads versions " + std::to_string(kOldestCheckpointFormat) + " to " + std::to_string(kCheckpointFormat) +
        " only";
  if (peek(in, 12, 4) != kHeaderBytes) return "corrupted header (header size)";
  h.software = read_fixed(in.data() + 16, 16);
  h.scene_fingerprint = peek(in, 32, 8);
  h.ranks = std::int32_t(std::uint32_t(peek(in, 40, 4)));
  h.blowup = peek(in, 44, 4) & kFlagBlowup;
  h.step = std::int64_t(peek(in, 48, 8));
  h.time = from_bits(peek(in, 56, 8));
  h.app = read_fixed(in.data() + 64, 16);
  h.file_bytes = peek(in, 80, 8);
  const auto ns = peek(in, 88, 4);
  if (ns > kMaxSections) return "corrupted header (section count " + std::to_string(ns) + ")";
  if (h.ranks < 1) return "corrupted header (writer rank count " + std::to_string(h.ranks) + ")";
  h.sections.clear();
  std::size_t at = kTableFirst;
  for (std::uint64_t k = 0; k < ns; ++k, at += kEntryBytes) {
    CheckpointSection s;
    s.name = read_fixed(in.data() + at, kNameBytes);
    s.offset = peek(in, at + kNameBytes, 8);
    s.bytes = peek(in, at + kNameBytes + 8, 8);
    s.records = peek(in, at + kNameBytes + 16, 8);
    s.record_bytes = std::uint32_t(peek(in, at + kNameBytes + 24, 4));
    const auto kind = peek(in, at + kNameBytes + 28, 4);
    if (kind > 2) return "corrupted header (kind of section " + s.name + ")";
    s.kind = SectionKind(kind);
    if (s.kind != SectionKind::Global && (s.record_bytes == 0 || s.bytes != s.records * s.record_bytes))
      return "corrupted header (size of section " + s.name + ")";
    h.sections.push_back(s);
  }
  return "";
}

// The ranks agree on the outcome of an MPI-IO call; if it failed on any rank, every rank throws
// the message of the lowest such rank ('detail' adds to MPI's own text).
void check_mpi(int err, MPI_Comm comm, const std::string& what, const std::string& path,
               const std::string& detail = "") {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  int first = err != MPI_SUCCESS ? rank : size;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return;
  std::string msg;
  if (err != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(err, text, &len);
    msg = what + ": " + std::string(text, std::size_t(len)) + detail;
    if (size > 1) msg += " on rank " + std::to_string(rank);
  }
  int len = int(msg.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  msg.resize(std::size_t(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, first, comm);
  throw CollectiveError(path + ": cannot write the checkpoint (" + msg + "); the previous checkpoint, if any, is kept");
}

// The message of the lowest rank whose 'error' is not empty ("" if none), on every rank.
std::string agreed(MPI_Comm comm, const std::string& error) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  int first = error.empty() ? size : rank;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size) return "";
  std::string msg = error;
  int len = int(msg.size());
  MPI_Bcast(&len, 1, MPI_INT, first, comm);
  msg.resize(std::size_t(len));
  MPI_Bcast(msg.data(), len, MPI_CHAR, first, comm);
  return msg;
}

// Reads n bytes at 'offset' (independent I/O, in chunks below 2 GiB); "" or what went wrong.
std::string read_at(MPI_File fh, std::uint64_t offset, std::uint64_t n, std::string& out) {
  out.resize(std::size_t(n));
  for (std::uint64_t k = 0; k < n; k += kChunk) {
    const std::uint64_t len = std::min(n - k, kChunk);
    MPI_Status st;
    const int err = MPI_File_read_at(fh, MPI_Offset(offset + k), out.data() + k, int(len), MPI_BYTE, &st);
    int count = 0;
    if (err == MPI_SUCCESS) MPI_Get_count(&st, MPI_BYTE, &count);
    if (err != MPI_SUCCESS || std::uint64_t(count) != len) {
      char text[MPI_MAX_ERROR_STRING];
      int tl = 0;
      if (err != MPI_SUCCESS) MPI_Error_string(err, text, &tl);
      return "cannot read " + std::to_string(len) + " bytes at offset " + std::to_string(offset + k) +
          (err != MPI_SUCCESS ? " (" + std::string(text, std::size_t(tl)) + ")"
                              : " (" + std::to_string(count) + " read)");
    }
  }
  return "";
}

void put_f64(std::string& out, double v) { put_le(out, bits(v), 8); }

}  // namespace

std::uint64_t scene_fingerprint(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

std::string BytesIn::get_string() {
  const auto n = get<std::uint64_t>();
  need(n);
  std::string v = s_.substr(pos_, n);
  pos_ += n;
  return v;
}

void BytesIn::need(std::size_t n) const {
  if (s_.size() - pos_ < n) throw InputError(where_ + ": section ends early (corrupted checkpoint)");
}

// ---------------------------------------------------------------------------------- writing

CheckpointWriter::CheckpointWriter(MPI_Comm comm, std::uint64_t fingerprint, std::string app, bool blowup)
    : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  head_.format = kCheckpointFormat;
  head_.software = FABRICA_VERSION;
  head_.scene_fingerprint = fingerprint;
  head_.ranks = size_;
  head_.blowup = blowup;
  head_.app = std::move(app);
}

void CheckpointWriter::add_global(const std::string& name, std::string bytes) {
  staged_.push_back({name, SectionKind::Global, 0, std::move(bytes)});
}

void CheckpointWriter::add_fields(const std::string& name, const FieldWriter& fields) {
  std::string b;
  put_le(b, fields.schema().size(), 8);
  b += fields.schema();
  b += fields.bytes();
  add_global(name, std::move(b));
}

void CheckpointWriter::add_simulation(const std::string& prefix, const Simulation& sim) {
  if (!have_step_) {
    head_.step = sim.step_count();
    head_.time = sim.time();
    have_step_ = true;
  }
  const SimulationParams& par = sim.params();
  const bool twisting = par.twisting();
  const bool materials = !par.materials.empty();
  FieldWriter g;
  g.text("particle_record", particle_record_schema(materials)).text("contact_record", contact_record_schema(twisting));
  g.vec3("cell.lengths", sim.cell().lengths()).vec3("cell.strain_rate", sim.cell().strain_rate());
  write_law(g, par.law);
  g.f64("dt", par.dt).f64("skin", par.skin).vec3("gravity", par.gravity);
  g.f64("local_damping", par.local_damping).u64("walls", par.walls.size());
  for (const Wall& w : par.walls) {  // its plane, velocity and law (format 4)
    g.vec3("wall.point", w.point).vec3("wall.normal", w.normal).vec3("wall.velocity", w.velocity);
    g.u8("wall.own_law", w.own_law ? 1 : 0);
    if (w.own_law) write_law(g, w.law);
    g.f64("wall.servo_pressure", w.servo_pressure).f64("wall.servo_relaxation", w.servo_relaxation);
    g.f64("wall.servo_max_speed", w.servo_max_speed);   // format 6
    if (materials) g.i32("wall.material", w.material);  // format 10
  }
  g.u64("driven", par.driven.size());  // the sets of driven particles (format 4)
  for (const DrivenSet& d : par.driven) {
    g.i64("driven.first", d.first).i64("driven.last", d.last).u64("driven.ids", d.ids.size());
    for (GlobalId id : d.ids) g.i64("driven.id", id);
    g.vec3("driven.velocity", d.velocity).vec3("driven.spin", d.spin);
  }
  g.u8("spatial_sort", par.spatial_sort ? 1 : 0);
  if (materials) write_materials(g, par.materials);  // format 10
  g.i64("step", sim.step_count()).i64("rebuilds", sim.rebuild_count()).f64("time", sim.time());
  write_macro(g, sim.macro());
  Simulation& mut = const_cast<Simulation&>(sim);  // Domain accessors are not const
  const DecompositionRecord dec = mut.domain().decomposition_record();
  g.vec3("decomposition_lengths", dec.lengths).i64("decomposition_cuts", std::int64_t(dec.cuts.size()));
  for (std::int32_t c : dec.cuts) g.i32("decomposition_cut", c);  // format 5
  g.i64("decomposition_since_check", dec.since_check);
  const EnergyAccount ea = sim.energy_account();
  g.f64("energy.e0", ea.e0).f64("energy.work", ea.work).vec3("energy.vol_strain", ea.vol_strain);
  g.mat3("energy.stress_prev", ea.stress_prev);
  g.f64("energy.wall_work", ea.wall_work).f64("energy.drive_work", ea.drive_work);
  add_fields(prefix + ".global", g);

  Staged parts{prefix + ".particles", SectionKind::Distributed, std::uint32_t(particle_record_bytes(materials)), {}};
  parts.records = sim.particles().n_owned();
  parts.produce = [&sim, materials](std::uint64_t first, std::uint64_t n, std::string& out) {
    write_particles(sim.particles(), std::size_t(first), std::size_t(n), out, materials);
  };
  staged_.push_back(std::move(parts));
  Staged contacts{prefix + ".contacts", SectionKind::Distributed, std::uint32_t(contact_record_bytes(twisting)), {}};
  sim.for_each_contact([&](GlobalId, GlobalId, const ContactHistory&) { ++contacts.records; });
  // Records [first, first + n) of the contacts in for_each_contact's order; the cursor makes
  // the blocks, written in order, one pass over the lists in all.
  contacts.produce = [&sim, twisting, at = Simulation::ContactCursor{}](std::uint64_t first, std::uint64_t n,
                                                                        std::string& out) mutable {
    sim.for_each_contact_in(
        first, n, at, [&](GlobalId a, GlobalId b, const ContactHistory& h) { write_contact(a, b, h, twisting, out); });
  };
  staged_.push_back(std::move(contacts));
  FieldWriter d;
  write_dissipation(d, sim.dissipation());
  staged_.push_back({prefix + ".dissipation", SectionKind::PerRank, 32, d.take_bytes()});
  std::string gw;
  put_f64(gw, ea.gravity_work_local);
  staged_.push_back({prefix + ".gravity_work", SectionKind::PerRank, 8, std::move(gw)});
}

std::uint64_t CheckpointWriter::write(const std::string& path) {
  const std::size_t ns = staged_.size();
  if (ns > kMaxSections) throw std::logic_error("checkpoint: too many sections");
  // Sizes of every rank's blocks, and the offsets that follow.
  std::vector<std::uint64_t> mine(ns), all(ns * std::size_t(size_));
  for (std::size_t s = 0; s < ns; ++s) mine[s] = staged_[s].bytes();
  MPI_Allgather(mine.data(), int(ns), MPI_UINT64_T, all.data(), int(ns), MPI_UINT64_T, comm_);
  std::vector<std::uint64_t> my_offset(ns);
  head_.sections.clear();
  std::uint64_t at = kHeaderBytes;
  for (std::size_t s = 0; s < ns; ++s) {
    CheckpointSection sec{staged_[s].name, at, 0, 0, staged_[s].record_bytes, staged_[s].kind};
    if (staged_[s].kind != SectionKind::Global) {
      for (int r = 0; r < size_; ++r) {
        if (r == rank_) my_offset[s] = at + sec.bytes;
        sec.bytes += all[std::size_t(r) * ns + s];
      }
      sec.records = sec.bytes / staged_[s].record_bytes;
    } else {
      sec.bytes = mine[s];  // identical on every rank
      my_offset[s] = at;
    }
    at += sec.bytes;
    head_.sections.push_back(sec);
  }
  head_.file_bytes = at + kTrailerBytes;
  const std::string header = encode_header(head_);

  // Checksum: each rank its blocks (rank 0 the header and global sections), summed over the
  // ranks once every block is written.
  std::uint64_t part = 0;
  if (rank_ == 0) part += checksum(header.data(), header.size(), 0);
  const std::string tmp = path + ".tmp";
  MPI_File fh;
  check_mpi(MPI_File_open(comm_, tmp.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &fh), comm_,
            "open " + tmp, path);
  MPI_File_set_errhandler(fh, MPI_ERRORS_RETURN);
  auto write_at = [&](std::uint64_t offset, const std::string& bytes, bool mine_to_write, const std::string& what) {
    const std::string& b = mine_to_write ? bytes : std::string();
    if (b.size() > std::size_t(std::numeric_limits<int>::max()))
      throw std::runtime_error(path + ": a checkpoint block above 2 GiB on one rank");
    MPI_Status st;
    int err = MPI_File_write_at_all(fh, MPI_Offset(offset), b.data(), int(b.size()), MPI_BYTE, &st);
    // A write can succeed short (a full disk, a file-size limit): the count must be the size.
    int count = 0;
    if (err == MPI_SUCCESS) MPI_Get_count(&st, MPI_BYTE, &count);
    std::string detail;
    if (err == MPI_SUCCESS && (count != int(b.size()) || fault_injected("ckpt_write"))) {
      err = MPI_ERR_IO;
      detail = fault_injected("ckpt_write")
          ? " (" + fault_text("ckpt_write") + ")"
          : " (" + std::to_string(count) + " of " + std::to_string(b.size()) + " bytes written: is the disk full?)";
    }
    check_mpi(err, comm_, "write " + what + " to " + tmp, path, detail);
  };
  try {
    check_mpi(MPI_File_set_size(fh, 0), comm_, "truncate " + tmp, path);
    write_at(0, header, rank_ == 0, "header");
    for (std::size_t s = 0; s < ns; ++s) {
      const Staged& st = staged_[s];
      const bool mine_to_write = st.kind != SectionKind::Global || rank_ == 0;
      if (!st.produce) {
        write_at(my_offset[s], st.local, mine_to_write, st.name);
        if (mine_to_write) part += checksum(st.local.data(), st.local.size(), my_offset[s]);
        continue;
      }
      // Block by block; every rank takes part in as many collective writes as the rank with
      // the most blocks (the others with none left write nothing).
      std::uint64_t blocks = (st.records + block_records_ - 1) / block_records_;
      MPI_Allreduce(MPI_IN_PLACE, &blocks, 1, MPI_UINT64_T, MPI_MAX, comm_);
      std::string block;
      for (std::uint64_t b = 0; b < blocks; ++b) {
        const std::uint64_t first = std::min(st.records, b * block_records_);
        const std::uint64_t n = std::min(block_records_, st.records - first);
        block.clear();
        st.produce(first, n, block);
        if (block.size() != n * st.record_bytes)
          throw std::logic_error("checkpoint: section " + st.name + " changed while it was written");
        const std::uint64_t offset = my_offset[s] + first * st.record_bytes;
        write_at(offset, block, true, st.name);
        part += checksum(block.data(), block.size(), offset);
      }
    }
    std::uint64_t sum = 0;
    MPI_Reduce(&part, &sum, 1, MPI_UINT64_T, MPI_SUM, 0, comm_);  // unsigned: modulo 2^64
    std::string trailer(kEndMagic, 8);
    put_le(trailer, sum, 8);
    write_at(at, trailer, rank_ == 0, "trailer");
    check_mpi(MPI_File_sync(fh), comm_, "sync " + tmp, path);
  } catch (const CollectiveError&) {  // every rank is here: close, keep the last checkpoint
    MPI_File_close(&fh);
    if (rank_ == 0) std::remove(tmp.c_str());  // the partial file gives its space back
    throw;
  }
  check_mpi(MPI_File_close(&fh), comm_, "close " + tmp, path);
  // The complete file is on disk before it replaces the previous checkpoint: rank 0 checks the
  // size of the temporary, and every rank learns the outcome.
  int short_file = 0;
  std::uint64_t on_disk = 0;
  if (rank_ == 0) {
    std::error_code ec;
    on_disk = std::filesystem::file_size(tmp, ec);
    short_file = ec || on_disk != head_.file_bytes;
  }
  MPI_Bcast(&short_file, 1, MPI_INT, 0, comm_);
  if (short_file && rank_ == 0) std::remove(tmp.c_str());
  if (short_file)
    check_mpi(rank_ == 0 ? MPI_ERR_IO : MPI_SUCCESS, comm_, "check " + tmp, path,
              " (" + std::to_string(on_disk) + " bytes on disk, " + std::to_string(head_.file_bytes) + " written)");
  // Rank 0 replaces the previous checkpoint (atomic rename) and syncs the directory entry.
  int err = 0;
  if (rank_ == 0) {
    err = std::rename(tmp.c_str(), path.c_str()) != 0 ? errno : 0;
    if (!err) {
      std::filesystem::path dir = std::filesystem::path(path).parent_path();
      if (dir.empty()) dir = ".";
      const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
      if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
      }
    }
  }
  MPI_Bcast(&err, 1, MPI_INT, 0, comm_);
  if (err) throw CollectiveError(path + ": cannot rename " + tmp + " to it (" + std::strerror(err) + ")");
  return head_.file_bytes;
}

// ---------------------------------------------------------------------------------- reading

Checkpoint Checkpoint::read(MPI_Comm comm, const std::string& path, const Expect& expect) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  Checkpoint c;
  c.path_ = path;
  auto fail = [&](const std::string& error) {
    if (const std::string e = agreed(comm, error); !e.empty()) throw InputError(path + ": " + e);
  };
  // Every rank reads for itself: the header, the small sections, and its share of the records of
  // the distributed ones (particles, contacts); no rank reads or holds the whole file.
  std::string error;
  if (fault_injected("checkpoint")) error = "cannot read the checkpoint (" + fault_text("checkpoint") + ")";
  else if (std::error_code ec; std::filesystem::is_directory(path, ec))
    error = "cannot open the checkpoint (it is a directory)";
  else if (::access(path.c_str(), R_OK) != 0)
    error = "cannot open the checkpoint (" + std::string(std::strerror(errno)) + ")";
  fail(error);
  MPI_File fh;
  int err = MPI_File_open(comm, path.c_str(), MPI_MODE_RDONLY, MPI_INFO_NULL, &fh);
  if (err != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(err, text, &len);
    error = "cannot open the checkpoint (" + std::string(text, std::size_t(len)) + ")";
  }
  const bool opened = err == MPI_SUCCESS;
  try {
    fail(error);
    if (opened) MPI_File_set_errhandler(fh, MPI_ERRORS_RETURN);
    MPI_Offset on_disk = 0;
    MPI_File_get_size(fh, &on_disk);
    std::string head;
    error = read_at(fh, 0, std::min<std::uint64_t>(std::uint64_t(on_disk), kHeaderBytes), head);
    if (error.empty()) error = decode_header(head, c.head_);
    if (error.empty() && std::uint64_t(on_disk) != c.head_.file_bytes)
      error = "truncated or extended: " + std::to_string(on_disk) + " bytes, the header says " +
          std::to_string(c.head_.file_bytes) + " (an interrupted copy?)";
    // The sections follow one another from the header to the trailer, with no gap.
    std::uint64_t at = kHeaderBytes;
    for (const CheckpointSection& s : c.head_.sections) {
      if (!error.empty()) break;
      if (s.offset != at || s.offset + s.bytes > c.head_.file_bytes - kTrailerBytes)
        error = "corrupted: section " + s.name + " lies outside its place in the file";
      at = s.offset + s.bytes;
    }
    if (error.empty() && at != c.head_.file_bytes - kTrailerBytes)
      error = "corrupted: the sections do not fill the file";
    fail(error);
    // Small sections whole; distributed ones, this rank's range of records.
    std::uint64_t part = rank == 0 ? checksum(head.data(), head.size(), 0) : 0;
    for (const CheckpointSection& s : c.head_.sections) {
      if (!error.empty()) break;
      if (s.kind == SectionKind::Distributed) {
        Chunk& ch = c.chunks_[s.name];
        ch.first = s.records * std::uint64_t(rank) / std::uint64_t(size);
        const std::uint64_t last = s.records * std::uint64_t(rank + 1) / std::uint64_t(size);
        const std::uint64_t off = s.offset + ch.first * s.record_bytes;
        error = read_at(fh, off, (last - ch.first) * s.record_bytes, ch.bytes);
        part += checksum(ch.bytes.data(), ch.bytes.size(), off);
      } else {
        std::string& b = c.small_[s.name];
        error = read_at(fh, s.offset, s.bytes, b);
        if (rank == 0) part += checksum(b.data(), b.size(), s.offset);
      }
    }
    std::string trailer;
    if (error.empty()) error = read_at(fh, c.head_.file_bytes - kTrailerBytes, kTrailerBytes, trailer);
    fail(error);
    std::uint64_t sum = 0;
    MPI_Allreduce(&part, &sum, 1, MPI_UINT64_T, MPI_SUM, comm);  // unsigned: modulo 2^64
    if (std::memcmp(trailer.data(), kEndMagic, 8) != 0) error = "corrupted: no trailer at the end";
    else if (sum != get_le(trailer.data() + 8, 8)) error = "corrupted: the checksum does not match the contents";
    fail(error);
  } catch (...) {
    if (opened) MPI_File_close(&fh);
    throw;
  }
  MPI_File_close(&fh);

  const CheckpointHeader& h = c.head_;
  if (expect.scene_text && h.scene_fingerprint != scene_fingerprint(*expect.scene_text))
    throw InputError(path + ": checkpoint of another scene (scene fingerprint " + std::to_string(h.scene_fingerprint) +
                     " in the checkpoint, " + std::to_string(scene_fingerprint(*expect.scene_text)) +
                     " for this scene file): restart with the scene it was written for");
  if (!expect.app.empty() && h.app != expect.app)
    throw InputError(path + ": checkpoint of a \"" + h.app + "\" run, this scene runs \"" + expect.app + "\"");
  if (h.blowup && !expect.allow_blowup)
    throw InputError(path +
                     ": blow-up checkpoint (the state when a numerical blow-up was detected "
                     "at step " +
                     std::to_string(h.step) +
                     ", kept for post-mortem): a run cannot "
                     "restart from it; restart from an earlier checkpoint");
  return c;
}

const CheckpointSection& Checkpoint::find(const std::string& name) const {
  for (const CheckpointSection& s : head_.sections)
    if (s.name == name) return s;
  throw InputError(path_ + ": no section " + name + " in the checkpoint");
}

bool Checkpoint::has(const std::string& name) const {
  for (const CheckpointSection& s : head_.sections)
    if (s.name == name) return true;
  return false;
}

std::string Checkpoint::section(const std::string& name) const {
  const CheckpointSection& s = find(name);
  if (s.kind == SectionKind::Distributed)
    throw std::logic_error("checkpoint section " + name + " is distributed: read with simulation()");
  return small_.at(name);
}

FieldReader Checkpoint::fields(const std::string& name) const {
  const std::string& b = small_.at(find(name).name);
  const std::string where = path_ + ": section " + name;
  if (b.size() < 8 || get_le(b.data(), 8) > b.size() - 8)
    throw InputError(where + ": no field layout at its start (corrupted)");
  const std::size_t n = std::size_t(get_le(b.data(), 8));
  return FieldReader(b.substr(8, n), b.data() + 8 + n, b.size() - 8 - n, where);
}

SimulationSnapshot Checkpoint::simulation(const std::string& prefix, MPI_Comm comm) const {
  SimulationSnapshot snap;
  snap.holding = Holding::Share;
  const std::string where = path_ + ": section " + prefix;
  FieldReader g = fields(prefix + ".global");
  const std::string prec = g.text("particle_record"), crec = g.text("contact_record");
  const ParticleRecordReader particle_records(prec, where + ".global");
  // The twisting spring is in the records of a scene with twisting resistance only.
  const bool twisting = crec == contact_record_schema(true);
  if (!twisting && crec != contact_record_schema(false))
    throw InputError(where + ".global: written by a build with other contact records ('" + crec + "'; this build: '" +
                     contact_record_schema(false) + "' or '" + contact_record_schema(true) + "')");
  snap.cell = PeriodicCell(g.vec3("cell.lengths"));
  snap.cell.set_strain_rate(g.vec3("cell.strain_rate"));
  SimulationParams& par = snap.params;
  par.law = read_law(g);
  par.dt = g.f64("dt");
  par.skin = g.f64("skin");
  par.gravity = g.vec3("gravity");
  par.local_damping = g.f64("local_damping");
  const auto nw = g.u64("walls");
  if (nw > 1000000) throw InputError(where + ".global: corrupted (wall count)");
  for (std::uint64_t k = 0; k < nw; ++k) {
    Wall w;
    w.point = g.vec3("wall.point");
    w.normal = g.vec3("wall.normal");
    w.velocity = g.vec3("wall.velocity");
    w.own_law = g.u8("wall.own_law") != 0;
    if (w.own_law) w.law = read_law(g);
    w.servo_pressure = g.f64("wall.servo_pressure");
    w.servo_relaxation = g.f64("wall.servo_relaxation");
    w.servo_max_speed = g.f64("wall.servo_max_speed");
    if (g.next_is("wall.material")) w.material = g.i32("wall.material");
    par.walls.push_back(w);
  }
  const auto nd = g.u64("driven");
  if (nd > 1000000) throw InputError(where + ".global: corrupted (driven set count)");
  for (std::uint64_t k = 0; k < nd; ++k) {
    DrivenSet d;
    d.first = g.i64("driven.first");
    d.last = g.i64("driven.last");
    const auto ni = g.u64("driven.ids");
    if (ni > (std::uint64_t(1) << 40)) throw InputError(where + ".global: corrupted (driven id count)");
    for (std::uint64_t i = 0; i < ni; ++i) d.ids.push_back(g.i64("driven.id"));
    d.velocity = g.vec3("driven.velocity");
    d.spin = g.vec3("driven.spin");
    par.driven.push_back(d);
  }
  par.spatial_sort = g.u8("spatial_sort") != 0;
  if (g.next_is("materials")) par.materials = read_materials(g);
  for (const Wall& w : par.walls)
    if (w.material >= std::int32_t(par.materials.size()))
      throw InputError(where + ".global: wall.material = " + std::to_string(w.material) + " of " +
                       std::to_string(par.materials.size()) + " materials (corrupted)");
  snap.step = g.i64("step");
  snap.rebuilds = g.i64("rebuilds");
  snap.time = g.f64("time");
  snap.macro = read_macro(g);
  snap.decomposition.lengths = g.vec3("decomposition_lengths");
  const std::int64_t cuts = g.i64("decomposition_cuts");
  if (cuts < 0 || cuts > 3 * std::int64_t(head_.ranks))
    throw InputError(where + ": decomposition_cuts = " + std::to_string(cuts) + ", expected 0 to " +
                     std::to_string(3 * head_.ranks) + " (three axes of at most " + std::to_string(head_.ranks) +
                     " runs)");
  for (std::int64_t c = 0; c < cuts; ++c) snap.decomposition.cuts.push_back(g.i32("decomposition_cut"));
  snap.decomposition.since_check = g.i64("decomposition_since_check");
  snap.energy.e0 = g.f64("energy.e0");
  snap.energy.work = g.f64("energy.work");
  snap.energy.vol_strain = g.vec3("energy.vol_strain");
  snap.energy.stress_prev = g.mat3("energy.stress_prev");
  snap.energy.wall_work = g.f64("energy.wall_work");
  snap.energy.drive_work = g.f64("energy.drive_work");
  g.done();

  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (size != head_.ranks) snap.decomposition = {};  // a new decomposition

  auto records = [&](const std::string& name, std::size_t bytes) -> const std::string& {
    const CheckpointSection& s = find(name);
    if (s.kind != SectionKind::Distributed || s.record_bytes != bytes)
      throw InputError(where + ": section " + name + " has records of " + std::to_string(s.record_bytes) +
                       " bytes, this build reads " + std::to_string(bytes));
    return chunks_.at(name).bytes;
  };
  const std::string& parts = records(prefix + ".particles", particle_records.bytes());
  particle_records.read(parts.data(), parts.size() / particle_records.bytes(), snap.particles);
  const std::string& contacts = records(prefix + ".contacts", contact_record_bytes(twisting));
  const std::size_t nc = contacts.size() / contact_record_bytes(twisting);
  snap.history.reset(nc, twisting);
  read_contacts(contacts.data(), nc, twisting, snap.history);

  // Per-rank records: the same ranks' when the rank count is unchanged, else the totals to rank 0.
  auto per_rank = [&](const std::string& name, std::uint32_t bytes) -> const std::string& {
    const CheckpointSection& s = find(name);
    if (s.kind != SectionKind::PerRank || s.record_bytes != bytes || s.records != std::uint64_t(head_.ranks))
      throw InputError(where + ": section " + name + ": " + std::to_string(s.records) + " records of " +
                       std::to_string(s.record_bytes) + " bytes for " + std::to_string(head_.ranks) +
                       " ranks (corrupted)");
    return small_.at(name);
  };
  const std::string& diss = per_rank(prefix + ".dissipation", 32);
  const std::string& gw = per_rank(prefix + ".gravity_work", 8);
  const std::string dschema = [] {
    FieldWriter w;
    write_dissipation(w, Dissipation{});
    return w.schema();
  }();
  for (int r = 0; r < head_.ranks; ++r) {
    if (size == head_.ranks ? r != rank : rank != 0) continue;
    FieldReader dr(dschema, diss.data() + std::size_t(r) * 32, 32, where + ".dissipation");
    const Dissipation d = read_dissipation(dr);
    snap.dissipation.friction += d.friction;
    snap.dissipation.rolling += d.rolling;
    snap.dissipation.viscous += d.viscous;
    snap.dissipation.local += d.local;
    snap.energy.gravity_work_local += from_bits(get_le(gw.data() + std::size_t(r) * 8, 8));
  }
  return snap;
}

std::string describe(const CheckpointHeader& h, const std::string& path) {
  std::ostringstream s;
  s << "checkpoint " << path << "\n"
    << "  format version    " << h.format << "\n"
    << "  written by        Fabrica " << h.software << " on " << h.ranks << " rank(s)\n"
    << "  application       " << h.app << (h.blowup ? " (blow-up state, not restartable)" : "") << "\n"
    << "  step              " << h.step << "\n";
  s.precision(17);
  s << "  time              " << h.time << " s\n"
    << "  scene fingerprint " << h.scene_fingerprint << "\n"
    << "  size              " << h.file_bytes << " bytes\n"
    << "  sections (name, offset, bytes, records, bytes per record, kind):\n";
  static const char* kinds[3] = {"global", "per-rank", "distributed"};
  for (const CheckpointSection& c : h.sections)
    s << "    " << c.name << " " << c.offset << " " << c.bytes << " " << c.records << " " << c.record_bytes << " "
      << kinds[int(c.kind)] << "\n";
  return s.str();
}

bool keep_series_through(const std::string& path, int step_column, std::int64_t step) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream all;
  all << in.rdbuf();
  const std::string text = all.str();
  std::string kept;
  std::size_t pos = 0;
  for (bool header = true; pos < text.size(); header = false) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) break;  // cut short: dropped
    const std::string line = text.substr(pos, end + 1 - pos);
    pos = end + 1;
    if (!header) {
      std::size_t at = 0;
      for (int c = 0; c < step_column && at != std::string::npos; ++c) {
        at = line.find(',', at);
        if (at != std::string::npos) ++at;
      }
      if (at == std::string::npos) continue;
      char* stop = nullptr;
      const long long s = std::strtoll(line.c_str() + at, &stop, 10);
      if (stop == line.c_str() + at || s > step) continue;
    }
    kept += line;
  }
  write_file_atomic(path, kept);  // path.tmp, checked, synced, renamed (io/serial/write_check.hpp)
  return true;
}

// ------------------------------------------------------------------------------- scheduling

namespace {
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

CheckpointSchedule::CheckpointSchedule(MPI_Comm comm, std::int64_t every, double seconds, std::int64_t step)
    : comm_(comm), every_(every), seconds_(seconds), last_step_(step), last_time_(wall_seconds()) {}

bool CheckpointSchedule::due(const Simulation& sim) {
  if (!sim.rebuilt_last_step()) return false;  // identical on every rank
  if (every_ > 0 && sim.step_count() - last_step_ >= every_) return true;
  if (seconds_ <= 0) return false;
  int now = wall_seconds() - last_time_ >= seconds_;  // rank 0 decides for all
  MPI_Bcast(&now, 1, MPI_INT, 0, comm_);
  return now != 0;
}

void CheckpointSchedule::taken(std::int64_t step) {
  last_step_ = step;
  last_time_ = wall_seconds();
}

}  // namespace fabrica
