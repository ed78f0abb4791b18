// When and where a running decomposition moves: the rebalancing of MpiDomain, apart from its
// data movement (MpiDomain::migrate sends the particles to the owners chosen here). What a
// rank's load is weighed by is a policy of its own (parallel/balance_policy.hpp).
//   - the bins must stay at least one cutoff / kReach wide as the cell deforms: when they no
//     longer are, a new decomposition (new bins, so the particles may go anywhere);
//   - Cartesian runs by work: checked at the first rebuild whose work is known, then every
//     rebalance_interval rebuilds, and moved when the busiest rank has 2 % more than the mean
//     and new runs would lighten it by 1 %;
//   - METIS: the owned particle counts checked every rebalance_interval rebuilds, repartitioned
//     above rebalance_threshold.
// Every decision is taken from exact integer sums or from the same reductions on every rank,
// so every rank takes it.
#pragma once
#include "core/domain.hpp"
#include "parallel/balance_policy.hpp"
#include "parallel/decomposition.hpp"

#include <mpi.h>

#include <memory>
#include <optional>
#include <string>

namespace fabrica {

struct MpiDomainOptions {
  DecompositionKind kind = DecompositionKind::Cartesian;
  double rebalance_threshold = 1.10;  // repartition (METIS) when max/mean work exceeds this
  int rebalance_interval = 10;        // check the imbalance every this many rebuilds
  // Cartesian: place the runs of bins by the particles' weights rather than in equal lengths;
  // checked at the first rebuild and every rebalance_interval rebuilds, and moved when the
  // busiest rank has 2 % more than the mean and new runs would lighten it by 1 %.
  bool balance_work = true;
  std::string balance = "count";  // the weights' policy (make_balance_policy)
};

// What the rebalancing did (part of MpiDomain's DomainStats).
struct BalanceStats {
  std::int64_t rebalances = 0;
  double imbalance_before = 1, imbalance_after = 1;  // last rebalance (max/mean owned particles)
  double imbalance = 1;                              // at the last check
  // Cartesian runs by work, at the last check: max/mean of the ranks' weights (the policy's;
  // "count": 1 + list pairs per owned particle) with the runs in use before it and with those
  // kept after it; the number of checks and of times the runs were moved.
  double work_imbalance_before = 1, work_imbalance = 1;
  std::int64_t cut_checks = 0, cuts_moved = 0;
};

class Rebalancer {
 public:
  Rebalancer(MPI_Comm comm, const MpiDomainOptions& opt);

  // The decomposition a domain starts with (adopt): the saved one (a checkpoint's record),
  // else runs of equal length (Cartesian) or METIS by particle count; 'holding': whether every
  // rank holds every particle (bin counts are then local knowledge) or a share. Collective.
  Decomposition first(const Particles& p, const PeriodicCell& cell, real_t cutoff, const DecompositionRecord* saved,
                      Holding holding);

  // A decomposition to migrate to at a rebuild, or none to keep 'current'. 'work': as
  // Domain::migrate's (null on every rank or on none). Collective.
  struct Change {
    Decomposition next;
    bool new_bins;  // another set of bins: particles may go to any rank (all-to-all)
  };
  std::optional<Change> at_rebuild(const Particles& p, const PeriodicCell& cell, const Decomposition& current,
                                   const std::vector<std::int32_t>* work, BalanceStats& stats);
  // After the migration that followed a METIS repartition: the imbalance it left.
  void after_migration(const Particles& p, BalanceStats& stats);

  // How to remake 'current' (empty for METIS).
  DecompositionRecord record(const Decomposition& current) const;

  bool timed() const { return policy_->timed(); }
  void note_force_seconds(double s) { force_seconds_ += s; }
  // max/mean of the owned particle count over ranks (collective).
  double load_imbalance(const Particles& p) const;

 private:
  Decomposition decompose(const Particles& p, const PeriodicCell& cell, const std::vector<std::int32_t>* work);
  // The runs by weight near the current ones, if the rule above moves them; collective (two
  // allreduces).
  std::optional<Decomposition> balance_cuts(const Particles& p, const PeriodicCell& cell, const Decomposition& current,
                                            const std::vector<std::int64_t>& weight, BalanceStats& stats);
  // Per axis of d's bins, the owned particles' weights summed over each bin plane and over all
  // ranks (exact integers: the same on every rank); one allreduce of dims[0] + dims[1] + dims[2]
  // values.
  PlaneWork global_plane_work(const Particles& p, const PeriodicCell& cell, const Decomposition& d,
                              const std::vector<std::int64_t>& weight) const;
  std::vector<double> global_bin_work(const Particles& p, const PeriodicCell& cell, const Decomposition& d) const;

  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  MpiDomainOptions opt_;
  std::shared_ptr<const BalancePolicy> policy_;
  real_t cutoff_ = 0;
  Vec3 decomposed_for_ = Vec3::Zero();  // cell lengths of the last Cartesian decomposition
  std::int64_t rebuilds_since_check_ = 0;
  std::int64_t rebuilds_since_cut_check_ = -1;  // -1: not checked yet
  double force_seconds_ = 0;                    // since the last rebuild (a timed policy's)
};

}  // namespace fabrica
