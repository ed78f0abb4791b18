#include "parallel/rebalancer.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace fabrica {

Rebalancer::Rebalancer(MPI_Comm comm, const MpiDomainOptions& opt)
    : comm_(comm), opt_(opt), policy_(make_balance_policy(opt.balance)) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

double Rebalancer::load_imbalance(const Particles& p) const {
  double n = double(p.n_owned()), mx = 0, sum = 0;
  MPI_Allreduce(&n, &mx, 1, MPI_DOUBLE, MPI_MAX, comm_);
  MPI_Allreduce(&n, &sum, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return sum > 0 ? mx / (sum / size_) : 1.0;
}

std::vector<double> Rebalancer::global_bin_work(const Particles& p, const PeriodicCell& cell,
                                                const Decomposition& d) const {
  const BinFrame frame(cell);
  std::vector<double> work(d.bins(), 0.0);
  for (std::size_t a = 0; a < p.n_owned(); ++a) work[d.bin_of(p.x[a], frame)] += 1.0;
  MPI_Allreduce(MPI_IN_PLACE, work.data(), int(work.size()), MPI_DOUBLE, MPI_SUM, comm_);
  return work;
}

PlaneWork Rebalancer::global_plane_work(const Particles& p, const PeriodicCell& cell, const Decomposition& d,
                                        const std::vector<std::int64_t>& weight) const {
  const BinFrame frame(cell);
  const std::array<int, 3>& n = d.dims();
  std::vector<std::int64_t> flat(std::size_t(n[0] + n[1] + n[2]), 0);  // axis 0, then 1, then 2
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const int bin = d.bin_of(p.x[a], frame);
    const int c[3] = {bin % n[0], (bin / n[0]) % n[1], bin / (n[0] * n[1])};
    flat[c[0]] += weight[a];
    flat[n[0] + c[1]] += weight[a];
    flat[n[0] + n[1] + c[2]] += weight[a];
  }
  MPI_Allreduce(MPI_IN_PLACE, flat.data(), int(flat.size()), MPI_INT64_T, MPI_SUM, comm_);
  PlaneWork w;
  for (int k = 0, at = 0; k < 3; at += n[k++]) w[k].assign(flat.begin() + at, flat.begin() + at + n[k]);
  return w;
}

Decomposition Rebalancer::first(const Particles& p, const PeriodicCell& cell, real_t cutoff,
                                const DecompositionRecord* saved, Holding holding) {
  const BinFrame frame(cell);
  cutoff_ = cutoff;
  if (opt_.kind == DecompositionKind::Cartesian) {
    decomposed_for_ = saved ? saved->lengths : frame.L;
    rebuilds_since_cut_check_ = saved ? saved->since_check : -1;
    if (!saved || saved->cuts.empty()) return Decomposition::cartesian(size_, decomposed_for_, cutoff_);
    const Decomposition shape = Decomposition::cartesian(size_, decomposed_for_, cutoff_);  // the saved runs
    CartesianCuts cuts;
    std::size_t next = 0;
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < shape.rank_grid()[k] && next < saved->cuts.size(); ++j)
        cuts[k].push_back(saved->cuts[next++]);
    if (next != saved->cuts.size())
      throw std::runtime_error("the saved decomposition has " + std::to_string(saved->cuts.size()) +
                               " cuts, not one per run of the rank grid");
    return Decomposition::cartesian(size_, decomposed_for_, cutoff_, cuts);
  }
  const Decomposition shape = Decomposition::shape(DecompositionKind::Metis, frame.L, cutoff_);
  std::vector<double> work;
  if (holding == Holding::Share) {
    work = global_bin_work(p, cell, shape);
  } else {  // every rank holds every particle: bin work is local knowledge, no reduction
    work.assign(shape.bins(), 0.0);
    for (std::size_t a = 0; a < p.n_owned(); ++a) work[shape.bin_of(p.x[a], frame)] += 1;
  }
  return Decomposition::metis(size_, frame.L, cutoff_, work, comm_);
}

Decomposition Rebalancer::decompose(const Particles& p, const PeriodicCell& cell,
                                    const std::vector<std::int32_t>* work) {
  const BinFrame frame(cell);
  if (opt_.kind == DecompositionKind::Cartesian) {
    decomposed_for_ = frame.L;
    if (!opt_.balance_work || !work)  // work is null on every rank or on none
      return Decomposition::cartesian(size_, frame.L, cutoff_);
    const Decomposition shape = Decomposition::shape(DecompositionKind::Cartesian, frame.L, cutoff_);
    return Decomposition::by_work(size_, frame.L, cutoff_,
                                  global_plane_work(p, cell, shape, policy_->weigh(*work, force_seconds_)));
  }
  // Bin work from the current owners (the bins of the new decomposition).
  const Decomposition shape = Decomposition::shape(DecompositionKind::Metis, frame.L, cutoff_);
  return Decomposition::metis(size_, frame.L, cutoff_, global_bin_work(p, cell, shape), comm_);
}

std::optional<Decomposition> Rebalancer::balance_cuts(const Particles& p, const PeriodicCell& cell,
                                                      const Decomposition& current,
                                                      const std::vector<std::int64_t>& weight, BalanceStats& stats) {
  const BinFrame frame(cell);
  // The runs the current weights give, on the bins of the current decomposition (made for
  // decomposed_for_, so the same bins).
  Decomposition next = Decomposition::by_work(size_, decomposed_for_, cutoff_,
                                              global_plane_work(p, cell, current, weight), &current.cuts());
  // Each rank's weight with the current runs and with the new ones, summed exactly (integers):
  // every rank takes the same decision.
  std::vector<std::int64_t> load(2 * std::size_t(size_), 0);
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const int bin = current.bin_of(p.x[a], frame);
    load[current.owner(bin)] += weight[a];
    load[size_ + next.owner(bin)] += weight[a];
  }
  MPI_Allreduce(MPI_IN_PLACE, load.data(), int(load.size()), MPI_INT64_T, MPI_SUM, comm_);
  std::int64_t total = 0, now = 0, then = 0;
  for (int r = 0; r < size_; ++r) {
    total += load[r];
    now = std::max(now, load[r]);
    then = std::max(then, load[size_ + r]);
  }
  ++stats.cut_checks;
  auto imbalance = [&](std::int64_t most) { return total > 0 ? double(most) * size_ / double(total) : 1.0; };
  stats.work_imbalance_before = stats.work_imbalance = imbalance(now);
  // Moved when the busiest rank has more than 2 % above the mean and the new runs lighten it
  // by at least 1 %.
  if (!(100 * now * size_ > 102 * total && 100 * then <= 99 * now)) return std::nullopt;
  stats.work_imbalance = imbalance(then);
  ++stats.cuts_moved;
  return next;
}

std::optional<Rebalancer::Change> Rebalancer::at_rebuild(const Particles& p, const PeriodicCell& cell,
                                                         const Decomposition& current,
                                                         const std::vector<std::int32_t>* work, BalanceStats& stats) {
  const BinFrame frame(cell);
  // 'work' is null on every rank or on none, so every rank calls the same collectives.
  std::optional<Change> change;
  if (!current.fits(frame.L, cutoff_)) {
    change = Change{decompose(p, cell, work), true};
  } else if (opt_.kind == DecompositionKind::Cartesian && opt_.balance_work && work &&
             (rebuilds_since_cut_check_ < 0 || ++rebuilds_since_cut_check_ >= opt_.rebalance_interval)) {
    rebuilds_since_cut_check_ = 0;
    // Runs moved by a few planes send the particles between them to partners of the new
    // decomposition (symmetric, so point to point works); a destination that is not one sets
    // the all-to-all flag in migrate() anyway. No forced all-to-all, unlike a new set of bins.
    if (std::optional<Decomposition> moved =
            balance_cuts(p, cell, current, policy_->weigh(*work, force_seconds_), stats))
      change = Change{std::move(*moved), false};
  }
  if (opt_.kind == DecompositionKind::Metis && ++rebuilds_since_check_ >= opt_.rebalance_interval) {
    rebuilds_since_check_ = 0;
    stats.imbalance = load_imbalance(p);
    if (stats.imbalance > opt_.rebalance_threshold) {
      stats.imbalance_before = stats.imbalance;
      change = Change{decompose(p, cell, work), true};
      ++stats.rebalances;
      stats.imbalance_after = -1;  // measured after the particles have moved (after_migration)
    }
  }
  force_seconds_ = 0;  // the next list's
  return change;
}

void Rebalancer::after_migration(const Particles& p, BalanceStats& stats) {
  if (stats.imbalance_after < 0) stats.imbalance_after = load_imbalance(p);
}

DecompositionRecord Rebalancer::record(const Decomposition& current) const {
  DecompositionRecord r;
  if (opt_.kind != DecompositionKind::Cartesian) return r;
  r.lengths = decomposed_for_;
  r.since_check = rebuilds_since_cut_check_;
  for (const std::vector<int>& axis : current.cuts())
    for (int c : axis) r.cuts.push_back(std::int32_t(c));
  return r;
}

}  // namespace fabrica
