// The fabric analysis (core/fabric.hpp) does not depend on the number of ranks: one snapshot of
// 60,000 contacts (normals from an anisotropic distribution, forces of a wide range, random
// sliding / rolling flags) is dealt out over the ranks in an irregular way (contact c to rank
// (c * 7919) mod P, each rank's records in reverse order) and analysed through MpiDomain; every
// number of the result must equal, bit for bit, the analysis of the whole snapshot by one
// process (SerialDomain). Registered at 1, 2 and 4 ranks.
#include "core/fabric.hpp"
#include "core/serial_domain.hpp"
#include "parallel/mpi_domain.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using namespace fabrica;

namespace {

std::vector<ContactRecord> snapshot(std::size_t n) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<ContactRecord> rec;
  while (rec.size() < n) {
    Vec3 v(g(rng), g(rng), g(rng));
    v.normalize();
    if (u(rng) * 1.6 > 1 + 0.6 * (v[0] * v[0] - 1.0 / 3)) continue;  // more contacts along axis 1
    ContactRecord c;
    c.id1 = GlobalId(rec.size());
    c.id2 = c.id1 + 5;
    c.normal = v;
    c.branch = (0.01 + 0.03 * u(rng)) * v;
    c.fn = 50 * std::pow(u(rng), 2.0) * (1 + 0.8 * v[0] * v[0]);
    Vec3 t = Vec3(g(rng), g(rng), g(rng));
    t -= t.dot(v) * v;
    c.ft = 0.3 * c.fn * u(rng) * t.normalized();
    c.sliding = u(rng) < 0.25;
    c.rolling = u(rng) < 0.5;
    rec.push_back(c);
  }
  return rec;
}

// Every number of a result, in a fixed order.
std::vector<double> flatten(const FabricResult& r) {
  std::vector<double> v = {double(r.contacts), r.mean_fn, r.strong_threshold, r.p, r.q, r.q_p};
  auto put = [&](const auto& m) { v.insert(v.end(), m.data(), m.data() + m.size()); };
  put(r.stress);
  for (double x : r.q_p_star) v.push_back(x);
  for (double x : r.q_p_star_tensor) v.push_back(x);
  for (double x : r.q_p_exact) v.push_back(x);
  for (double x : r.q_p_exact_tensor) v.push_back(x);
  for (double x : r.q_p_recombined) v.push_back(x);
  for (const NetworkFabric& n : r.net) {
    v.insert(v.end(),
             {double(n.count), n.mean_fn, n.a_c, n.a_b, n.a_n, n.a_t, n.zeta, n.gamma, n.xi, n.share,
              double(n.nonpositive_weights), n.min_weight});
    for (const Mat3* m :
         {&n.phi, &n.branch, &n.normal_force, &n.tangential_force, &n.ac, &n.ab, &n.an, &n.at, &n.stress})
      put(*m);
    put(n.phi_principal);
    put(n.phi_major);
    for (auto c : n.rose12) v.push_back(double(c));
    for (auto c : n.rose23) v.push_back(double(c));
  }
  return v;
}

}  // namespace

TEST(FabricRanks, SameResultBitForBitOnAnyRankCount) {
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const std::vector<ContactRecord> all = snapshot(60000);
  std::vector<ContactRecord> mine;
  for (std::size_t c = all.size(); c-- > 0;)
    if (int((c * 7919) % std::size_t(size)) == rank) mine.push_back(all[c]);
  FabricOptions opt;
  opt.strong_ratio = 1.0;
  MpiDomain domain(MPI_COMM_WORLD);
  const FabricResult par = analyse_fabric(mine, 2.5, opt, domain);
  SerialDomain serial;
  const FabricResult ser = analyse_fabric(all, 2.5, opt, serial);
  const std::vector<double> a = flatten(par), b = flatten(ser);
  ASSERT_EQ(a.size(), b.size());
  std::size_t differ = 0, nan = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (std::isnan(b[k])) ++nan;
    if (std::memcmp(&a[k], &b[k], sizeof(double)) != 0) ++differ;
  }
  EXPECT_EQ(differ, 0u) << "of " << a.size() << " numbers";
  EXPECT_EQ(nan, 0u);  // every network is populated
  EXPECT_EQ(par.reductions, 3);
  // The populations are mixed enough for the test to mean something.
  EXPECT_GT(ser.net[kSf].count, 1000);
  EXPECT_GT(ser.net[kSR].count, 1000);
  if (rank == 0)
    std::printf(
        "[fabric ranks] %d rank(s): %zu numbers, %zu differ from the serial analysis "
        "(bitwise); q/p = %.6f, (q/p)* all %.6f\n",
        size, a.size(), differ, ser.q_p, ser.q_p_star[kPartAll]);
}
