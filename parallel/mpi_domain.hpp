// The MPI implementation of core/domain.hpp: spatial decomposition (parallel/decomposition.hpp),
// ghosts, migration with contact history and reductions: the data movement. When and where the
// decomposition moves (load balance) is the rebalancer's (parallel/rebalancer.hpp), and what a
// rank's load is weighed by a policy's (parallel/balance_policy.hpp).
//
// Contacts between an owned particle and a ghost are computed on both ranks, identically
// (same inputs, bitwise: the ghost is an exact copy, the pair is oriented by global id), and
// each rank adds the force only to its own particle. There is no reverse communication of
// forces; the history of such a contact is held, identically, by both ranks, and travels with
// a migrating particle so that its new owner has it. Energies and measures of a contact are
// counted by the rank that owns its lower-id body.
#pragma once
#include "core/domain.hpp"
#include "parallel/decomposition.hpp"
#include "parallel/exchange.hpp"
#include "parallel/rebalancer.hpp"

#include <mpi.h>

#include <optional>

namespace fabrica {

struct DomainStats : BalanceStats {
  std::int64_t migrations = 0;             // rebuilds with migration
  std::int64_t migrations_all_to_all = 0;  // of which after a new decomposition (all ranks)
  std::int64_t particles_migrated = 0;     // sent by this rank
  std::int64_t bytes_migrated = 0;         // sent by this rank (particles + history)
  std::int64_t bytes_ghost_build = 0;      // sent by this rank at ghost creation
  std::int64_t bytes_forward = 0;          // sent by this rank in forward updates
  std::int64_t forward_updates = 0;
};

class MpiDomain final : public Domain {
 public:
  MpiDomain(MPI_Comm comm, MpiDomainOptions opt = {});

  void begin_ghost_update(Particles& p, const GhostDrift* drift) override;
  void end_ghost_update(Particles& p) override;
  real_t max_all(real_t local) override;
  void max_all(std::span<double> values) override;
  void sum_all(std::span<double> values) override;
  void sum_all(std::span<std::int64_t> values) override;
  void adopt(Particles& p, const PeriodicCell& cell, real_t cutoff, const DecompositionRecord* decomposed_as = nullptr,
             Holding holding = Holding::Whole, HistoryMap* history = nullptr) override;
  DecompositionRecord decomposition_record() const override;
  void migrate(Particles& p, const PeriodicCell& cell, HistoryMap& history,
               const std::vector<std::int32_t>* work) override;
  void build_ghosts(Particles& p, const PeriodicCell& cell, real_t cutoff) override;
  bool wants_force_seconds() const override { return balance_.timed(); }
  void note_force_seconds(double seconds) override { balance_.note_force_seconds(seconds); }
  std::unique_ptr<Domain> clone() const override { return std::make_unique<MpiDomain>(*this); }
  int rank() const override { return rank_; }
  int size() const override { return size_; }

  const Decomposition& decomposition() const { return *dec_; }
  // The ranks this one exchanges ghosts and migrants with (Decomposition::partners).
  const std::vector<int>& partners() const { return partners_; }
  const DomainStats& stats() const { return stats_; }
  // max/mean of the owned particle count over ranks (collective).
  double load_imbalance(const Particles& p) const { return balance_.load_imbalance(p); }

 private:
  void set_decomposition(Decomposition d);  // and its partner ranks
  // adopt() of a share: particles to their owners, springs to the owners of their bodies.
  void gather_share(Particles& p, const PeriodicCell& cell, HistoryMap* history);

  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  Rebalancer balance_;
  real_t rmax_ = 0;  // the largest radius of all ranks (the cutoff is 2 rmax_ + skin)
  std::optional<Decomposition> dec_;
  std::vector<int> partners_;      // dec_->partners(rank_)
  std::vector<int> partner_slot_;  // per rank: its index in partners_, or -1
  bool redecomposed_ = false;      // a new decomposition since the last migration
  // Ghost plan: owned indices sent to each partner every step; ghosts received from each.
  std::vector<std::vector<Index>> ghost_send_idx_;
  std::vector<std::size_t> ghost_recv_first_, ghost_recv_count_;
  NeighbourExchange forward_;
  std::vector<std::vector<BytePiece>> forward_recv_pieces_;  // per recv rank, this update's places
  std::optional<GhostDrift> forward_drift_;                  // the drift end_ghost_update applies (begin's)
  DomainStats stats_;
};

}  // namespace fabrica
