#include "io/checkpoint.hpp"

#include "io/fault.hpp"
#include "io/write_check.hpp"

#include "io/errors.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/properties.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
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
constexpr std::size_t kTableFirst = 128;  // the section table starts here in the header
constexpr std::size_t kMaxSections = (kHeaderBytes - kTableFirst) / (kNameBytes + 24);
constexpr std::uint32_t kFlagBlowup = 1;

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

std::size_t particle_record_bytes() {
  std::size_t b = 0;
  Particles probe;
  for_each_property(probe, [&](const char*, auto& vec, Travel) {
    b += sizeof(typename std::decay_t<decltype(vec)>::value_type);
  });
  return b;
}

struct ContactRecord {
  GlobalId a, b;
  ContactHistory h;
};

void fixed_string(std::string& out, std::size_t at, const std::string& s, std::size_t width) {
  for (std::size_t k = 0; k < width; ++k) out[at + k] = k < s.size() && k + 1 < width ? s[k] : '\0';
}
std::string read_fixed(const char* at, std::size_t width) {
  std::size_t n = 0;
  while (n < width && at[n]) ++n;
  return std::string(at, n);
}
template <class T>
void poke(std::string& out, std::size_t at, const T& v) {
  std::memcpy(out.data() + at, &v, sizeof(T));
}
template <class T>
T peek(const std::string& in, std::size_t at) {
  T v;
  std::memcpy(static_cast<void*>(&v), in.data() + at, sizeof(T));
  return v;
}

std::string encode_header(const CheckpointHeader& h) {
  std::string out(kHeaderBytes, '\0');
  std::memcpy(out.data(), kMagic, 8);
  poke(out, 8, h.format);
  poke(out, 12, std::uint32_t(kHeaderBytes));
  fixed_string(out, 16, h.software, 16);
  poke(out, 32, h.scene_fingerprint);
  poke(out, 40, h.ranks);
  poke(out, 44, std::uint32_t(h.blowup ? kFlagBlowup : 0));
  poke(out, 48, h.step);
  poke(out, 56, h.time);
  fixed_string(out, 64, h.app, 16);
  poke(out, 80, h.file_bytes);
  poke(out, 88, std::uint32_t(h.sections.size()));
  std::size_t at = kTableFirst;
  for (const CheckpointSection& s : h.sections) {
    fixed_string(out, at, s.name, kNameBytes);
    poke(out, at + kNameBytes, s.offset);
    poke(out, at + kNameBytes + 8, s.bytes);
    poke(out, at + kNameBytes + 16, s.records);
    at += kNameBytes + 24;
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
  h.format = peek<std::uint32_t>(in, 8);
  if (h.format != kCheckpointFormat)
    return "checkpoint format version " + std::to_string(h.format) + ", this build of Fabrica (" +
           FABRICA_VERSION + ") reads version " + std::to_string(kCheckpointFormat) + " only";
  if (peek<std::uint32_t>(in, 12) != kHeaderBytes) return "corrupted header (header size)";
  h.software = read_fixed(in.data() + 16, 16);
  h.scene_fingerprint = peek<std::uint64_t>(in, 32);
  h.ranks = peek<std::int32_t>(in, 40);
  h.blowup = peek<std::uint32_t>(in, 44) & kFlagBlowup;
  h.step = peek<std::int64_t>(in, 48);
  h.time = peek<double>(in, 56);
  h.app = read_fixed(in.data() + 64, 16);
  h.file_bytes = peek<std::uint64_t>(in, 80);
  const auto ns = peek<std::uint32_t>(in, 88);
  if (ns > kMaxSections) return "corrupted header (section count " + std::to_string(ns) + ")";
  h.sections.clear();
  std::size_t at = kTableFirst;
  for (std::uint32_t k = 0; k < ns; ++k, at += kNameBytes + 24)
    h.sections.push_back({read_fixed(in.data() + at, kNameBytes),
                          peek<std::uint64_t>(in, at + kNameBytes),
                          peek<std::uint64_t>(in, at + kNameBytes + 8),
                          peek<std::uint64_t>(in, at + kNameBytes + 16)});
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
  throw CollectiveError(path + ": cannot write the checkpoint (" + msg +
                        "); the previous checkpoint, if any, is kept");
}

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

CheckpointWriter::CheckpointWriter(MPI_Comm comm, std::uint64_t fingerprint, std::string app,
                                   bool blowup)
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
  staged_.push_back({name, false, 0, std::move(bytes)});
}

void CheckpointWriter::add_simulation(const std::string& prefix, const Simulation& sim) {
  if (!have_step_) {
    head_.step = sim.step_count();
    head_.time = sim.time();
    have_step_ = true;
  }
  const Particles& p = sim.particles();
  const SimulationParams& par = sim.params();
  Bytes g;
  g.put(std::uint64_t(particle_record_bytes())).put(std::uint64_t(sizeof(ContactRecord)));
  g.put(std::uint64_t(sizeof(ContactLawParams))).put(std::uint64_t(sizeof(MacroState)));
  g.put(sim.cell().lengths()).put(sim.cell().strain_rate());
  g.put(par.law).put(par.dt).put(par.skin).put(par.gravity).put(par.local_damping);
  g.put(std::uint64_t(par.walls.size()));
  for (const Wall& w : par.walls) g.put(w.point).put(w.normal);
  g.put(std::uint8_t(par.spatial_sort));
  g.put(sim.step_count()).put(sim.rebuild_count()).put(sim.time());
  g.put(sim.macro());
  Simulation& mut = const_cast<Simulation&>(sim);  // Domain accessors are not const
  g.put(mut.domain().decomposition_lengths());
  const EnergyAccount ea = sim.energy_account();
  g.put(ea.e0).put(ea.work).put(ea.vol_strain).put(ea.stress_prev);
  add_global(prefix + ".global", g.str());

  std::string parts;
  parts.reserve(p.n_owned() * particle_record_bytes());
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    for_each_property(p, [&](const char*, const auto& vec, Travel) {
      parts.append(reinterpret_cast<const char*>(&vec[a]), sizeof(vec[a]));
    });
  staged_.push_back({prefix + ".particles", true, particle_record_bytes(), std::move(parts)});

  std::string contacts;
  sim.for_each_contact([&](GlobalId a, GlobalId b, const ContactHistory& h) {
    const ContactRecord r{a, b, h};
    contacts.append(reinterpret_cast<const char*>(&r), sizeof r);
  });
  staged_.push_back({prefix + ".contacts", true, sizeof(ContactRecord), std::move(contacts)});

  const Dissipation& d = sim.dissipation();
  staged_.push_back({prefix + ".dissipation", true, sizeof(Dissipation),
                     std::string(reinterpret_cast<const char*>(&d), sizeof d)});
  staged_.push_back({prefix + ".gravity_work", true, sizeof(real_t),
                     Bytes().put(ea.gravity_work_local).str()});
}

std::uint64_t CheckpointWriter::write(const std::string& path) {
  const std::size_t ns = staged_.size();
  if (ns > kMaxSections) throw std::logic_error("checkpoint: too many sections");
  // Sizes of every rank's blocks, and the offsets that follow.
  std::vector<std::uint64_t> mine(ns), all(ns * std::size_t(size_));
  for (std::size_t s = 0; s < ns; ++s) mine[s] = staged_[s].local.size();
  MPI_Allgather(mine.data(), int(ns), MPI_UINT64_T, all.data(), int(ns), MPI_UINT64_T, comm_);
  std::vector<std::uint64_t> my_offset(ns);
  head_.sections.clear();
  std::uint64_t at = kHeaderBytes;
  for (std::size_t s = 0; s < ns; ++s) {
    CheckpointSection sec{staged_[s].name, at, 0, 0};
    if (staged_[s].collective) {
      for (int r = 0; r < size_; ++r) {
        if (r == rank_) my_offset[s] = at + sec.bytes;
        sec.bytes += all[std::size_t(r) * ns + s];
      }
      sec.records = staged_[s].record_bytes ? sec.bytes / staged_[s].record_bytes : 0;
    } else {
      sec.bytes = mine[s];  // identical on every rank
      my_offset[s] = at;
    }
    at += sec.bytes;
    head_.sections.push_back(sec);
  }
  head_.file_bytes = at + kTrailerBytes;
  const std::string header = encode_header(head_);

  // Checksum: each rank its blocks (rank 0 the header and global sections).
  std::uint64_t part = 0;
  if (rank_ == 0) part += checksum(header.data(), header.size(), 0);
  for (std::size_t s = 0; s < ns; ++s)
    if (staged_[s].collective || rank_ == 0)
      part += checksum(staged_[s].local.data(), staged_[s].local.size(), my_offset[s]);
  std::vector<std::uint64_t> parts(static_cast<std::size_t>(size_), 0);
  MPI_Gather(&part, 1, MPI_UINT64_T, parts.data(), 1, MPI_UINT64_T, 0, comm_);
  std::uint64_t sum = 0;
  for (std::uint64_t v : parts) sum += v;
  std::string trailer(kTrailerBytes, '\0');
  std::memcpy(trailer.data(), kEndMagic, 8);
  poke(trailer, 8, sum);

  const std::string tmp = path + ".tmp";
  MPI_File fh;
  check_mpi(MPI_File_open(comm_, tmp.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &fh),
            comm_, "open " + tmp, path);
  MPI_File_set_errhandler(fh, MPI_ERRORS_RETURN);
  auto write_at = [&](std::uint64_t offset, const std::string& bytes, bool mine_to_write,
                      const std::string& what) {
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
                   : " (" + std::to_string(count) + " of " + std::to_string(b.size()) +
                         " bytes written: is the disk full?)";
    }
    check_mpi(err, comm_, "write " + what + " to " + tmp, path, detail);
  };
  try {
    check_mpi(MPI_File_set_size(fh, 0), comm_, "truncate " + tmp, path);
    write_at(0, header, rank_ == 0, "header");
    for (std::size_t s = 0; s < ns; ++s)
      write_at(my_offset[s], staged_[s].local, staged_[s].collective || rank_ == 0, staged_[s].name);
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
              " (" + std::to_string(on_disk) + " bytes on disk, " +
                  std::to_string(head_.file_bytes) + " written)");
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
  if (err)
    throw CollectiveError(path + ": cannot rename " + tmp + " to it (" + std::strerror(err) + ")");
  return head_.file_bytes;
}

// ---------------------------------------------------------------------------------- reading

Checkpoint Checkpoint::read(MPI_Comm comm, const std::string& path, const Expect& expect) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  Checkpoint c;
  c.path_ = path;
  std::string error;
  if (rank == 0) {
    std::ifstream in(path, std::ios::binary);
    if (fault_injected("checkpoint")) {
      error = "cannot read the checkpoint (" + fault_text("checkpoint") + ")";
    } else if (!in) {
      error = "cannot open the checkpoint (" + std::string(std::strerror(errno)) + ")";
    } else {
      std::ostringstream s;
      s << in.rdbuf();
      c.data_ = s.str();
      error = decode_header(c.data_, c.head_);
      if (error.empty() && c.data_.size() != c.head_.file_bytes)
        error = "truncated or extended: " + std::to_string(c.data_.size()) +
                " bytes, the header says " + std::to_string(c.head_.file_bytes) +
                " (an interrupted copy?)";
      if (error.empty()) {
        const std::size_t body = c.data_.size() - kTrailerBytes;
        if (std::memcmp(c.data_.data() + body, kEndMagic, 8) != 0)
          error = "corrupted: no trailer at the end";
        else if (checksum(c.data_.data(), body, 0) != peek<std::uint64_t>(c.data_, body + 8))
          error = "corrupted: the checksum does not match the contents";
      }
      if (error.empty())
        for (const CheckpointSection& s : c.head_.sections)
          if (s.offset < kHeaderBytes || s.offset + s.bytes > c.head_.file_bytes - kTrailerBytes)
            error = "corrupted: section " + s.name + " lies outside the file";
    }
  }
  // Every rank meets the same outcome.
  std::uint64_t n = error.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
  error.resize(n);
  MPI_Bcast(error.data(), int(n), MPI_CHAR, 0, comm);
  if (!error.empty()) throw InputError(path + ": " + error);
  n = c.data_.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
  c.data_.resize(n);
  for (std::uint64_t k = 0; k < n; k += std::uint64_t(1) << 30) {
    const std::uint64_t len = std::min<std::uint64_t>(n - k, std::uint64_t(1) << 30);
    MPI_Bcast(c.data_.data() + k, int(len), MPI_CHAR, 0, comm);
  }
  if (rank != 0) decode_header(c.data_, c.head_);

  const CheckpointHeader& h = c.head_;
  if (expect.scene_text && h.scene_fingerprint != scene_fingerprint(*expect.scene_text))
    throw InputError(path + ": checkpoint of another scene (scene fingerprint " +
                     std::to_string(h.scene_fingerprint) + " in the checkpoint, " +
                     std::to_string(scene_fingerprint(*expect.scene_text)) +
                     " for this scene file): restart with the scene it was written for");
  if (!expect.app.empty() && h.app != expect.app)
    throw InputError(path + ": checkpoint of a \"" + h.app + "\" run, this scene runs \"" +
                     expect.app + "\"");
  if (h.blowup && !expect.allow_blowup)
    throw InputError(path + ": blow-up checkpoint (the state when a numerical blow-up was detected "
                     "at step " + std::to_string(h.step) + ", kept for post-mortem): a run cannot "
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
  return data_.substr(s.offset, s.bytes);
}

SimulationSnapshot Checkpoint::simulation(const std::string& prefix, MPI_Comm comm) const {
  SimulationSnapshot snap;
  const std::string where = path_ + ": section " + prefix;
  BytesIn g(section(prefix + ".global"), where + ".global");
  const auto prec = g.get<std::uint64_t>(), crec = g.get<std::uint64_t>();
  const auto lrec = g.get<std::uint64_t>(), mrec = g.get<std::uint64_t>();
  if (prec != particle_record_bytes() || crec != sizeof(ContactRecord) ||
      lrec != sizeof(ContactLawParams) || mrec != sizeof(MacroState))
    throw InputError(where + ".global: written by a build with other record sizes (particle, "
                     "contact, contact law, measures: " + std::to_string(prec) + ", " +
                     std::to_string(crec) + ", " + std::to_string(lrec) + ", " +
                     std::to_string(mrec) + " bytes; this build: " +
                     std::to_string(particle_record_bytes()) + ", " +
                     std::to_string(sizeof(ContactRecord)) + ", " +
                     std::to_string(sizeof(ContactLawParams)) + ", " +
                     std::to_string(sizeof(MacroState)) + ")");
  snap.cell = PeriodicCell(g.get<Vec3>());
  snap.cell.set_strain_rate(g.get<Vec3>());
  SimulationParams& par = snap.params;
  par.law = g.get<ContactLawParams>();
  par.dt = g.get<real_t>();
  par.skin = g.get<real_t>();
  par.gravity = g.get<Vec3>();
  par.local_damping = g.get<real_t>();
  const auto nw = g.get<std::uint64_t>();
  if (nw > 1000000) throw InputError(where + ".global: corrupted (wall count)");
  for (std::uint64_t k = 0; k < nw; ++k) {
    Wall w;
    w.point = g.get<Vec3>();
    w.normal = g.get<Vec3>();
    par.walls.push_back(w);
  }
  par.spatial_sort = g.get<std::uint8_t>() != 0;
  snap.step = g.get<std::int64_t>();
  snap.rebuilds = g.get<std::int64_t>();
  snap.time = g.get<real_t>();
  snap.macro = g.get<MacroState>();
  snap.decomposition_lengths = g.get<Vec3>();
  snap.energy.e0 = g.get<real_t>();
  snap.energy.work = g.get<real_t>();
  snap.energy.vol_strain = g.get<Vec3>();
  snap.energy.stress_prev = g.get<Mat3>();
  if (!g.done()) throw InputError(where + ".global: unexpected extra bytes");

  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (size != head_.ranks) snap.decomposition_lengths = Vec3::Zero();  // a new decomposition

  const std::string parts = section(prefix + ".particles");
  if (parts.size() % prec) throw InputError(where + ".particles: size is not a whole number of records");
  const std::size_t n = parts.size() / prec;
  Particles& p = snap.particles;
  p.append_owned(n);
  const char* in = parts.data();
  for (std::size_t a = 0; a < n; ++a)
    for_each_property(p, [&](const char*, auto& vec, Travel) {
      std::memcpy(static_cast<void*>(&vec[a]), in, sizeof(vec[a]));
      in += sizeof(vec[a]);
    });

  const std::string contacts = section(prefix + ".contacts");
  if (contacts.size() % crec) throw InputError(where + ".contacts: size is not a whole number of records");
  const std::size_t nc = contacts.size() / crec;
  snap.history.reset(nc);
  for (std::size_t k = 0; k < nc; ++k) {
    ContactRecord r;
    std::memcpy(static_cast<void*>(&r), contacts.data() + k * crec, crec);
    snap.history.insert(r.a, r.b, r.h);
  }

  const std::string diss = section(prefix + ".dissipation");
  if (diss.size() != std::size_t(head_.ranks) * sizeof(Dissipation))
    throw InputError(where + ".dissipation: " + std::to_string(diss.size()) + " bytes for " +
                     std::to_string(head_.ranks) + " ranks");
  if (size == head_.ranks) {
    std::memcpy(static_cast<void*>(&snap.dissipation), diss.data() + std::size_t(rank) * sizeof(Dissipation),
                sizeof(Dissipation));
  } else if (rank == 0) {  // another rank count: the totals go to rank 0
    for (int r = 0; r < head_.ranks; ++r) {
      Dissipation d;
      std::memcpy(static_cast<void*>(&d), diss.data() + std::size_t(r) * sizeof(Dissipation), sizeof d);
      snap.dissipation.friction += d.friction;
      snap.dissipation.rolling += d.rolling;
      snap.dissipation.viscous += d.viscous;
      snap.dissipation.local += d.local;
    }
  }

  // This rank's work of gravity, like the dissipation (totals to rank 0 on another rank count).
  const std::string gw = section(prefix + ".gravity_work");
  if (gw.size() != std::size_t(head_.ranks) * sizeof(real_t))
    throw InputError(where + ".gravity_work: " + std::to_string(gw.size()) + " bytes for " +
                     std::to_string(head_.ranks) + " ranks");
  for (int r = 0; r < head_.ranks; ++r) {
    if (size == head_.ranks ? r != rank : rank != 0) continue;
    real_t w;
    std::memcpy(&w, gw.data() + std::size_t(r) * sizeof(real_t), sizeof w);
    snap.energy.gravity_work_local += w;
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
    << "  sections (name, offset, bytes, records):\n";
  for (const CheckpointSection& c : h.sections)
    s << "    " << c.name << " " << c.offset << " " << c.bytes << " " << c.records << "\n";
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
  write_file_atomic(path, kept);  // path.tmp, checked, synced, renamed (io/write_check.hpp)
  return true;
}

// ------------------------------------------------------------------------------- scheduling

namespace {
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

CheckpointSchedule::CheckpointSchedule(MPI_Comm comm, std::int64_t every, double seconds,
                                       std::int64_t step)
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
