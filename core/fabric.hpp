// Fabric of contact sub-networks (shared/spec/reference-problem.md sections 5-6; docs/fabric.md):
// classification of every contact (sliding / non-sliding, rolling / non-rolling, strong / weak),
// the 15 networks of the reference study, and per network the fabric tensor phi, the branch,
// normal-force and tangential-force tensors weighted by 1 / (1 + a^c : n n), the deviatoric
// anisotropy tensors a^c, a^b, a^n, a^t and their signed indices, the weights zeta, gamma, xi,
// the network's stress contribution and rose diagrams of its contact normals; and the
// stress-force-fabric prediction (q/p)* of each partition of the contacts next to the measured
// q/p (Wang et al. 2021, eq. 17-18; Sufian et al. 2017 for sub-networks).
//
// Collective: every rank passes its own records (each contact listed once over all ranks,
// core/contact_snapshot.hpp) and calls the reducer's sum_all three times (see analyse_fabric).
// The sums are exact (core/exact_sum.hpp), so the result is bitwise the same on any number of
// ranks and for any distribution of the records over them.
#pragma once
#include "core/contact_snapshot.hpp"
#include "core/domain.hpp"

#include <array>
#include <functional>
#include <span>
#include <string_view>
#include <vector>

namespace fabrica {

// The networks, in the order of the spec's list.
enum Network : int { kAll, kNs, kS, kR, kNr, kSf, kWf, kNsNr, kNsR, kSNr, kSR, kNsSf, kNsWf, kSSf, kSWf, kNetworks };
inline constexpr std::array<std::string_view, kNetworks> kNetworkNames = {
    "all", "ns", "s", "r", "nr", "sf", "wf", "ns-nr", "ns-r", "s-nr", "s-r", "ns-sf", "ns-wf", "s-sf", "s-wf"};

// Partitions of the contacts (each a set of disjoint networks whose union is 'all') for which
// the stress-force-fabric prediction is made. 'all' alone is the classical global relation.
enum Partition : int { kPartAll, kPartNsS, kPartSfWf, kPartNrR, kPartSlideRoll, kPartSlideForce, kPartitions };
inline constexpr std::array<std::string_view, kPartitions> kPartitionNames = {"all",  "ns_s",      "sf_wf",
                                                                              "nr_r", "ns_s_nr_r", "ns_s_sf_wf"};
std::span<const int> partition_networks(int partition);
int partition_of(int network);  // the partition a network belongs to
// The six networks contact 'c' belongs to (one per partition, in partition order); strong:
// f_n > threshold.
std::array<int, kPartitions> contact_networks(const ContactRecord& c, real_t threshold);

struct FabricOptions {
  real_t strong_ratio = 1.0;  // strong: f_n > strong_ratio * (global mean f_n)
  int rose_bins = 36;         // bins of the rose diagrams over [0, pi)
};

struct NetworkFabric {
  std::int64_t count = 0;                // N^k
  real_t mean_fn = 0;                    // N, mean normal force (NaN if empty, as every mean below)
  Mat3 phi = Mat3::Zero();               // fabric tensor (1/N^k) sum n n
  Mat3 branch = Mat3::Zero();            // b^k: (1/N^k) sum |b| n n / (1 + a^c:nn)   [m]
  Mat3 normal_force = Mat3::Zero();      // f^{n,k} [N]
  Mat3 tangential_force = Mat3::Zero();  // f^{t,k}: (1/N^k) sum f_t,i n_j / (1 + a^c:nn) [N], not symmetric
  Mat3 ac = Mat3::Zero(), ab = Mat3::Zero(), an = Mat3::Zero(), at = Mat3::Zero();  // deviatoric
  real_t a_c = 0, a_b = 0, a_n = 0, a_t = 0;  // signed indices sign(a:s) sqrt(3/2 a:a)
  real_t zeta = 0, gamma = 0, xi = 0;
  // The network's exact share of the mean stress, p_k / p = tr(stress) / tr(sigma of all): the
  // weight of network k in the exact decomposition s / p = sum_k (p_k / p) (s^k / p_k) of a
  // partition's deviatoric stress ratio (0 if empty or p = 0). xi = zeta gamma = (sum f_n over k) /
  // (sum f_n over all) is this share only if every branch had the same length, since
  // tr(f (x) b) = f_n |b| for a branch along n.
  real_t share = 0;
  Vec3 phi_principal = Vec3::Zero();     // eigenvalues of phi, descending
  Vec3 phi_major = Vec3::Zero();         // unit eigenvector of the largest (first nonzero component > 0)
  Mat3 stress = Mat3::Zero();            // (1/V) sum over the network of f (x) b [Pa]
  std::int64_t nonpositive_weights = 0;  // contacts with 1 + a^c:nn <= 0 (then b, f^n, f^t are not meaningful)
  // 1 + (smallest eigenvalue of a^c): the minimum over all directions of the second-order
  // density 4 pi E(n) = 1 + a^c:nn. Where it is <= 0 that density is negative somewhere, and the
  // weights 1 / (1 + a^c:nn) of the contacts near such directions are huge or undefined.
  real_t min_weight = 0;
  std::vector<std::int64_t> rose12, rose23;  // counts per bin of the normal's angle in the 1-2 / 2-3 plane
};

struct FabricResult {
  std::array<NetworkFabric, kNetworks> net;
  std::int64_t contacts = 0;                   // N over all ranks
  real_t mean_fn = 0;                          // N, over all contacts
  real_t strong_threshold = 0;                 // N
  Mat3 stress = Mat3::Zero();                  // Pa: (1/V) sum f (x) b over all contacts
  real_t p = 0, q = 0, q_p = 0;                // of 'stress' (q_p = 0 if p <= 0)
  std::array<real_t, kPartitions> q_p_star{};  // (2/5) sum_k xi_k (a_c + a_b + a_n + 3/2 a_t)
  // Not in the spec: the same sum taken over the tensors before the invariant,
  // sqrt(3/2 D:D) with D = (2/5) sum_k xi_k (a^c + a^b + a^n + 3/2 a^t) - the first-order
  // prediction without the assumption that the tensors are coaxial with the stress.
  std::array<real_t, kPartitions> q_p_star_tensor{};
  // The exact form (docs/fabric.md, "Each network's share of the stress"): the same two sums
  // with the weights xi_k replaced by the networks' exact shares of p, share_k = p_k / p, which is
  // what the Love-Weber decomposition sigma = sum_k sigma^k and the first-order expansion
  // sigma^k = p_k (I + (2/5) (a^c + a^b + a^n + 3/2 a^t)) give:
  //   q_p_exact = (2/5) sum_k share_k (a_c + a_b + a_n + 3/2 a_t),
  //   q_p_exact_tensor = sqrt(3/2 D:D), D = (2/5) sum_k share_k (a^c + a^b + a^n + 3/2 a^t).
  std::array<real_t, kPartitions> q_p_exact{};
  std::array<real_t, kPartitions> q_p_exact_tensor{};
  // The networks' measured stress ratios recombined as the scalar form combines its terms:
  // sum_k share_k sign(s^k : s) q_k / p_k. Were every network's SFF relation exact
  // ((2/5)(a_c + a_b + a_n + 3/2 a_t) = q_k / p_k), q_p_exact would be this; it differs from q/p
  // only where the networks' deviatoric stresses are not coaxial with s (for 'all' it is q/p).
  std::array<real_t, kPartitions> q_p_recombined{};
  int rose_bins = 0;
  int reductions = 0;  // collective sums made (3)
};

// Classifies this rank's records and reduces over the ranks of 'reducer':
//   1. sum_all: the number of contacts and the sum of f_n (the strong/weak threshold);
//   2. sum_all: per network the count, sum f_n, sum n n, sum f (x) b and the rose counts
//      (phi, hence a^c, of every network);
//   3. sum_all: per network the sums weighted by 1 / (1 + a^c:nn) (b^k, f^n, f^t).
// Each sum needs the previous one's result, hence three collectives per analysis (every rank
// calls all three, whatever its records). 'volume' is the cell volume [m^3].
FabricResult analyse_fabric(std::span<const ContactRecord> records, real_t volume, const FabricOptions& options,
                            Domain& reducer);
// The records visited rather than held: 'visit' calls its argument once per record of this
// rank, in the same order at each call; it is called three times (once per pass above). A run
// passes for_each_contact_record over its pair list, so that a fabric row at 10^6 spheres does not
// hold a 128-byte record per contact (138 MB at 869,376 spheres, above the run's own peak).
using ContactVisitor = std::function<void(const ContactRecord&)>;
FabricResult analyse_fabric(const std::function<void(const ContactVisitor&)>& visit, real_t volume,
                            const FabricOptions& options, Domain& reducer);

// sign(a:s) sqrt(3/2 a:a), with s the deviatoric stress (sign + if a:s = 0).
real_t signed_index(const Mat3& a, const Mat3& s);

}  // namespace fabrica
