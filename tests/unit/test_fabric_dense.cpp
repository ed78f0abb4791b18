// The exact stress shares of the contact sub-networks on the shared dense-13584 packing
// (13,584 spheres, benchmarks/dense-13584.toml: mu_s = 0.3, mu_r = 0.05; the contact forces
// after 200 steps, as benchmarks/bench_fabric.cpp, so that sliding and rolling contacts exist;
// docs/fabric.md "Each network's share of the stress").
// Required, for each of the six partitions: the networks' stresses sigma^k = (1/V) sum over k of
// f (x) b add up to the Love-Weber stress of all the contacts (1e-12 of max |sigma_ij|), their
// p_k to p (1e-12 relative), the q of their sum to q (1e-12 of p), their shares p_k / p to 1
// (1e-12); every network of the sub-network partitions is populated (so each sum has terms).
#include "core/contact_snapshot.hpp"
#include "core/fabric.hpp"
#include "core/measures.hpp"
#include "core/serial_domain.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace fabrica {
namespace {

TEST(FabricDense, StressSharesAddUpToTheLoveWeberStress) {
  Scene scene = load_scene(std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml");
  ASSERT_EQ(scene.law.friction, 0.3);
  ASSERT_EQ(scene.law.rolling_friction, 0.05);
  fabrica::Setup setup = make_setup(scene);
  Simulation sim(setup.particles, setup.cell, setup.params);
  const int steps = 200;
  for (int k = 0; k < steps; ++k) sim.step(k == steps - 1);
  const auto rec = contact_records(sim.particles(), sim.cell(), sim.params().law, sim.pairs());
  ASSERT_GT(rec.size(), 10000u);
  SerialDomain serial;
  const FabricResult r = analyse_fabric(rec, sim.cell().volume(), FabricOptions{}, serial);
  ASSERT_GT(r.p, 0);
  const double scale = r.stress.cwiseAbs().maxCoeff();
  double worst_sigma = 0, worst_p = 0, worst_q = 0, worst_share = 0;
  for (int p = 0; p < kPartitions; ++p) {
    Mat3 sum = Mat3::Zero();
    double p_sum = 0, share = 0;
    for (int k : partition_networks(p)) {
      const NetworkFabric& nf = r.net[k];
      EXPECT_GT(nf.count, 0) << kNetworkNames[k];
      real_t pk = 0, qk = 0;
      deviatoric_invariants(nf.stress, pk, qk);
      sum += nf.stress;
      p_sum += pk;
      share += nf.share;
    }
    real_t ps = 0, qs = 0;
    deviatoric_invariants(sum, ps, qs);
    const double e_sigma = (sum - r.stress).cwiseAbs().maxCoeff() / scale;
    const double e_p = std::abs(p_sum - r.p) / r.p, e_q = std::abs(qs - r.q) / r.p;
    const double e_share = std::abs(share - 1.0);
    EXPECT_LT(e_sigma, 1e-12) << kPartitionNames[p];
    EXPECT_LT(e_p, 1e-12) << kPartitionNames[p];
    EXPECT_LT(e_q, 1e-12) << kPartitionNames[p];
    EXPECT_LT(e_share, 1e-12) << kPartitionNames[p];
    worst_sigma = std::max(worst_sigma, e_sigma), worst_p = std::max(worst_p, e_p);
    worst_q = std::max(worst_q, e_q), worst_share = std::max(worst_share, e_share);
  }
  std::printf(
      "[fabric dense-13584] %zu contacts, p = %.1f Pa, q/p = %.4f; over the six partitions the networks' "
      "stresses add up to sigma within %.1e of max |sigma_ij|, p_k to p within %.1e, q within %.1e of p, "
      "shares to 1 within %.1e\n",
      rec.size(), r.p, r.q_p, worst_sigma, worst_p, worst_q, worst_share);
  for (int k : partition_networks(kPartSlideForce))
    std::printf("[fabric dense-13584] %-6s %5lld contacts: xi %.4f, share of p %.4f\n",
                std::string(kNetworkNames[k]).c_str(), (long long)r.net[k].count, r.net[k].xi, r.net[k].share);
}

}  // namespace
}  // namespace fabrica
