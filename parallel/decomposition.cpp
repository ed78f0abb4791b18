#include "parallel/decomposition.hpp"

#include <Eigen/Eigenvalues>

#include <metis.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace fabrica {

BinFrame::BinFrame(const PeriodicCell& cell) : sheared(cell.sheared()), L(cell.lengths()) {
  if (!sheared) return;
  L = cell.heights();
  const Mat3 inv = cell.matrix().inverse();
  to_bin = L.asDiagonal() * inv;
  Mat3 n = inv;  // rows: the face normals, made unit
  for (int k = 0; k < 3; ++k) n.row(k).normalize();
  normal_spread = Eigen::SelfAdjointEigenSolver<Mat3>(n * n.transpose()).eigenvalues().maxCoeff();
}

std::array<int, 3> Decomposition::bin_dims(const Vec3& L, real_t cutoff, DecompositionKind kind) {
  // Bins made kSlack wider than needed, so that a decomposition stays valid (fits()) while an
  // axis of the cell shrinks by up to 1 - 1/kSlack = 20 %: a new decomposition, which migrates
  // with one all-to-all, is then rare in a triaxial test instead of every bin's worth of
  // strain. METIS's bins are no more than kMaxBins: its map is a table per bin on every rank,
  // and a fine grid adds nothing to the balance of a large cell but costs METIS time.
  constexpr double kMaxBins = 32768;
  constexpr double kSlack = 1.25;
  real_t edge = kSlack * cutoff / kReach;
  if (kind == DecompositionKind::Metis) edge = std::max(edge, std::cbrt(L.prod() / kMaxBins));
  std::array<int, 3> d;
  for (int k = 0; k < 3; ++k) d[k] = std::max(1, int(std::floor(L[k] / edge)));
  return d;
}

Decomposition Decomposition::shape(DecompositionKind kind, const Vec3& L, real_t cutoff) {
  Decomposition d;
  d.dims_ = bin_dims(L, cutoff, kind);
  for (int k = 0; k < 3; ++k) d.cuts_[k] = {0};
  d.own_by_cuts();
  return d;
}

bool Decomposition::fits(const Vec3& L, real_t cutoff) const {
  for (int k = 0; k < 3; ++k)
    if (L[k] / dims_[k] * kReach < cutoff) return false;
  return true;
}

Decomposition Decomposition::grid(int nranks, const Vec3& L, real_t cutoff) {
  Decomposition d;
  d.kind_ = DecompositionKind::Cartesian;
  d.dims_ = bin_dims(L, cutoff, DecompositionKind::Cartesian);
  // The factorisation P1 P2 P3 = nranks with Pk <= bins along k that minimises the largest
  // face area of a subdomain (ghost volume), for this cell's aspect ratio.
  double best = std::numeric_limits<double>::infinity();
  for (int p0 = 1; p0 <= nranks; ++p0) {
    if (nranks % p0) continue;
    for (int p1 = 1; p1 <= nranks / p0; ++p1) {
      if ((nranks / p0) % p1) continue;
      const int p2 = nranks / p0 / p1;
      const int p[3] = {p0, p1, p2};
      bool ok = true;
      for (int k = 0; k < 3; ++k) ok &= p[k] <= d.dims_[k];
      if (!ok) continue;
      const double a = L[0] / p0, b = L[1] / p1, c = L[2] / p2;
      const double surface = (p0 > 1 ? b * c : 0) + (p1 > 1 ? a * c : 0) + (p2 > 1 ? a * b : 0);
      if (surface < best - 1e-15) {
        best = surface;
        d.grid_ = {p0, p1, p2};
      }
    }
  }
  if (!std::isfinite(best))
    throw std::runtime_error("cannot split a cell of " + std::to_string(d.dims_[0]) + " x " +
                             std::to_string(d.dims_[1]) + " x " + std::to_string(d.dims_[2]) +
                             " bins (bin edge >= (2 Rmax + skin) / 2) over " + std::to_string(nranks) +
                             " ranks; use fewer ranks or a larger specimen");
  return d;
}

void Decomposition::own_by_cuts() {
  // Per axis: the run of each plane, and its class: the plane's run with the distinct runs
  // within kReach of it (periodic); planes of one class have the same neighbour ranks along
  // this axis.
  std::array<std::vector<std::vector<int>>, 3> classes;  // per axis: {own run, near runs...}
  for (int k = 0; k < 3; ++k) {
    const int n = dims_[k], P = grid_[k];
    run_[k].assign(n, 0);
    for (int j = 0; j < P; ++j) {
      const int first = cuts_[k][j], end = j + 1 < P ? cuts_[k][j + 1] : cuts_[k][0] + n;
      for (int x = first; x < end; ++x) run_[k][x % n] = j;
    }
    near_[k].assign(n, 0);
    for (int x = 0; x < n; ++x) {
      std::vector<int> key{run_[k][x]};
      for (int o = -kReach; o <= kReach; ++o) key.push_back(run_[k][((x + o) % n + n) % n]);
      std::sort(key.begin() + 1, key.end());
      key.erase(std::unique(key.begin() + 1, key.end()), key.end());
      auto at = std::find(classes[k].begin(), classes[k].end(), key);
      near_[k][x] = int(at - classes[k].begin());
      if (at == classes[k].end()) classes[k].push_back(std::move(key));
    }
    near_count_[k] = int(classes[k].size());
  }
  // Per combination of classes: the ranks of the product of the three axes' near runs, less
  // the bin's own.
  adj_ranks_.assign(std::size_t(near_count_[0]) * near_count_[1] * near_count_[2], {});
  for (int c2 = 0; c2 < near_count_[2]; ++c2)
    for (int c1 = 0; c1 < near_count_[1]; ++c1)
      for (int c0 = 0; c0 < near_count_[0]; ++c0) {
        const std::vector<int>&a = classes[0][c0], &b = classes[1][c1], &c = classes[2][c2];
        const int own = a[0] + grid_[0] * (b[0] + grid_[1] * c[0]);
        std::vector<int>& out = adj_ranks_[c0 + near_count_[0] * (c1 + near_count_[1] * c2)];
        for (std::size_t i2 = 1; i2 < c.size(); ++i2)
          for (std::size_t i1 = 1; i1 < b.size(); ++i1)
            for (std::size_t i0 = 1; i0 < a.size(); ++i0) {
              const int r = a[i0] + grid_[0] * (b[i1] + grid_[1] * c[i2]);
              if (r != own) out.push_back(r);
            }
        std::sort(out.begin(), out.end());
      }
}

Decomposition Decomposition::cartesian(int nranks, const Vec3& L, real_t cutoff) {
  Decomposition d = grid(nranks, L, cutoff);
  for (int k = 0; k < 3; ++k)  // equal runs: bin x in run floor(x P / n)
    for (int j = 0; j < d.grid_[k]; ++j) d.cuts_[k].push_back((j * d.dims_[k] + d.grid_[k] - 1) / d.grid_[k]);
  d.own_by_cuts();
  return d;
}

Decomposition Decomposition::by_work(int nranks, const Vec3& L, real_t cutoff, const PlaneWork& plane_work,
                                     const CartesianCuts* current) {
  Decomposition d = grid(nranks, L, cutoff);
  for (int k = 0; k < 3; ++k) {
    if (int(plane_work[k].size()) != d.dims_[k])
      throw std::logic_error("Decomposition::by_work: one work value per bin plane expected");
    if (current && int((*current)[k].size()) != d.grid_[k])
      throw std::logic_error("Decomposition::by_work: the current runs are of another rank grid");
    d.cuts_[k] =
        current ? balanced_runs(plane_work[k], d.grid_[k], (*current)[k]) : balanced_runs(plane_work[k], d.grid_[k]);
  }
  d.own_by_cuts();
  return d;
}

Decomposition Decomposition::cartesian(int nranks, const Vec3& L, real_t cutoff, const CartesianCuts& cuts) {
  Decomposition d = grid(nranks, L, cutoff);
  for (int k = 0; k < 3; ++k) {
    const std::vector<int>& c = cuts[k];
    bool ok = int(c.size()) == d.grid_[k] && !c.empty() && c[0] >= 0 && c[0] < d.dims_[k];
    for (std::size_t j = 1; ok && j < c.size(); ++j) ok = c[j] > c[j - 1];
    ok = ok && c.back() < d.dims_[k];
    if (!ok)
      throw std::runtime_error("the saved decomposition's cuts along axis " + std::to_string(k + 1) + " do not fit " +
                               std::to_string(d.grid_[k]) + " runs of " + std::to_string(d.dims_[k]) + " bins");
  }
  d.cuts_ = cuts;
  d.own_by_cuts();
  return d;
}

namespace {

// The fewest runs of w, from plane s, none heavier than M (each at least one plane).
int runs_needed(std::span<const std::int64_t> w, int s, std::int64_t M) {
  const int n = int(w.size());
  int runs = 0;
  for (int i = 0; i < n;) {
    std::int64_t sum = w[(s + i++) % n];
    while (i < n && sum + w[(s + i) % n] <= M) sum += w[(s + i++) % n];
    ++runs;
  }
  return runs;
}

// The lightest bound on the heaviest run over every start, and the lowest start that reaches it.
std::pair<std::int64_t, int> lightest_bound(std::span<const std::int64_t> w, int parts) {
  const int n = int(w.size());
  if (parts < 1 || parts > n) throw std::logic_error("balanced_runs: need 1 <= parts <= planes");
  std::int64_t total = 0, heaviest = 0;
  for (std::int64_t x : w) total += x, heaviest = std::max(heaviest, x);
  std::int64_t best_M = total + 1;
  int best_s = 0;
  for (int s = 0; s < n; ++s) {  // the lightest bound for this start (bisection on integers)
    std::int64_t lo = heaviest, hi = std::min(total, best_M - 1);
    if (lo > hi || runs_needed(w, s, hi) > parts) continue;  // cannot beat the best so far
    while (lo < hi) {
      const std::int64_t mid = lo + (hi - lo) / 2;
      if (runs_needed(w, s, mid) <= parts) hi = mid;
      else lo = mid + 1;
    }
    best_M = lo, best_s = s;
  }
  return {best_M, best_s};
}

// Runs from s, each as long as M allows while leaving a plane for each later run; ascending.
std::vector<int> runs_from(std::span<const std::int64_t> w, int parts, int s, std::int64_t M) {
  const int n = int(w.size());
  std::vector<int> first;
  for (int i = 0, j = 0; j < parts; ++j) {
    first.push_back((s + i) % n);
    std::int64_t sum = w[(s + i++) % n];
    while (n - i > parts - 1 - j && sum + w[(s + i) % n] <= M) sum += w[(s + i++) % n];
  }
  std::sort(first.begin(), first.end());
  return first;
}

// The weight of the planes whose run differs between two splits (run j from first[j] to
// first[j + 1]; the planes before first[0] belong to the last run).
std::int64_t moved_weight(std::span<const std::int64_t> w, std::span<const int> a, std::span<const int> b) {
  std::int64_t moved = 0;
  std::size_t ja = a.size() - 1, jb = b.size() - 1;
  for (int i = 0; i < int(w.size()); ++i) {
    for (std::size_t j = 0; j < a.size(); ++j)
      if (a[j] == i) ja = j;
    for (std::size_t j = 0; j < b.size(); ++j)
      if (b[j] == i) jb = j;
    if (ja != jb) moved += w[i];
  }
  return moved;
}

}  // namespace

std::vector<int> balanced_runs(std::span<const std::int64_t> w, int parts) {
  const auto [M, s] = lightest_bound(w, parts);
  return runs_from(w, parts, s, M);
}

std::vector<int> balanced_runs(std::span<const std::int64_t> w, int parts, std::span<const int> current) {
  if (int(current.size()) != parts) throw std::logic_error("balanced_runs: one current run per part expected");
  const int n = int(w.size());
  const std::int64_t M = lightest_bound(w, parts).first;
  const std::int64_t allowed = M + M / 100;
  std::vector<int> best;
  std::int64_t best_moved = 0;
  for (int s = 0; s < n; ++s) {
    if (runs_needed(w, s, allowed) > parts) continue;
    std::vector<int> first = runs_from(w, parts, s, allowed);
    const std::int64_t moved = moved_weight(w, current, first);
    if (best.empty() || moved < best_moved) best = std::move(first), best_moved = moved;
  }
  return best;
}

namespace {
// The distinct periodic bins within 'reach' of a bin along every axis (itself excluded), in the
// order of their first offset (dz, then dy, then dx, each from -reach to reach). A bin is a
// product of one coordinate per axis, so the distinct bins are the products of each axis'
// distinct coordinates (fewer than 2 reach + 1 when the axis has fewer bins), in the same
// order; no search among the bins found so far (that search is quadratic in the 125 bins of
// reach 2, and this runs for every bin of a METIS decomposition).
std::vector<int> neighbour_bins(const std::array<int, 3>& n, int bin, int reach) {
  const int c[3] = {bin % n[0], bin / n[0] % n[1], bin / (n[0] * n[1])};
  std::array<std::vector<int>, 3> coord;  // each axis' distinct coordinates, first offset first
  for (int k = 0; k < 3; ++k)
    for (int d = -reach; d <= reach; ++d) {
      const int x = ((c[k] + d) % n[k] + n[k]) % n[k];
      if (std::find(coord[k].begin(), coord[k].end(), x) == coord[k].end()) coord[k].push_back(x);
    }
  std::vector<int> out;
  out.reserve(coord[0].size() * coord[1].size() * coord[2].size());
  for (int z : coord[2])
    for (int y : coord[1])
      for (int x : coord[0]) {
        const int b = x + n[0] * (y + n[1] * z);
        if (b != bin) out.push_back(b);
      }
  return out;
}
}  // namespace

Decomposition Decomposition::metis(int nranks, const Vec3& L, real_t cutoff, const std::vector<double>& bin_work,
                                   MPI_Comm comm) {
  Decomposition d;
  d.kind_ = DecompositionKind::Metis;
  d.dims_ = bin_dims(L, cutoff, DecompositionKind::Metis);
  const int nb = d.bins();
  if (int(bin_work.size()) != nb) throw std::logic_error("metis: one work value per bin expected");
  if (nb < nranks)
    throw std::runtime_error("cannot partition " + std::to_string(nb) +
                             " bins (bin edge >= (2 Rmax + skin) / 2) over " + std::to_string(nranks) +
                             " ranks; use fewer ranks or a larger specimen");
  d.owner_.assign(nb, 0);
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (nranks > 1 && rank == 0) {
    std::vector<idx_t> xadj(1, 0), adjncy, vwgt(nb);
    for (int b = 0; b < nb; ++b) {
      for (int o : neighbour_bins(d.dims_, b, 1)) adjncy.push_back(o);  // face/edge/corner graph
      xadj.push_back(idx_t(adjncy.size()));
      vwgt[b] = idx_t(1 + 1000 * std::llround(bin_work[b]));  // an empty bin: 0.1 % of a particle
    }
    idx_t nv = nb, ncon = 1, np = nranks, objval = 0;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 1;
    options[METIS_OPTION_CONTIG] = 0;
    std::vector<idx_t> part(nb);
    const int rc = METIS_PartGraphKway(&nv, &ncon, xadj.data(), adjncy.data(), vwgt.data(), nullptr, nullptr, &np,
                                       nullptr, nullptr, options, &objval, part.data());
    if (rc != METIS_OK) throw std::runtime_error("METIS_PartGraphKway failed with code " + std::to_string(rc));
    for (int b = 0; b < nb; ++b) d.owner_[b] = int(part[b]);
  }
  MPI_Bcast(d.owner_.data(), nb, MPI_INT, 0, comm);
  d.finish();
  return d;
}

std::vector<int> Decomposition::partners(int rank) const {
  std::vector<int> out;
  if (kind_ == DecompositionKind::Metis) {
    for (int b = 0; b < bins(); ++b)
      if (owner_[b] == rank) out.insert(out.end(), adj_ranks_[b].begin(), adj_ranks_[b].end());
  } else {  // the classes of the planes of the rank's run along each axis, combined
    const int mine[3] = {rank % grid_[0], rank / grid_[0] % grid_[1], rank / (grid_[0] * grid_[1])};
    std::array<std::vector<int>, 3> cls;
    for (int k = 0; k < 3; ++k) {
      for (int x = 0; x < dims_[k]; ++x)
        if (run_[k][x] == mine[k]) cls[k].push_back(near_[k][x]);
      std::sort(cls[k].begin(), cls[k].end());
      cls[k].erase(std::unique(cls[k].begin(), cls[k].end()), cls[k].end());
    }
    for (int c2 : cls[2])
      for (int c1 : cls[1])
        for (int c0 : cls[0]) {
          const std::vector<int>& v = adj_ranks_[c0 + near_count_[0] * (c1 + near_count_[1] * c2)];
          out.insert(out.end(), v.begin(), v.end());
        }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void Decomposition::finish() {
  const int nb = bins();
  adj_ranks_.assign(nb, {});
  for (int b = 0; b < nb; ++b) {
    for (int o : neighbour_bins(dims_, b, kReach)) {
      const int r = owner_[o];
      auto& v = adj_ranks_[b];
      if (r != owner_[b] && std::find(v.begin(), v.end(), r) == v.end()) v.push_back(r);
    }
    std::sort(adj_ranks_[b].begin(), adj_ranks_[b].end());
  }
}

}  // namespace fabrica
