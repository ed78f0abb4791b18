#include "io/mpi/distributed_setup.hpp"

#include "core/exact_sum.hpp"
#include "core/neighbor.hpp"
#include "io/mpi/distributed_read.hpp"
#include "io/serial/setup_ranks.hpp"
#include "parallel/byte_buffer.hpp"
#include "parallel/exchange.hpp"
#include "parallel/guard.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fabrica {

namespace {

// Squared periodic distance from x to the box [lo, lo + side).
double box_distance2(const Vec3& x, const Vec3& lo, const Vec3& side, const Vec3& L) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double t = std::fmod(x[k] - lo[k], L[k]);
    if (t < 0) t += L[k];
    const double d = t <= side[k] ? 0.0 : std::min(t - side[k], L[k] - t);
    d2 += d * d;
  }
  return d2;
}

// The ranks of a communicator as the set-up sees them (io/serial/setup_ranks.hpp): the
// reductions are MPI's, an error on any rank becomes every rank's through parallel/guard.hpp's
// agree, a data file is read in byte ranges, regions go to the ranks whose subdomains will
// hold them, and each rank takes its subdomain's share through an MpiDomain.
class CommRanks final : public SetupRanks {
 public:
  CommRanks(MPI_Comm comm, const MpiDomainOptions& options) : comm_(comm), options_(options) {
    MPI_Comm_rank(comm, &rank_);
    MPI_Comm_size(comm, &ranks_);
  }
  int rank() const override { return rank_; }
  int ranks() const override { return ranks_; }
  int ranks_on_node() override { return ranks_on_this_node(comm_); }
  Holding holding() const override { return Holding::Share; }

  void agree(const std::function<void()>& phase) override { fabrica::agree(comm_, phase); }
  double min(double x) override { return reduce(x, MPI_DOUBLE, MPI_MIN); }
  double max(double x) override { return reduce(x, MPI_DOUBLE, MPI_MAX); }
  std::int64_t min(std::int64_t x) override { return reduce(x, MPI_INT64_T, MPI_MIN); }
  void sum(std::vector<std::int64_t>& x) override {
    MPI_Allreduce(MPI_IN_PLACE, x.data(), int(x.size()), MPI_INT64_T, MPI_SUM, comm_);
  }
  void sum(ExactSums& s) override {
    MPI_Allreduce(MPI_IN_PLACE, s.words().data(), int(s.words().size()), MPI_INT64_T, MPI_SUM, comm_);
    s.normalize();
  }
  OverlapReport largest(const OverlapReport& mine) override {
    std::vector<double> all(std::size_t(4 * ranks_));
    const double m[4] = {mine.ratio, mine.overlap, double(mine.a), double(mine.b)};
    MPI_Allgather(m, 4, MPI_DOUBLE, all.data(), 4, MPI_DOUBLE, comm_);
    OverlapReport worst;
    for (int k = 0; k < ranks_; ++k) {
      const double* o = &all[std::size_t(4 * k)];
      if (o[0] > worst.ratio) worst = {o[0], o[1], GlobalId(o[2]), GlobalId(o[3])};
    }
    return worst;
  }

  DataFile read_data(const std::string& path, const std::vector<std::int64_t>* types) override {
    return read_data_share(path, comm_, types);
  }
  // Cartesian: the rank whose subdomain will hold the region's centre (the decomposition made
  // as the simulation will make it, with the largest possible cutoff), so that few spheres move
  // afterwards; METIS: contiguous blocks.
  std::vector<int> region_owners(const RegionCut& cut, const PeriodicCell& cell, real_t cutoff) override {
    std::vector<int> owner = SetupRanks::region_owners(cut, cell, cutoff);
    if (options_.kind != DecompositionKind::Cartesian) return owner;
    const Decomposition dec = Decomposition::cartesian(ranks_, cell.lengths(), cutoff);
    for (int q = 0; q < cut.grid.regions(); ++q)
      owner[std::size_t(q)] = dec.owner(dec.bin_of(cut.grid.lower(q) + 0.5 * cut.grid.side(), cell.lengths()));
    return owner;
  }
  RegionExchange region_exchange(const Scene& sc, const RegionCut& cut, const PeriodicCell& cell,
                                 const std::vector<int>& owners) override;
  OverlapReport take_share(Particles& p, const PeriodicCell& cell, real_t cutoff, Holding h) override {
    MpiDomain domain(comm_, options_);
    domain.adopt(p, cell, cutoff, nullptr, h);
    domain.build_ghosts(p, cell, cutoff);
    NeighborSearch search;
    PairList pairs;
    search.build(p, cell, 0.0, pairs);
    const OverlapReport r = largest_overlap(p, pairs, cell);
    p.clear_ghosts();
    return r;
  }

 private:
  template <class T>
  T reduce(T x, MPI_Datatype type, MPI_Op op) {
    MPI_Allreduce(MPI_IN_PLACE, &x, 1, type, op, comm_);
    return x;
  }
  MPI_Comm comm_;
  MpiDomainOptions options_;
  int rank_ = 0, ranks_ = 1;
};

// After each colour, each placed sphere goes to the ranks of the adjacent regions it can reach:
// a later sphere of region h overlaps it only if it lies within d_max of h (the regions are
// 4 d_max wide or more: a thin layer).
RegionExchange CommRanks::region_exchange(const Scene& sc, const RegionCut& cut, const PeriodicCell& cell,
                                          const std::vector<int>& owners) {
  return [this, &sc, &cut, &cell, &owners](const Particles& placed, const std::vector<int>& region_of) {
    const real_t d_max = sc.generate.d_max;
    std::vector<std::vector<char>> out(static_cast<std::size_t>(ranks_));
    for (std::size_t a = 0; a < placed.n_owned(); ++a) {
      std::vector<int> to;
      for (int h : cut.grid.neighbours(region_of[a])) {
        const int r = owners[std::size_t(h)];
        if (r == rank_ || std::find(to.begin(), to.end(), r) != to.end()) continue;
        if (box_distance2(placed.x[a], cut.grid.lower(h), cut.grid.side(), cell.lengths()) < d_max * d_max)
          to.push_back(r);
      }
      for (int r : to) {
        put(out[std::size_t(r)], placed.id[a]);
        put(out[std::size_t(r)], placed.radius[a]);
        put(out[std::size_t(r)], placed.x[a]);
      }
    }
    const auto in = exchange_all(comm_, out);
    Particles got;
    for (const auto& b : in)
      for (const char *c = b.data(), *e = c + b.size(); c < e;) {
        const auto id = get<GlobalId>(c);
        const auto rad = get<real_t>(c);
        got.add({id, rad, sc.density, get<Vec3>(c)});  // its material and mass: apply_scene_run
      }
    return got;
  };
}

}  // namespace

Setup make_distributed_setup(const Scene& sc, MPI_Comm comm, const MpiDomainOptions& options) {
  CommRanks ranks(comm, options);
  return make_setup(sc, ranks);
}

Setup make_run_setup(const Scene& scene, MPI_Comm comm, const MpiDomainOptions& options) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  if (ranks > 1) return make_distributed_setup(scene, comm, options);
  Setup s;
  agree(comm, [&] { s = make_setup(scene); });
  return s;
}

SpecimenTotals specimen_totals(const Particles& p, MPI_Comm comm) {
  ExactSums sums(3);
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const real_t R = p.radius[a];
    sums.add(0, 2 * R);
    sums.add(1, p.mass[a]);
    sums.add(2, 4.0 / 3.0 * std::numbers::pi * R * R * R);
  }
  sums.normalize();
  std::int64_t n = std::int64_t(p.n_owned());
  MPI_Allreduce(MPI_IN_PLACE, sums.words().data(), int(sums.words().size()), MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &n, 1, MPI_INT64_T, MPI_SUM, comm);
  sums.normalize();
  return {n, sums.value(0), sums.value(1), sums.value(2)};
}

}  // namespace fabrica
