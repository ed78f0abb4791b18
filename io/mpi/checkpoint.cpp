#include "io/mpi/checkpoint.hpp"

#include "core/errors.hpp"
#include "io/mpi/checkpoint_older.hpp"
#include "io/mpi/fields.hpp"
#include "io/mpi/simulation_fields.hpp"
#include "io/mpi/state_fields.hpp"
#include "parallel/mpi_context.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#ifndef FABRICA_VERSION
#define FABRICA_VERSION "unknown"
#endif

namespace fabrica {
namespace {
double from_bits(std::uint64_t b) {
  double v;
  std::memcpy(&v, &b, 8);
  return v;
}
}  // namespace

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

void CheckpointWriter::add_records(const std::string& name, std::uint32_t record_bytes, std::string records) {
  if (record_bytes == 0 || records.size() % record_bytes != 0)
    throw std::logic_error("checkpoint: section " + name + " is not a whole number of records");
  staged_.push_back({name, SectionKind::Distributed, record_bytes, std::move(records)});
}

void CheckpointWriter::add_simulation(const std::string& prefix, const Simulation& sim) {
  if (!have_step_) {
    head_.step = sim.step_count();
    head_.time = sim.time();
    have_step_ = true;
  }
  const SimulationGlobal global = simulation_global(sim);
  FieldWriter g;
  write_simulation_global(g, global);
  add_fields(prefix + ".global", g);

  const bool twisting = global.params.twisting();
  const bool materials = !global.params.materials.empty();
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
  std::uint64_t bits;
  std::memcpy(&bits, &global.energy.gravity_work_local, 8);
  put_le(gw, bits, 8);
  staged_.push_back({prefix + ".gravity_work", SectionKind::PerRank, 8, std::move(gw)});
}

std::vector<std::uint64_t> CheckpointWriter::lay_out() {
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
  return my_offset;
}

void CheckpointWriter::write_section(CheckpointOutFile& file, const Staged& st, std::uint64_t offset,
                                     std::uint64_t& part) {
  const bool mine_to_write = st.kind != SectionKind::Global || rank_ == 0;
  if (!st.produce) {
    file.write_at(offset, st.local, mine_to_write, st.name);
    if (mine_to_write) part += checksum(st.local.data(), st.local.size(), offset);
    return;
  }
  // Block by block; every rank takes part in as many collective writes as the rank with the
  // most blocks (the others with none left write nothing).
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
    const std::uint64_t at = offset + first * st.record_bytes;
    file.write_at(at, block, true, st.name);
    part += checksum(block.data(), block.size(), at);
  }
}

std::uint64_t CheckpointWriter::write(const std::string& path) {
  const std::vector<std::uint64_t> my_offset = lay_out();
  const std::string header = encode_header(head_);
  // Checksum: each rank its blocks (rank 0 the header and global sections), summed over the
  // ranks once every block is written.
  std::uint64_t part = rank_ == 0 ? checksum(header.data(), header.size(), 0) : 0;
  CheckpointOutFile file(comm_, path);
  try {
    file.truncate();
    file.write_at(0, header, rank_ == 0, "header");
    for (std::size_t s = 0; s < staged_.size(); ++s) write_section(file, staged_[s], my_offset[s], part);
    std::uint64_t sum = 0;
    MPI_Reduce(&part, &sum, 1, MPI_UINT64_T, MPI_SUM, 0, comm_);  // unsigned: modulo 2^64
    std::string trailer(kEndMagic, 8);
    put_le(trailer, sum, 8);
    file.write_at(head_.file_bytes - kTrailerBytes, trailer, rank_ == 0, "trailer");
  } catch (const CollectiveError&) {  // every rank is here: keep the last checkpoint
    file.abandon();
    throw;
  }
  file.replace(head_.file_bytes);
  return head_.file_bytes;
}

// ---------------------------------------------------------------------------------- reading

Checkpoint Checkpoint::read(MPI_Comm comm, const std::string& path, const Expect& expect) {
  Checkpoint c;
  c.path_ = path;
  {
    // Every rank reads for itself: the header, the small sections, and its share of the
    // records of the distributed ones (particles, contacts); no rank reads or holds the whole
    // file.
    const CheckpointInFile file(comm, path);
    if (const std::string e = agreed(comm, c.load(file, comm)); !e.empty()) throw InputError(path + ": " + e);
  }
  c.check(expect);
  return c;
}

std::string Checkpoint::load(const CheckpointInFile& file, MPI_Comm comm) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  auto failed = [&](const std::string& error) { return !agreed(comm, error).empty(); };
  const std::uint64_t on_disk = file.size();
  std::string head;
  std::string error = file.read_at(0, std::min<std::uint64_t>(on_disk, kHeaderBytes), head);
  if (error.empty()) error = decode_header(head, head_);
  if (error.empty() && on_disk != head_.file_bytes)
    error = "truncated or extended: " + std::to_string(on_disk) + " bytes, the header says " +
        std::to_string(head_.file_bytes) + " (an interrupted copy?)";
  // The sections follow one another from the header to the trailer, with no gap.
  std::uint64_t at = kHeaderBytes;
  for (const CheckpointSection& s : head_.sections) {
    if (!error.empty()) break;
    if (s.offset != at || s.offset + s.bytes > head_.file_bytes - kTrailerBytes)
      error = "corrupted: section " + s.name + " lies outside its place in the file";
    at = s.offset + s.bytes;
  }
  if (error.empty() && at != head_.file_bytes - kTrailerBytes) error = "corrupted: the sections do not fill the file";
  if (failed(error)) return error;
  // Small sections whole; distributed ones, this rank's range of records.
  std::uint64_t part = rank == 0 ? checksum(head.data(), head.size(), 0) : 0;
  for (const CheckpointSection& s : head_.sections) {
    if (!error.empty()) break;
    if (s.kind == SectionKind::Distributed) {
      Chunk& ch = chunks_[s.name];
      ch.first = s.records * std::uint64_t(rank) / std::uint64_t(size);
      const std::uint64_t last = s.records * std::uint64_t(rank + 1) / std::uint64_t(size);
      const std::uint64_t off = s.offset + ch.first * s.record_bytes;
      error = file.read_at(off, (last - ch.first) * s.record_bytes, ch.bytes);
      part += checksum(ch.bytes.data(), ch.bytes.size(), off);
    } else {
      std::string& b = small_[s.name];
      error = file.read_at(s.offset, s.bytes, b);
      if (rank == 0) part += checksum(b.data(), b.size(), s.offset);
    }
  }
  std::string trailer;
  if (error.empty()) error = file.read_at(head_.file_bytes - kTrailerBytes, kTrailerBytes, trailer);
  if (failed(error)) return error;
  std::uint64_t sum = 0;
  MPI_Allreduce(&part, &sum, 1, MPI_UINT64_T, MPI_SUM, comm);  // unsigned: modulo 2^64
  if (std::memcmp(trailer.data(), kEndMagic, 8) != 0) return "corrupted: no trailer at the end";
  if (sum != get_le(trailer.data() + 8, 8)) return "corrupted: the checksum does not match the contents";
  return "";
}

void Checkpoint::check(const Expect& expect) const {
  const CheckpointHeader& h = head_;
  const std::string& path = path_;
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

const std::string& Checkpoint::records(const std::string& name, std::uint32_t record_bytes) const {
  const CheckpointSection& s = find(name);
  if (s.kind != SectionKind::Distributed || s.record_bytes != record_bytes)
    throw InputError(path_ + ": section " + name + " has records of " + std::to_string(s.record_bytes) +
                     " bytes, this build reads " + std::to_string(record_bytes));
  return chunks_.at(name).bytes;
}

SimulationSnapshot Checkpoint::simulation(const std::string& prefix, MPI_Comm comm) const {
  SimulationSnapshot snap;
  snap.holding = Holding::Share;
  const std::string where = path_ + ": section " + prefix;
  FieldReader g = fields(prefix + ".global");
  SimulationGlobal global = read_simulation_global(g, where, head_.ranks);
  const ParticleRecordReader particle_records(global.particle_record, where + ".global");
  const bool twisting = contact_records_twisting(global.contact_record, where + ".global");
  snap.cell = cell_of(global);
  snap.params = std::move(global.params);
  snap.step = global.step;
  snap.rebuilds = global.rebuilds;
  snap.time = global.time;
  snap.macro = std::move(global.macro);
  snap.decomposition = std::move(global.decomposition);
  snap.energy = global.energy;

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
  read_per_rank(prefix, where, rank, size, snap);
  return snap;
}

PeriodicCell Checkpoint::cell(const std::string& prefix) const {
  FieldReader g = fields(prefix + ".global");
  return cell_of(read_simulation_global(g, path_ + ": section " + prefix, head_.ranks));
}

void Checkpoint::read_per_rank(const std::string& prefix, const std::string& where, int rank, int size,
                               SimulationSnapshot& snap) const {
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
}

}  // namespace fabrica
