#include "io/mpi/snapshot_writer.hpp"

#include "core/contact_snapshot.hpp"
#include "core/exact_sum.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <vector>

namespace fabrica {
namespace {

// Plain records for the MPI exchange (Eigen vectors are not trivially copyable).
struct PartRec {
  std::int64_t id;
  double x[3], v[3], w[3], r;
  std::uint8_t material;
};
struct ContRec {
  std::int64_t id1, id2;
  double normal[3], branch[3], overlap, fn, ft[3], mr[3];
  std::uint8_t sliding, rolling;
  double x1[3];  // centre of body 1, filled after the exchange (for the XDMF line cells)
};

void put(double* d, const Vec3& v) { d[0] = v[0], d[1] = v[1], d[2] = v[2]; }

// The first id of round k of 'rounds' over [lo, hi] (round 'rounds' starts at hi + 1), in
// unsigned arithmetic that cannot overflow for fewer than 2^31 rounds.
std::int64_t round_start(std::int64_t lo, std::int64_t hi, int k, int rounds) {
  const std::uint64_t span = std::uint64_t(hi) - std::uint64_t(lo) + 1;
  const std::uint64_t K = std::uint64_t(rounds), kk = std::uint64_t(k);
  return std::int64_t(std::uint64_t(lo) + span / K * kk + span % K * kk / K);
}

// The rank whose slice of the ids [b0, b1) holds 'id' (b0 <= id < b1): slices of
// ceil((b1 - b0) / size) ids, in rank order.
int slice_rank(std::int64_t id, std::int64_t b0, std::int64_t b1, int size) {
  const std::uint64_t width = std::uint64_t(b1) - std::uint64_t(b0);
  const std::uint64_t slice = width / std::uint64_t(size) + (width % std::uint64_t(size) != 0);
  return int(std::min<std::uint64_t>(std::uint64_t(size - 1), (std::uint64_t(id) - std::uint64_t(b0)) / slice));
}

// Sends each record to the rank dest(record) (one MPI_Alltoallv of bytes) and returns what this
// rank received, in no particular order. 'recs' is released before the receive buffer is made.
template <class Rec, class Dest>
std::vector<Rec> redistribute(MPI_Comm comm, int size, std::vector<Rec> recs, Dest dest) {
  std::vector<int> scount(size, 0), rcount(size), sdisp(size, 0), rdisp(size, 0);
  for (const Rec& r : recs) scount[dest(r)] += int(sizeof(Rec));
  MPI_Alltoall(scount.data(), 1, MPI_INT, rcount.data(), 1, MPI_INT, comm);
  for (int k = 1; k < size; ++k) {
    sdisp[k] = sdisp[k - 1] + scount[k - 1];
    rdisp[k] = rdisp[k - 1] + rcount[k - 1];
  }
  std::vector<Rec> send(recs.size());
  std::vector<int> fill = sdisp;
  for (const Rec& r : recs) {
    const int d = dest(r);
    std::memcpy(reinterpret_cast<char*>(send.data()) + fill[d], &r, sizeof(Rec));
    fill[d] += int(sizeof(Rec));
  }
  std::vector<Rec>().swap(recs);
  std::vector<Rec> recv(std::size_t(rdisp[size - 1] + rcount[size - 1]) / sizeof(Rec));
  MPI_Alltoallv(send.data(), scount.data(), sdisp.data(), MPI_BYTE, recv.data(), rcount.data(), rdisp.data(), MPI_BYTE,
                comm);
  return recv;
}

// This rank's first row and the total number of rows, for 'n' rows here (ranks in order).
std::pair<hsize_t, hsize_t> rows_of(MPI_Comm comm, int rank, std::size_t n) {
  long long mine = (long long)n, before = 0, total = 0;
  MPI_Exscan(&mine, &before, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (rank == 0) before = 0;  // MPI_Exscan leaves rank 0's result undefined
  MPI_Allreduce(&mine, &total, 1, MPI_LONG_LONG, MPI_SUM, comm);
  return {hsize_t(before), hsize_t(total)};
}

// One dataset of a snapshot: its name, unit, width (0: one value per row, a 1-d dataset),
// type, and how a record gives its values (max(cols, 1) values of 'type' at the pointer).
template <class Rec>
struct Column {
  const char* name;
  const char* unit;
  hsize_t cols;
  h5::Type type;
  std::function<void(const Rec&, void*)> get;
};

std::size_t type_bytes(h5::Type t) { return t == h5::Type::U8 ? 1 : 8; }

template <class Rec, class F>
Column<Rec> f64(const char* name, const char* unit, hsize_t cols, F f) {
  return {name, unit, cols, h5::Type::F64, [f](const Rec& r, void* d) { f(r, static_cast<double*>(d)); }};
}
template <class Rec, class F>
Column<Rec> i64(const char* name, F f) {
  return {name, "1", 0, h5::Type::I64, [f](const Rec& r, void* d) { *static_cast<std::int64_t*>(d) = f(r); }};
}
template <class Rec, class F>
Column<Rec> flag(const char* name, F f) {
  return {name, "bool", 0, h5::Type::U8, [f](const Rec& r, void* d) { *static_cast<std::uint8_t*>(d) = f(r) ? 1 : 0; }};
}

std::vector<Column<PartRec>> particle_columns() {
  using R = PartRec;
  auto copy3 = [](const double* s, double* d) { std::copy(s, s + 3, d); };
  return {i64<R>("id", [](const R& r) { return r.id; }),
          f64<R>("position", "m", 3, [=](const R& r, double* d) { copy3(r.x, d); }),
          f64<R>("velocity", "m/s", 3, [=](const R& r, double* d) { copy3(r.v, d); }),
          f64<R>("spin", "rad/s", 3, [=](const R& r, double* d) { copy3(r.w, d); }),
          f64<R>("radius", "m", 0, [](const R& r, double* d) { *d = r.r; }),
          // the index of its [[material]] (0 in a scene of one material)
          {"material", "1", 0, h5::Type::U8, [](const R& r, void* d) { *static_cast<std::uint8_t*>(d) = r.material; }}};
}

std::vector<Column<ContRec>> contact_columns(double strong_threshold) {
  using R = ContRec;
  auto copy3 = [](const double* s, double* d) { std::copy(s, s + 3, d); };
  auto norm3 = [](const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); };
  return {i64<R>("id1", [](const R& r) { return r.id1; }), i64<R>("id2", [](const R& r) { return r.id2; }),
          f64<R>("normal", "1", 3, [=](const R& r, double* d) { copy3(r.normal, d); }),
          f64<R>("branch", "m", 3, [=](const R& r, double* d) { copy3(r.branch, d); }),
          f64<R>("overlap", "m", 0, [](const R& r, double* d) { *d = r.overlap; }),
          f64<R>("fn", "N", 0, [](const R& r, double* d) { *d = r.fn; }),
          f64<R>("ft", "N", 3, [=](const R& r, double* d) { copy3(r.ft, d); }),
          f64<R>("mr", "N m", 3, [=](const R& r, double* d) { copy3(r.mr, d); }),
          flag<R>("sliding", [](const R& r) { return r.sliding != 0; }),
          flag<R>("rolling", [](const R& r) { return r.rolling != 0; }),
          // For the contacts' XDMF sidecar (line cells): the strong flag, |f_t|, |m_r| and both ends.
          flag<R>("strong", [strong_threshold](const R& r) { return r.id2 >= 0 && r.fn > strong_threshold; }),
          f64<R>("ft_norm", "N", 0, [=](const R& r, double* d) { *d = norm3(r.ft); }),
          f64<R>("mr_norm", "N m", 0, [=](const R& r, double* d) { *d = norm3(r.mr); }),
          f64<R>("ends", "m", 6, [](const R& r, double* d) {
            for (int k = 0; k < 3; ++k) d[k] = r.x1[k], d[3 + k] = r.x1[k] + r.branch[k];
          })};
}

// Creates the datasets of 'cols' in g with 'total' rows; adds their bytes to 'bytes'.
template <class Rec>
std::vector<h5::Dataset> create(const h5::Group& g, const std::vector<Column<Rec>>& cols, hsize_t total,
                                double& bytes) {
  std::vector<h5::Dataset> ds;
  for (const Column<Rec>& c : cols) {
    ds.push_back(g.create_dataset(c.name, c.type, total, c.cols));
    ds.back().set_attr("unit", std::string(c.unit));
    bytes += double(total * std::max<hsize_t>(c.cols, 1) * type_bytes(c.type));
  }
  return ds;
}

// Writes 'recs' as rows [row0, row0 + recs.size()) of every dataset (collective: every rank
// calls it, with its own rows, possibly none).
template <class Rec>
void write_round(const std::vector<h5::Dataset>& ds, const std::vector<Column<Rec>>& cols, const std::vector<Rec>& recs,
                 hsize_t row0) {
  std::vector<unsigned char> buf;
  for (std::size_t c = 0; c < cols.size(); ++c) {
    const std::size_t w = std::max<hsize_t>(cols[c].cols, 1), sz = type_bytes(cols[c].type);
    buf.assign(std::max<std::size_t>(recs.size() * w * sz, 1), 0);  // a valid pointer when empty
    for (std::size_t i = 0; i < recs.size(); ++i) cols[c].get(recs[i], buf.data() + i * w * sz);
    ds[c].write_rows(cols[c].type, row0, recs.size(), buf.data(), true);
  }
}

// Every contact row of this rank: the particle contacts, then the wall contacts.
void for_each_row(const Simulation& sim, const std::function<void(const ContactRecord&)>& fn) {
  const Particles& p = sim.particles();
  for_each_contact_record(p, sim.cell(), sim.params().law, sim.pairs(), fn, &sim.params().materials);
  if (!sim.params().walls.empty())
    for (const ContactRecord& c :
         wall_contact_records(p, sim.params().law, sim.params().walls, sim.wall_contacts(), &sim.params().materials))
      fn(c);
}

}  // namespace

SnapshotWriter::SnapshotWriter(MPI_Comm comm, const Simulation& sim, double strong_ratio, std::int64_t round_records)
    : comm_(comm), sim_(sim) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  const Particles& p = sim.particles();
  std::int64_t lo = std::numeric_limits<std::int64_t>::max(), hi = std::numeric_limits<std::int64_t>::min();
  for (std::size_t i = 0; i < p.n_owned(); ++i) lo = std::min(lo, p.id[i]), hi = std::max(hi, p.id[i]);
  MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_INT64_T, MPI_MIN, comm_);
  MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_INT64_T, MPI_MAX, comm_);
  if (hi < lo) lo = hi = 0;  // no particles at all
  lo_ = lo, hi_ = hi;

  ExactSums fn(1);
  std::int64_t particle_contacts = 0, wall_contacts = 0;  // walls: not in the threshold
  for_each_row(sim, [&](const ContactRecord& c) {
    if (c.id2 < 0) {
      ++wall_contacts;
      return;
    }
    fn.add(0, c.fn);
    ++particle_contacts;
  });
  fn.normalize();
  std::vector<std::int64_t> buf(fn.words().begin(), fn.words().end());
  const std::size_t words = buf.size();
  buf.push_back(particle_contacts);
  buf.push_back(wall_contacts);
  buf.push_back(std::int64_t(p.n_owned()));
  MPI_Allreduce(MPI_IN_PLACE, buf.data(), int(buf.size()), MPI_INT64_T, MPI_SUM, comm_);
  np_ = buf[words + 2];
  nw_ = buf[words + 1];
  nc_ = buf[words] + nw_;
  std::copy(buf.begin(), buf.begin() + std::ptrdiff_t(words), fn.words().begin());
  fn.normalize();
  if (buf[words] > 0) strong_threshold_ = strong_ratio * (fn.value(0) / double(buf[words]));

  const std::int64_t per_round = std::max<std::int64_t>(1, round_records) * size_;
  const std::int64_t most = std::max(np_, nc_);
  rounds_ = int(std::max<std::int64_t>(1, (most + per_round - 1) / per_round));
}

double SnapshotWriter::write(const h5::Group& g) const {
  const std::vector<Column<PartRec>> pcols = particle_columns();
  const std::vector<Column<ContRec>> ccols = contact_columns(strong_threshold_);
  double bytes = 0;
  const std::vector<h5::Dataset> pds = create(g.create_group("particles"), pcols, hsize_t(np_), bytes);
  const std::vector<h5::Dataset> cds = create(g.create_group("contacts"), ccols, hsize_t(nc_), bytes);

  const Particles& p = sim_.particles();
  hsize_t prow = 0, crow = 0;  // rows written by the earlier rounds
  for (int k = 0; k < rounds_; ++k) {
    const std::int64_t b0 = round_start(lo_, hi_, k, rounds_), b1 = round_start(lo_, hi_, k + 1, rounds_);
    auto in_round = [&](std::int64_t id) { return id >= b0 && id < b1; };
    std::vector<PartRec> parts;
    for (std::size_t i = 0; i < p.n_owned(); ++i) {
      if (!in_round(p.id[i])) continue;
      PartRec r;
      r.id = p.id[i];
      put(r.x, p.x[i]), put(r.v, p.v[i]), put(r.w, p.w[i]);
      r.r = p.radius[i];
      r.material = p.material[i];
      parts.push_back(r);
    }
    std::vector<ContRec> conts;
    for_each_row(sim_, [&](const ContactRecord& c) {
      if (!in_round(c.id1)) return;
      ContRec r{};
      r.id1 = c.id1, r.id2 = c.id2;
      put(r.normal, c.normal), put(r.branch, c.branch), put(r.ft, c.ft), put(r.mr, c.mr);
      r.overlap = c.overlap, r.fn = c.fn;
      r.sliding = c.sliding, r.rolling = c.rolling;
      conts.push_back(r);
    });
    if (size_ > 1) {
      parts = redistribute(comm_, size_, std::move(parts),
                           [&](const PartRec& r) { return slice_rank(r.id, b0, b1, size_); });
      conts = redistribute(comm_, size_, std::move(conts),
                           [&](const ContRec& r) { return slice_rank(r.id1, b0, b1, size_); });
    }
    std::sort(parts.begin(), parts.end(), [](const PartRec& a, const PartRec& b) { return a.id < b.id; });
    std::sort(conts.begin(), conts.end(),
              [](const ContRec& a, const ContRec& b) { return a.id1 != b.id1 ? a.id1 < b.id1 : a.id2 < b.id2; });
    // Body 1 of every contact is here: particles and contacts went by the same id slices (by id
    // and id1). Its centre is the first end of the contact's line cell in the XDMF sidecar.
    for (ContRec& r : conts) {
      const auto it = std::lower_bound(parts.begin(), parts.end(), r.id1,
                                       [](const PartRec& a, std::int64_t id) { return a.id < id; });
      if (it == parts.end() || it->id != r.id1)
        throw std::logic_error("SnapshotWriter: body 1 of a contact is not on its rank");
      std::copy(it->x, it->x + 3, r.x1);
    }
    const auto [p0, pn] = rows_of(comm_, rank_, parts.size());
    const auto [c0, cn] = rows_of(comm_, rank_, conts.size());
    if (pn > 0) write_round(pds, pcols, parts, prow + p0);  // pn, cn: the same on every rank
    if (cn > 0) write_round(cds, ccols, conts, crow + c0);
    prow += pn, crow += cn;
  }
  return bytes;
}

}  // namespace fabrica
