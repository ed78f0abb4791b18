#include "parallel/mpi_domain.hpp"

#include "core/integrator.hpp"
#include "parallel/byte_buffer.hpp"
#include "parallel/peak_memory.hpp"
#include "parallel/properties.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace fabrica {

namespace {

// Frees a container's storage (clear(), '= {}' and assign() keep a vector's capacity).
template <class T>
void release(T& c) {
  T().swap(c);
}

constexpr int kForwardTag = 7101;
constexpr int kMigrateTag = 7111;  // and 7112
constexpr int kGhostTag = 7121;    // and 7122

struct HistoryRecord {
  GlobalId a, b;
  ContactHistory h;
};

}  // namespace

MpiDomain::MpiDomain(MPI_Comm comm, MpiDomainOptions opt) : comm_(comm), balance_(comm, opt) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

real_t MpiDomain::max_all(real_t local) {
  real_t g = local;
  MPI_Allreduce(&local, &g, 1, MPI_DOUBLE, MPI_MAX, comm_);
  return g;
}

void MpiDomain::max_all(std::span<double> values) {
  MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_MAX, comm_);
}

void MpiDomain::sum_all(std::span<double> values) {
  MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_SUM, comm_);
  // MPI does not promise that a floating-point sum rounds the same on every rank; the decisions
  // taken from these sums (stage ends, guards, the servo) must be, so every rank takes rank 0's.
  MPI_Bcast(values.data(), int(values.size()), MPI_DOUBLE, 0, comm_);
}

void MpiDomain::sum_all(std::span<std::int64_t> values) {
  MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_INT64_T, MPI_SUM, comm_);
}

void MpiDomain::set_decomposition(Decomposition d) {
  dec_ = std::move(d);
  partners_ = dec_->partners(rank_);
  partner_slot_.assign(size_, -1);
  for (std::size_t k = 0; k < partners_.size(); ++k) partner_slot_[partners_[k]] = int(k);
  redecomposed_ = true;
}

DecompositionRecord MpiDomain::decomposition_record() const { return balance_.record(*dec_); }

void MpiDomain::adopt(Particles& p, const PeriodicCell& cell, real_t cutoff, const DecompositionRecord* decomposed_as,
                      Holding holding, HistoryMap* history) {
  rmax_ = 0;
  for (std::size_t a = 0; a < p.n_owned(); ++a) rmax_ = std::max(rmax_, p.radius[a]);
  MPI_Allreduce(MPI_IN_PLACE, &rmax_, 1, MPI_DOUBLE, MPI_MAX, comm_);
  set_decomposition(balance_.first(p, cell, cutoff, decomposed_as, holding));
  redecomposed_ = false;  // the particles go to their owners here
  if (holding == Holding::Share) {
    gather_share(p, cell, history);
    return;
  }
  std::vector<Index> keep;  // every rank keeps its own share: nothing to send
  const BinFrame frame(cell);
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    if (dec_->owner(dec_->bin_of(p.x[a], frame)) == rank_) keep.push_back(Index(a));
  p.permute_owned(keep);
}

void MpiDomain::gather_share(Particles& p, const PeriodicCell& cell, HistoryMap* history) {
  // 1. Particles to their owners: one all-to-all (at start-up only).
  const BinFrame L(cell);
  std::vector<std::vector<Index>> leave(size_);
  std::vector<Index> keep;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const int r = dec_->owner(dec_->bin_of(p.x[a], L));
    (r == rank_ ? keep : leave[r]).push_back(Index(a));
  }
  std::vector<std::vector<char>> out(size_);
  for (int r = 0; r < size_; ++r)
    if (!leave[r].empty()) pack(p, leave[r], Message::All, out[r]);
  release(leave);
  // The leavers' storage goes before the exchange, and what was sent before room is made for
  // the arrivals (peak memory: the share, what it sends and what it receives, not twice the
  // share; 869,376 spheres from a data file on 4 ranks: 27 MB less heap per rank).
  p.permute_owned(keep);
  release(keep);
  std::vector<std::vector<char>> in = exchange_all(comm_, out);
  for (auto& b : out) release(b);
  const std::size_t full = bytes_per_particle(Message::All);
  std::size_t arriving = 0;
  for (int r = 0; r < size_; ++r) arriving += in[r].size() / full;
  p.reserve(p.n_owned() + arriving);
  for (int r = 0; r < size_; ++r) {
    const std::size_t n = in[r].size() / full;
    if (n) unpack(p, p.append_owned(n), n, Message::All, in[r].data());
    std::vector<char>().swap(in[r]);
  }
  int any = history && history->size() != 0;
  MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_INT, MPI_LOR, comm_);
  if (!any) return;

  // 2. Springs to the owners of their bodies, through a directory: the rank id % P learns the
  //    owner of each id and the springs that name it, and forwards each spring to that owner.
  //    Two all-to-alls, each rank holding O(its share) throughout.
  auto dir = [&](GlobalId id) { return int(std::uint64_t(id) % std::uint64_t(size_)); };
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    put(out[dir(p.id[a])], std::int8_t(0));
    put(out[dir(p.id[a])], p.id[a]);
  }
  history->for_each([&](GlobalId a, GlobalId b, const ContactHistory& h) {
    put(out[dir(a)], std::int8_t(1));  // to the owner of a
    put(out[dir(a)], HistoryRecord{a, b, h});
    if (b >= 0) {                        // a particle, not a wall
      put(out[dir(b)], std::int8_t(2));  // to the owner of b
      put(out[dir(b)], HistoryRecord{a, b, h});
    }
  });
  const bool twisting = history->twisting();
  history->release();
  in = exchange_all(comm_, out);
  for (auto& b : out) release(b);
  std::unordered_map<GlobalId, int> owner;
  std::vector<std::pair<GlobalId, HistoryRecord>> springs;  // (the id to route by, the spring)
  for (int r = 0; r < size_; ++r) {
    for (const char *c = in[r].data(), *e = c + in[r].size(); c < e;) {
      const auto tag = get<std::int8_t>(c);
      if (tag == 0) {
        owner.emplace(get<GlobalId>(c), r);
      } else {
        const auto h = get<HistoryRecord>(c);
        springs.emplace_back(tag == 1 ? h.a : h.b, h);
      }
    }
    std::vector<char>().swap(in[r]);
  }
  GlobalId missing = -1;  // a spring naming a body that no rank holds (a damaged input)
  for (const auto& [id, h] : springs) {
    const auto it = owner.find(id);
    if (it != owner.end()) put(out[it->second], h);
    else missing = std::max(missing, id);
  }
  MPI_Allreduce(MPI_IN_PLACE, &missing, 1, MPI_INT64_T, MPI_MAX, comm_);
  if (missing >= 0)
    throw std::runtime_error("the contact springs name particle " + std::to_string(missing) +
                             ", which is not among the particles");
  release(springs);
  release(owner);
  in = exchange_all(comm_, out);
  release(out);
  std::size_t n = 0;
  for (const auto& b : in) n += b.size() / sizeof(HistoryRecord);
  history->reset(n, twisting);
  for (const auto& b : in)
    for (const char *c = b.data(), *e = c + b.size(); c < e;) {
      const auto h = get<HistoryRecord>(c);
      history->insert(h.a, h.b, h.h);
    }
}

void MpiDomain::migrate(Particles& p, const PeriodicCell& cell, HistoryMap& history,
                        const std::vector<std::int32_t>* work) {
  p.clear_ghosts();
  // The decomposition may move first (parallel/rebalancer.hpp): with new bins the particles may
  // go to any rank; with runs moved by a few planes, to partners of the new decomposition
  // (symmetric, so point to point works; a destination that is not one sets the all-to-all
  // flag below anyway).
  if (std::optional<Rebalancer::Change> change = balance_.at_rebuild(p, cell, *dec_, work, stats_)) {
    set_decomposition(std::move(change->next));
    redecomposed_ = change->new_bins;
  }

  // Particles leaving, by destination.
  const BinFrame L(cell);
  std::vector<std::vector<Index>> leave(size_);
  std::vector<Index> keep;
  std::unordered_map<GlobalId, int> dest;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const int r = dec_->owner(dec_->bin_of(p.x[a], L));
    if (r == rank_) {
      keep.push_back(Index(a));
    } else {
      leave[r].push_back(Index(a));
      dest.emplace(p.id[a], r);
    }
  }
  // Their contacts' springs go with them (to both destinations if both bodies leave).
  std::vector<std::vector<HistoryRecord>> hist_out(size_);
  if (!dest.empty()) {
    history.for_each([&](GlobalId a, GlobalId b, const ContactHistory& h) {
      int ra = -1;
      if (auto it = dest.find(a); it != dest.end()) hist_out[ra = it->second].push_back({a, b, h});
      if (b >= 0)
        if (auto it = dest.find(b); it != dest.end() && it->second != ra) hist_out[it->second].push_back({a, b, h});
    });
  }
  std::vector<std::vector<char>> out(size_);
  int beyond = redecomposed_ ? 1 : 0;  // a destination that is not a partner
  for (int r = 0; r < size_; ++r) {
    if (leave[r].empty()) continue;
    beyond |= partner_slot_[r] < 0;
    put(out[r], std::int64_t(leave[r].size()));
    pack(p, leave[r], Message::Full, out[r]);
    put(out[r], std::int64_t(hist_out[r].size()));
    for (const HistoryRecord& h : hist_out[r]) put(out[r], h);
    stats_.particles_migrated += std::int64_t(leave[r].size());
    stats_.bytes_migrated += std::int64_t(out[r].size());
  }
  // Between decompositions a particle moves less than a bin between rebuilds, so it goes to a
  // partner: point to point. After a new decomposition (or if anything would go further), one
  // all-to-all; the decision is one allreduce of a flag, the same on every rank.
  MPI_Allreduce(MPI_IN_PLACE, &beyond, 1, MPI_INT, MPI_LOR, comm_);
  redecomposed_ = false;
  std::vector<std::vector<char>> in;
  if (beyond) {
    in = exchange_all(comm_, out);
    ++stats_.migrations_all_to_all;
  } else {
    std::vector<std::vector<char>> to(partners_.size());
    for (std::size_t k = 0; k < partners_.size(); ++k) to[k] = std::move(out[partners_[k]]);
    std::vector<std::vector<char>> from = exchange_partners(comm_, partners_, to, kMigrateTag);
    in.assign(size_, {});
    for (std::size_t k = 0; k < partners_.size(); ++k) in[partners_[k]] = std::move(from[k]);
  }
  p.permute_owned(keep);
  // Room for the arrivals in one reallocation (appending source by source would grow every
  // array by doubling), with an eighth to spare, which the ghosts then use.
  std::size_t arriving = 0;
  for (int r = 0; r < size_; ++r) {
    if (in[r].empty()) continue;
    const char* c = in[r].data();
    arriving += std::size_t(get<std::int64_t>(c));
  }
  p.reserve_more(arriving);
  for (int r = 0; r < size_; ++r) {
    if (in[r].empty()) continue;
    const char* c = in[r].data();
    const auto n = std::size_t(get<std::int64_t>(c));
    c = unpack(p, p.append_owned(n), n, Message::Full, c);
    const auto nh = get<std::int64_t>(c);
    for (std::int64_t k = 0; k < nh; ++k) {
      const auto h = get<HistoryRecord>(c);
      history.insert(h.a, h.b, h.h);
    }
  }
  ++stats_.migrations;
  balance_.after_migration(p, stats_);
}

void MpiDomain::build_ghosts(Particles& p, const PeriodicCell& cell, real_t cutoff) {
  // A particle a becomes a ghost on rank r when a bin of r within kReach of its own bin comes
  // closer to it than R_a + Rmax + skin (= R_a + cutoff - Rmax): a partner j on r lies in such a
  // bin, and the list takes the pair only within R_a + R_j + skin. Small particles thus travel
  // only from a thinner layer than the cutoff; the bins alone (each at least cutoff / kReach
  // wide) would send every particle of the two boundary bins.
  const BinFrame frame(cell);
  const Vec3& L = frame.L;
  const std::array<int, 3>& dims = dec_->dims();
  const real_t beyond = cutoff - rmax_ + 1e-9 * cutoff;  // Rmax + skin, and a rounding margin
  ghost_send_idx_.assign(size_, {});
  std::vector<char> near(size_, 0);
  constexpr int kSpan = 2 * kReach + 1;
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const Vec3 y = frame.coords(p.x[a]);
    const int bin = dec_->bin_of(y, L);
    const std::vector<int>& partners = dec_->neighbour_ranks(bin);
    if (partners.empty()) continue;
    // Per axis: the squared distance from x_a to the slab of the bin at each offset, and that
    // bin's (periodic) coordinate.
    const int c[3] = {bin % dims[0], (bin / dims[0]) % dims[1], bin / (dims[0] * dims[1])};
    real_t d2[3][kSpan];
    int w[3][kSpan];
    for (int k = 0; k < 3; ++k) {
      const real_t edge = L[k] / dims[k], x = y[k];
      for (int o = -kReach; o <= kReach; ++o) {
        const real_t lo = (c[k] + o) * edge, hi = lo + edge;
        const real_t d = o == 0 ? 0.0 : std::max<real_t>(0.0, std::max(lo - x, x - hi));
        d2[k][o + kReach] = d * d;
        w[k][o + kReach] = ((c[k] + o) % dims[k] + dims[k]) % dims[k];
      }
    }
    // A sheared cell's per-axis distances are along non-orthogonal normals: their squares sum
    // to at most normal_spread times the squared distance (1 when orthogonal).
    const real_t lim = p.radius[a] + beyond, lim2 = frame.sheared ? lim * lim * frame.normal_spread : lim * lim;
    for (int oz = 0; oz < kSpan; ++oz)
      for (int oy = 0; oy < kSpan; ++oy) {
        const real_t dyz = d2[2][oz] + d2[1][oy];
        if (dyz > lim2) continue;
        for (int ox = 0; ox < kSpan; ++ox) {
          if (dyz + d2[0][ox] > lim2) continue;
          const int r = dec_->owner_at(w[0][ox], w[1][oy], w[2][oz]);
          if (r != rank_) near[r] = 1;
        }
      }
    for (int r : partners)
      if (near[r]) {
        ghost_send_idx_[r].push_back(Index(a));
        near[r] = 0;
      }
  }
  // Ghosts come only from partners (the owners of bins within kReach): point to point.
  std::vector<std::vector<char>> out(partners_.size());
  for (std::size_t k = 0; k < partners_.size(); ++k) {
    const int r = partners_[k];
    if (ghost_send_idx_[r].empty()) continue;
    pack(p, ghost_send_idx_[r], Message::Full, out[k]);
    stats_.bytes_ghost_build += std::int64_t(out[k].size());
  }
  const auto in = exchange_partners(comm_, partners_, out, kGhostTag);
  const std::size_t full = bytes_per_particle(Message::Full);
  ghost_recv_first_.assign(size_, 0);
  ghost_recv_count_.assign(size_, 0);
  std::size_t arriving = 0;
  for (const auto& b : in) arriving += b.size() / full;
  p.reserve_more(arriving);
  for (std::size_t k = 0; k < partners_.size(); ++k) {
    const int r = partners_[k];
    const std::size_t n = in[k].size() / full;
    ghost_recv_count_[r] = n;
    ghost_recv_first_[r] = p.append_ghosts(n);
    unpack(p, ghost_recv_first_[r], n, Message::Full, in[k].data());
  }
  note_ghosts(p.n_ghost(), p.n_owned());
  // The forward plan: same partners, same order, every step.
  forward_.send_ranks.clear();
  forward_.recv_ranks.clear();
  forward_.send_buf.clear();
  forward_.send_pieces.clear();
  for (int r = 0; r < size_; ++r) {
    if (!ghost_send_idx_[r].empty()) {
      forward_.send_ranks.push_back(r);
      forward_.send_buf.emplace_back();
      forward_.send_pieces.emplace_back();  // its pieces: at each update (the message kind varies)
    }
    if (ghost_recv_count_[r] != 0) forward_.recv_ranks.push_back(r);
  }
}

// The forward messages are field by field (all x, then all v, then all w), each field a
// message of its own, received straight into the ghosts' range of that array (a partner's
// ghosts are contiguous): no receive buffer and no copy out of it. The places are taken from
// p at every update, so a reallocation of p's arrays between updates cannot leave a receive
// pointing at freed memory.
void MpiDomain::begin_ghost_update(Particles& p, const GhostDrift* drift) {
  // Given the step's drift, the ghosts' positions are advanced here rather than sent (a third
  // of the bytes); otherwise they travel with v and w.
  const Message m = drift ? Message::Forward : Message::Refresh;
  forward_drift_.reset();
  if (drift) forward_drift_ = *drift;
  for (std::size_t k = 0; k < forward_.send_ranks.size(); ++k) {
    auto& buf = forward_.send_buf[k];
    buf.clear();
    const std::vector<Index>& idx = ghost_send_idx_[forward_.send_ranks[k]];
    pack_fields(p, idx, m, buf);
    field_piece_bytes(idx.size(), m, forward_.send_pieces[k]);
  }
  forward_recv_pieces_.resize(forward_.recv_ranks.size());
  for (std::size_t k = 0; k < forward_.recv_ranks.size(); ++k) {
    const int r = forward_.recv_ranks[k];
    field_pieces(p, ghost_recv_first_[r], ghost_recv_count_[r], m, forward_recv_pieces_[k]);
  }
  forward_.start(comm_, kForwardTag, forward_recv_pieces_);
}

void MpiDomain::end_ghost_update(Particles& p) {
  forward_.wait();
  stats_.bytes_forward += std::int64_t(forward_.bytes_sent());
  ++stats_.forward_updates;
  if (!forward_drift_) return;
  const GhostDrift d = *forward_drift_;
  forward_drift_.reset();
  for (const int r : forward_.recv_ranks) {
    const std::size_t first = ghost_recv_first_[r], end = first + ghost_recv_count_[r];
    const CellStep& s = d.deformation;
    if (d.deform && s.sheared)
      for (std::size_t a = first; a < end; ++a) p.x[a] = drifted_sheared(p.x[a], p.v[a], d.dt, s.F);
    else if (d.deform)
      for (std::size_t a = first; a < end; ++a) p.x[a] = drifted<true>(p.x[a], p.v[a], d.dt, s.scale);
    else
      for (std::size_t a = first; a < end; ++a) p.x[a] = drifted<false>(p.x[a], p.v[a], d.dt, s.scale);
  }
}

}  // namespace fabrica
