#include "core/fabric.hpp"

#include "core/exact_sum.hpp"
#include "core/measures.hpp"

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <numbers>

namespace fabrica {

namespace {

constexpr real_t kNaN = std::numeric_limits<real_t>::quiet_NaN();

constexpr int kPartAllNets[] = {kAll};
constexpr int kPartNsSNets[] = {kNs, kS};
constexpr int kPartSfWfNets[] = {kSf, kWf};
constexpr int kPartNrRNets[] = {kNr, kR};
constexpr int kPartSlideRollNets[] = {kNsNr, kNsR, kSNr, kSR};
constexpr int kPartSlideForceNets[] = {kNsSf, kNsWf, kSSf, kSWf};

}  // namespace

std::array<int, kPartitions> contact_networks(const ContactRecord& c, real_t threshold) {
  const bool s = c.sliding, r = c.rolling, strong = c.fn > threshold;
  return {kAll,
          s ? kS : kNs,
          strong ? kSf : kWf,
          r ? kR : kNr,
          s ? (r ? kSR : kSNr) : (r ? kNsR : kNsNr),
          s ? (strong ? kSSf : kSWf) : (strong ? kNsSf : kNsWf)};
}

namespace {

// Symmetric tensor components in the order of the sums: 00, 11, 22, 01, 12, 02.
constexpr int kSymI[6] = {0, 1, 2, 0, 1, 0};
constexpr int kSymJ[6] = {0, 1, 2, 1, 2, 2};

Mat3 sym_from(const ExactSums& s, std::size_t first, real_t scale) {
  Mat3 m;
  for (int k = 0; k < 6; ++k) m(kSymI[k], kSymJ[k]) = m(kSymJ[k], kSymI[k]) = s.value(first + k) * scale;
  return m;
}
Mat3 full_from(const ExactSums& s, std::size_t first, real_t scale) {
  Mat3 m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = s.value(first + 3 * i + j) * scale;
  return m;
}
Mat3 dev(const Mat3& m) { return m - m.trace() / 3.0 * Mat3::Identity(); }

int rose_bin(real_t y, real_t x, int bins) {
  real_t t = std::atan2(y, x);  // (-pi, pi]
  if (t < 0) t += std::numbers::pi;
  const int b = int(t / std::numbers::pi * bins);
  return b < 0 ? 0 : (b >= bins ? bins - 1 : b);
}

}  // namespace

std::span<const int> partition_networks(int partition) {
  switch (partition) {
    case kPartAll:
      return kPartAllNets;
    case kPartNsS:
      return kPartNsSNets;
    case kPartSfWf:
      return kPartSfWfNets;
    case kPartNrR:
      return kPartNrRNets;
    case kPartSlideRoll:
      return kPartSlideRollNets;
    default:
      return kPartSlideForceNets;
  }
}

int partition_of(int network) {
  for (int p = 0; p < kPartitions; ++p)
    for (int k : partition_networks(p))
      if (k == network) return p;
  return -1;
}

real_t signed_index(const Mat3& a, const Mat3& s) {
  const real_t mag = std::sqrt(1.5 * a.cwiseProduct(a).sum());
  return a.cwiseProduct(s).sum() < 0 ? -mag : mag;
}

FabricResult analyse_fabric(std::span<const ContactRecord> records, real_t volume, const FabricOptions& options,
                            Domain& reducer) {
  return analyse_fabric(
      [records](const ContactVisitor& fn) {
        for (const ContactRecord& c : records) fn(c);
      },
      volume, options, reducer);
}

FabricResult analyse_fabric(const std::function<void(const ContactVisitor&)>& visit, real_t volume,
                            const FabricOptions& options, Domain& reducer) {
  FabricResult out;
  const int B = options.rose_bins;
  out.rose_bins = B;

  // 1. The global mean normal force.
  {
    ExactSums s(1);
    std::int64_t n = 0;
    visit([&](const ContactRecord& c) {
      s.add(0, c.fn);
      ++n;
    });
    s.normalize();
    std::vector<std::int64_t> buf(s.words().begin(), s.words().end());
    buf.push_back(n);
    reducer.sum_all(std::span<std::int64_t>(buf));
    ++out.reductions;
    std::copy(buf.begin(), buf.end() - 1, s.words().begin());
    s.normalize();
    out.contacts = buf.back();
    out.mean_fn = out.contacts > 0 ? s.value(0) / real_t(out.contacts) : kNaN;
    out.strong_threshold = options.strong_ratio * (out.contacts > 0 ? out.mean_fn : 0.0);
  }
  const real_t threshold = out.strong_threshold;

  // 2. Per network: count, sum f_n, sum n n, sum f (x) b (exact); rose counts (integers).
  constexpr int kFn = 0, kNn = 1, kFb = 7, kSlots2 = 16;
  const std::size_t ints2 = std::size_t(kNetworks) * (1 + 2 * B);
  {
    ExactSums s(std::size_t(kNetworks) * kSlots2);
    std::vector<std::int64_t> counts(ints2, 0);
    visit([&](const ContactRecord& c) {
      const Vec3& n = c.normal;
      const Vec3 f = c.force();
      const int b12 = rose_bin(n[1], n[0], B), b23 = rose_bin(n[2], n[1], B);
      for (int k : contact_networks(c, threshold)) {
        const std::size_t base = std::size_t(k) * kSlots2;
        s.add(base + kFn, c.fn);
        for (int m = 0; m < 6; ++m) s.add(base + kNn + m, n[kSymI[m]] * n[kSymJ[m]]);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) s.add(base + kFb + 3 * i + j, f[i] * c.branch[j]);
        std::int64_t* ck = counts.data() + std::size_t(k) * (1 + 2 * B);
        ck[0] += 1;
        ck[1 + b12] += 1;
        ck[1 + B + b23] += 1;
      }
    });
    s.normalize();
    std::vector<std::int64_t> buf(s.words().begin(), s.words().end());
    buf.insert(buf.end(), counts.begin(), counts.end());
    reducer.sum_all(std::span<std::int64_t>(buf));
    ++out.reductions;
    std::copy(buf.begin(), buf.begin() + std::ptrdiff_t(s.words().size()), s.words().begin());
    s.normalize();
    const std::int64_t* cnt = buf.data() + s.words().size();
    for (int k = 0; k < kNetworks; ++k) {
      NetworkFabric& nf = out.net[k];
      const std::int64_t* ck = cnt + std::size_t(k) * (1 + 2 * B);
      nf.count = ck[0];
      nf.rose12.assign(ck + 1, ck + 1 + B);
      nf.rose23.assign(ck + 1 + B, ck + 1 + 2 * B);
      const std::size_t base = std::size_t(k) * kSlots2;
      nf.stress = full_from(s, base + kFb, 1.0 / volume);
      if (nf.count == 0) {
        nf.mean_fn = kNaN;
        nf.phi = nf.ac = Mat3::Constant(kNaN);
        continue;
      }
      const real_t inv = 1.0 / real_t(nf.count);
      nf.mean_fn = s.value(base + kFn) * inv;
      nf.phi = sym_from(s, base + kNn, inv);
      nf.ac = 7.5 * dev(nf.phi);
    }
  }

  // 3. Per network, the sums weighted by 1 / (1 + a^c:nn).
  constexpr int kB = 0, kFnn = 6, kFt = 12, kSlots3 = 21;
  {
    ExactSums s(std::size_t(kNetworks) * kSlots3);
    std::vector<std::int64_t> bad(kNetworks, 0);
    visit([&](const ContactRecord& c) {
      const Vec3& n = c.normal;
      const real_t len = c.branch.norm();
      for (int k : contact_networks(c, threshold)) {
        const real_t w = 1.0 + n.dot(out.net[k].ac * n);
        if (!(w > 0)) {
          ++bad[k];
          continue;
        }
        const real_t iw = 1.0 / w;
        const std::size_t base = std::size_t(k) * kSlots3;
        for (int m = 0; m < 6; ++m) {
          const real_t nn = n[kSymI[m]] * n[kSymJ[m]] * iw;
          s.add(base + kB + m, len * nn);
          s.add(base + kFnn + m, c.fn * nn);
        }
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) s.add(base + kFt + 3 * i + j, c.ft[i] * n[j] * iw);
      }
    });
    s.normalize();
    std::vector<std::int64_t> buf(s.words().begin(), s.words().end());
    buf.insert(buf.end(), bad.begin(), bad.end());
    reducer.sum_all(std::span<std::int64_t>(buf));
    ++out.reductions;
    std::copy(buf.begin(), buf.begin() + std::ptrdiff_t(s.words().size()), s.words().begin());
    s.normalize();
    for (int k = 0; k < kNetworks; ++k) {
      NetworkFabric& nf = out.net[k];
      nf.nonpositive_weights = buf[s.words().size() + std::size_t(k)];
      if (nf.count == 0) {
        nf.branch = nf.normal_force = nf.tangential_force = Mat3::Constant(kNaN);
        continue;
      }
      const real_t inv = 1.0 / real_t(nf.count);
      const std::size_t base = std::size_t(k) * kSlots3;
      nf.branch = sym_from(s, base + kB, inv);
      nf.normal_force = sym_from(s, base + kFnn, inv);
      nf.tangential_force = full_from(s, base + kFt, inv);
    }
  }

  // Derived quantities (identical arithmetic on every rank).
  out.stress = out.net[kAll].stress;
  deviatoric_invariants(out.stress, out.p, out.q);
  out.q_p = out.p > 0 ? out.q / out.p : 0.0;
  const Mat3 sdev = dev(out.stress);
  for (int k = 0; k < kNetworks; ++k) {
    NetworkFabric& nf = out.net[k];
    if (nf.count == 0) {
      nf.ab = nf.an = nf.at = Mat3::Constant(kNaN);
      nf.a_c = nf.a_b = nf.a_n = nf.a_t = nf.gamma = nf.min_weight = kNaN;
      nf.phi_principal = nf.phi_major = Vec3::Constant(kNaN);
      continue;
    }
    const real_t b0 = nf.branch.trace(), f0 = nf.normal_force.trace();
    nf.ab = 7.5 / b0 * dev(nf.branch);
    nf.an = 7.5 / f0 * dev(nf.normal_force);
    const Mat3 ft_sym = 0.5 * (nf.tangential_force + nf.tangential_force.transpose());
    nf.at = 5.0 / f0 * dev(ft_sym);
    nf.a_c = signed_index(nf.ac, sdev);
    nf.a_b = signed_index(nf.ab, sdev);
    nf.a_n = signed_index(nf.an, sdev);
    nf.a_t = signed_index(nf.at, sdev);
    nf.zeta = real_t(nf.count) / real_t(out.contacts);
    nf.gamma = nf.mean_fn / out.mean_fn;
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(nf.phi);
    nf.phi_principal = eig.eigenvalues().reverse();
    // a^c = 15/2 dev(phi) has the eigenvectors of phi: its smallest eigenvalue from phi's.
    nf.min_weight = 1.0 + 7.5 * (eig.eigenvalues()[0] - nf.phi.trace() / 3.0);
    Vec3 v = eig.eigenvectors().col(2);
    for (int i = 0; i < 3; ++i)
      if (v[i] != 0) {
        if (v[i] < 0) v = -v;
        break;
      }
    nf.phi_major = v;
  }
  // The exact shares of p and the networks' signed stress ratios (derived from the exact sums
  // of pass 2, so rank-independent like everything above).
  std::array<real_t, kNetworks> q_p_k{};
  for (int k = 0; k < kNetworks; ++k) {
    NetworkFabric& nf = out.net[k];
    real_t pk = 0, qk = 0;
    deviatoric_invariants(nf.stress, pk, qk);
    nf.share = nf.count > 0 && out.p > 0 ? pk / out.p : 0.0;
    q_p_k[k] = nf.count > 0 && pk > 0 ? (dev(nf.stress).cwiseProduct(sdev).sum() < 0 ? -qk : qk) / pk : 0.0;
  }
  for (int p = 0; p < kPartitions; ++p) {
    real_t norm = 0;
    for (int k : partition_networks(p)) norm += out.net[k].zeta * (out.net[k].count ? out.net[k].gamma : 0.0);
    real_t sum = 0, sum_exact = 0, recombined = 0;
    Mat3 D = Mat3::Zero(), D_exact = Mat3::Zero();
    for (int k : partition_networks(p)) {
      NetworkFabric& nf = out.net[k];
      nf.xi = nf.count > 0 && norm > 0 ? nf.zeta * nf.gamma / norm : 0.0;
      if (nf.count == 0) continue;
      const real_t index = nf.a_c + nf.a_b + nf.a_n + 1.5 * nf.a_t;
      const Mat3 tensor = nf.ac + nf.ab + nf.an + 1.5 * nf.at;
      sum += nf.xi * index;
      D += 0.4 * nf.xi * tensor;
      sum_exact += nf.share * index;
      D_exact += 0.4 * nf.share * tensor;
      recombined += nf.share * q_p_k[k];
    }
    out.q_p_star[p] = 0.4 * sum;
    out.q_p_star_tensor[p] = std::sqrt(1.5 * D.cwiseProduct(D).sum());
    out.q_p_exact[p] = 0.4 * sum_exact;
    out.q_p_exact_tensor[p] = std::sqrt(1.5 * D_exact.cwiseProduct(D_exact).sum());
    out.q_p_recombined[p] = recombined;
  }
  return out;
}

}  // namespace fabrica
