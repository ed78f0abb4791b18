// The SIMD contact kernel (core/simd.hpp, core/contact_law.hpp, core/forces.cpp) against the
// one-lane kernel (docs/verification.md section 11): four contacts evaluated at once must give
// the same bits as one at a time, lane for lane, for every branch of the law (Coulomb and
// rolling caps, zero springs, dashpot cut-off), and a whole run must be the same bit for bit:
//  - contact_law_l over simd::d4 against contact_law_l over double on random contacts, in
//    every combination of rolling resistance and dashpots: every output equal (== on doubles);
//  - a dense polydisperse packing with random velocities and spins, stepped 400 steps with
//    kernel_lanes = 1 and = 4 (measuring every 50 steps, a deforming cell): every
//    position, velocity, spin, shear and rolling spring, touching flag, energy book and
//    measured sum equal bit for bit, for each law variant, and with everything fetched ahead
//    of each contact or only the first lines (SimulationParams::fetch_ahead).
#include "core/contact_law.hpp"
#include "core/generate.hpp"
#include "core/timestep.hpp"
#include "scene_helpers.hpp"

#include <gtest/gtest.h>

#include <bit>

#include <cmath>
#include <string>
#include <cstdio>
#include <numbers>
#include <random>

namespace fabrica {
namespace {

using simd::d4;

// Random contacts (n, un, vrel, w1, w2, springs) with a quarter of the springs zero and a mix
// of capped and free springs; the constants of a sphere pair of random radii and masses.
template <bool Rolling, bool Viscous>
void law_lanes_case(const char* label) {
  std::mt19937_64 g(7);
  std::uniform_real_distribution<real_t> u(-1.0, 1.0);
  ContactLawParams p;
  p.youngs_modulus = 70e6;
  p.stiffness_ratio = 1.5;
  p.friction = 0.35;
  p.rolling_friction = Rolling ? 0.12 : 0.0;
  if (Viscous) p.damping_ratio_n = 0.4, p.damping_ratio_s = 0.25, p.damping_rate_n = 30.0;
  const real_t dt = 2e-6;
  int capped = 0, rcapped = 0, free_ = 0, cut = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    PairConstantsL<real_t> c1[4];
    ContactKinematicsL<real_t> k1[4];
    ContactHistoryL<real_t> h1[4];
    for (int l = 0; l < 4; ++l) {
      const real_t R1 = 0.005 * (1.5 + u(g)), R2 = 0.005 * (1.5 + u(g));
      const PairConstants c = pair_constants<Rolling, Viscous>(p, R1, R2, 1e-3 * (1.2 + u(g)), 1e-3 * (1.2 + u(g)));
      c1[l] = {c.kn, c.ks, c.kr, c.cn, c.cs, c.rbar};
      Vec3 n(u(g), u(g), u(g));
      n.normalize();
      const real_t un = 1e-5 * (1.0 + u(g));
      const real_t scale = std::pow(10.0, 2 * u(g));  // from deep stick to sliding
      k1[l] = {simd::from_vec(n),
               un,
               simd::from_vec(0.1 * scale * Vec3(u(g), u(g), u(g))),
               simd::from_vec(30.0 * scale * Vec3(u(g), u(g), u(g))),
               simd::from_vec(30.0 * scale * Vec3(u(g), u(g), u(g))),
               un};
      const bool zero = (g() & 3) == 0;
      const real_t fcap = p.friction * c.kn * un;
      const Vec3 fs = zero ? Vec3::Zero() : Vec3(fcap * 1.2 * Vec3(u(g), u(g), u(g)));
      const Vec3 mr = zero ? Vec3::Zero() : Vec3(p.rolling_friction * c.rbar * fcap * 1.2 * Vec3(u(g), u(g), u(g)));
      h1[l] = {simd::from_vec(fs), simd::from_vec(mr)};
    }
    // The same contacts in four lanes.
    auto pack = [](auto get) { return d4{get(0), get(1), get(2), get(3)}; };
    auto pack3 = [&](auto get) {
      return simd::V3<d4>{pack([&](int l) { return get(l).x; }), pack([&](int l) { return get(l).y; }),
                          pack([&](int l) { return get(l).z; })};
    };
    const PairConstantsL<d4> c4{pack([&](int l) { return c1[l].kn; }), pack([&](int l) { return c1[l].ks; }),
                                pack([&](int l) { return c1[l].kr; }), pack([&](int l) { return c1[l].cn; }),
                                pack([&](int l) { return c1[l].cs; }), pack([&](int l) { return c1[l].rbar; }),
                                pack([&](int l) { return c1[l].ir; })};
    const ContactKinematicsL<d4> k4{
        pack3([&](int l) { return k1[l].n; }),    pack([&](int l) { return k1[l].un; }),
        pack3([&](int l) { return k1[l].vrel; }), pack3([&](int l) { return k1[l].w1; }),
        pack3([&](int l) { return k1[l].w2; }),   pack([&](int l) { return k1[l].un_prev; })};
    ContactHistoryL<d4> h4{pack3([&](int l) { return h1[l].fs; }), pack3([&](int l) { return h1[l].mr; })};
    const ContactResultL<d4> r4 = contact_law_l<Rolling, Viscous>(p, c4, k4, h4, dt);
    for (int l = 0; l < 4; ++l) {
      const ContactResultL<real_t> r1 = contact_law_l<Rolling, Viscous>(p, c1[l], k1[l], h1[l], dt);
      auto same3 = [&](const simd::V3<real_t>& a, const simd::V3<d4>& b) {
        return a.x == b.x[l] && a.y == b.y[l] && a.z == b.z[l];
      };
      ASSERT_EQ(r1.fn, r4.fn[l]) << label << " trial " << trial << " lane " << l;
      ASSERT_TRUE(same3(r1.fs, r4.fs)) << label << " trial " << trial << " lane " << l;
      ASSERT_TRUE(same3(r1.mr, r4.mr)) << label << " trial " << trial << " lane " << l;
      ASSERT_TRUE(same3(h1[l].fs, h4.fs)) << label << " trial " << trial << " lane " << l;
      if (Rolling) ASSERT_TRUE(same3(h1[l].mr, h4.mr)) << label << " trial " << trial << " lane " << l;
      ASSERT_EQ(r1.sliding, simd::lane(r4.sliding, l));
      ASSERT_EQ(r1.rolling, simd::lane(r4.rolling, l));
      ASSERT_EQ(r1.e_friction, r4.e_friction[l]);
      ASSERT_EQ(r1.e_rolling, r4.e_rolling[l]);
      ASSERT_EQ(r1.e_viscous, r4.e_viscous[l]);
      capped += r1.e_friction != 0;
      rcapped += r1.e_rolling != 0;
      free_ += r1.e_friction == 0;
      cut += Viscous && r1.fn == 0;
    }
  }
  std::printf(
      "[law lanes] %s: 16000 contacts, %d capped, %d free, %d rolling capped, %d with "
      "the dashpot cut-off\n",
      label, capped, free_, rcapped, cut);
  // Every branch was taken on some lanes and not on others.
  EXPECT_GT(capped, 1000);
  EXPECT_GT(free_, 1000);
  if (Rolling) EXPECT_GT(rcapped, 1000);
  if (Viscous) EXPECT_GT(cut, 100);
}

TEST(ForcesSimd, LawLanesBitwise) {
  law_lanes_case<false, false>("no rolling, no dashpots");
  law_lanes_case<false, true>("dashpots");
  law_lanes_case<true, false>("rolling");
  law_lanes_case<true, true>("rolling and dashpots");
}

Vec3 random_vec(Random& rng) { return Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 2.0; }

// As tests/unit/test_conservation.cpp: n fractal diameters at solid fraction phi0, shrunk by s
// per axis (overlaps), random velocities and spins.
Simulation dense_sim(const ContactLawParams& law, int lanes, int fetch_ahead = -1) {
  Random rng(5);
  std::vector<real_t> d = fractal_diameters(400, 1.9, 0.01, 0.05, rng);
  real_t vs = 0;
  for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
  const real_t L = std::cbrt(vs / 0.4);
  const PeriodicCell big(Vec3(L, 0.9 * L, 1.1 * L));
  Particles p = random_packing(d, test::kRho, big, rng);
  const PeriodicCell cell(big.lengths() * 0.85);
  for (std::size_t a = 0; a < p.size(); ++a) {
    p.x[a] = cell.wrap(p.x[a] * 0.85);
    p.v[a] = 0.5 * random_vec(rng);
    p.w[a] = 0.5 / 0.01 * random_vec(rng);
  }
  SimulationParams sp;
  sp.law = law;
  sp.skin = 0.002;
  sp.dt = 0.3 * critical_time_step(p, law, false);
  sp.kernel_lanes = lanes;
  sp.fetch_ahead = fetch_ahead;
  Simulation sim(std::move(p), cell, sp);
  sim.cell().set_strain_rate(Vec3(-0.02, 0.01, 0.01) / (400 * sp.dt));
  return sim;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a == b;  // element-wise ==: doubles compare by value (no NaN arises here)
}

// fetch1 and fetch4: what each run's force loop fetches ahead (SimulationParams::fetch_ahead).
void run_case(const ContactLawParams& law, const char* label, int fetch1 = -1, int fetch4 = -1) {
  Simulation s1 = dense_sim(law, 1, fetch1), s4 = dense_sim(law, 4, fetch4);
  std::int64_t max_contacts = 0, max_sliding = 0, min_rolling = 1 << 30;
  for (int k = 1; k <= 400; ++k) {
    const bool measure = k % 50 == 0;
    s1.step(measure);
    s4.step(measure);
    if (measure) {
      const MacroState &m1 = s1.macro(), &m4 = s4.macro();
      ASSERT_EQ(m1.contacts, m4.contacts) << label << " step " << k;
      ASSERT_EQ(m1.sliding, m4.sliding) << label << " step " << k;
      ASSERT_EQ(m1.rolling, m4.rolling) << label << " step " << k;
      ASSERT_TRUE(m1.stress == m4.stress) << label << " step " << k;
      ASSERT_EQ(m1.e_normal, m4.e_normal) << label << " step " << k;
      ASSERT_EQ(m1.e_shear, m4.e_shear) << label << " step " << k;
      ASSERT_EQ(m1.e_rolling, m4.e_rolling) << label << " step " << k;
      ASSERT_EQ(m1.kinetic, m4.kinetic) << label << " step " << k;
      max_contacts = std::max(max_contacts, m1.contacts);
      max_sliding = std::max(max_sliding, m1.sliding);
      min_rolling = std::min(min_rolling, m1.rolling);
    }
  }
  const Particles &p1 = s1.particles(), &p4 = s4.particles();
  EXPECT_TRUE(p1.id == p4.id) << label;
  EXPECT_TRUE(same_bits(p1.x, p4.x)) << label;
  EXPECT_TRUE(same_bits(p1.v, p4.v)) << label;
  EXPECT_TRUE(same_bits(p1.w, p4.w)) << label;
  EXPECT_TRUE(same_bits(p1.f, p4.f)) << label;
  EXPECT_TRUE(same_bits(p1.t, p4.t)) << label;
  const PairList &l1 = s1.pairs(), &l4 = s4.pairs();
  EXPECT_TRUE(l1.i == l4.i && l1.j == l4.j && l1.touching == l4.touching) << label;
  // The springs of every list pair, wherever the pools keep them.
  auto springs = [](const PairList& l, bool rolling) {
    std::vector<Vec3> s(l.size());
    for (std::size_t q = 0; q < l.size(); ++q) s[q] = rolling ? l.rolling_spring(q) : l.shear_spring(q);
    return s;
  };
  EXPECT_TRUE(same_bits(springs(l1, false), springs(l4, false))) << label;
  EXPECT_TRUE(same_bits(springs(l1, true), springs(l4, true))) << label;
  for (std::size_t q = 0; q < l1.size(); ++q)
    EXPECT_EQ(std::bit_cast<std::uint64_t>(l1.twisting_spring(q)), std::bit_cast<std::uint64_t>(l4.twisting_spring(q)))
        << label << " twisting spring of pair " << q;
  const MacroState &m1 = s1.macro(), &m4 = s4.macro();
  EXPECT_EQ(m1.dissipated.friction, m4.dissipated.friction) << label;
  EXPECT_EQ(m1.dissipated.rolling, m4.dissipated.rolling) << label;
  EXPECT_EQ(m1.dissipated.viscous, m4.dissipated.viscous) << label;
  EXPECT_EQ(s1.rebuild_count(), s4.rebuild_count()) << label;
  std::printf(
      "[lanes 1 vs 4] %s: up to %lld contacts, up to %lld sliding, at least %lld rolling; "
      "%lld rebuilds; dissipated friction %.3e rolling %.3e viscous %.3e J: bitwise equal\n",
      label, (long long)max_contacts, (long long)max_sliding, (long long)min_rolling, (long long)s1.rebuild_count(),
      m1.dissipated.friction, m1.dissipated.rolling, m1.dissipated.viscous);
  // The scene exercised what it claims to.
  EXPECT_GT(max_contacts, 400) << label;
  EXPECT_GT(max_sliding, 10) << label;
  EXPECT_GT(m1.dissipated.friction, 0.0) << label;
  EXPECT_GT(s1.rebuild_count(), 1) << label;
  if (law.rolling()) {
    EXPECT_GT(m1.dissipated.rolling, 0.0) << label;
    EXPECT_TRUE(l1.rolling) << label;
    EXPECT_EQ(l1.spring_mr.size(), l1.spring_fs.size()) << label;
  } else {
    EXPECT_TRUE(!l1.rolling && l1.spring_mr.empty()) << label;  // mu_r = 0: no rolling springs at all
  }
  if (law.twisting()) {
    EXPECT_TRUE(l1.twisting && l1.spring_mt.size() == l1.spring_fs.size()) << label;
    real_t largest = 0;  // the twisting springs are loaded
    for (std::size_t q = 0; q < l1.size(); ++q) largest = std::max(largest, std::abs(l1.twisting_spring(q)));
    EXPECT_GT(largest, 0.0) << label;
  } else {
    EXPECT_TRUE(!l1.twisting && l1.spring_mt.empty()) << label;  // mu_t = 0: no twisting springs
  }
  if (law.viscous()) EXPECT_GT(m1.dissipated.viscous, 0.0) << label;
}

ContactLawParams law_of(bool rolling, bool viscous) {
  ContactLawParams law;
  law.youngs_modulus = 100e6;
  law.friction = 0.3;
  law.rolling_friction = rolling ? 0.1 : 0.0;
  if (viscous) law.damping_ratio_n = 0.3, law.damping_ratio_s = 0.2;
  return law;
}

TEST(ForcesSimd, RunBitwiseRollingViscous) { run_case(law_of(true, true), "rolling and dashpots"); }
TEST(ForcesSimd, RunBitwiseRolling) { run_case(law_of(true, false), "rolling"); }
TEST(ForcesSimd, RunBitwiseViscous) { run_case(law_of(false, true), "dashpots"); }
TEST(ForcesSimd, RunBitwisePlain) { run_case(law_of(false, false), "no rolling, no dashpots"); }
// What the loop fetches ahead of each contact changes no bit: this packing of 400 spheres is
// too small for the loop to fetch everything by itself (core/forces.cpp, fetch_all_ahead), so
// it is forced, in each kernel against the other without.
TEST(ForcesSimd, RunBitwiseFetchingAhead) {
  run_case(law_of(true, true), "rolling and dashpots, lanes 4 fetching everything ahead", 0, 1);
  run_case(law_of(true, true), "rolling and dashpots, lanes 1 fetching everything ahead", 1, 0);
}
TEST(ForcesSimd, RunBitwiseDirectStiffness) {
  ContactLawParams law = test::direct_law(2e5, 0.4, 0.05, 1.25);
  law.damping_rate_n = 50.0;
  run_case(law, "direct stiffness, rolling, mass-proportional dashpot");
}

// Each contact and rolling model through the same loop, 1 and 4 lanes bitwise (the model's one
// lane-generic source, core/contact/): the rolling models with the linear law and dashpots, and
// Hertz-Mindlin (whose kernel also computes the previous overlap) with each rolling model.
TEST(ForcesSimd, RunBitwiseEveryModel) {
  for (RollingModel rm : {RollingModel::Epsd, RollingModel::ConstantTorque}) {
    ContactLawParams law = law_of(true, true);
    law.rolling_model = rm;
    law.rolling_damping = 0.3;
    run_case(law, rolling_model_name(rm));
  }
  for (RollingModel rm : {RollingModel::ElasticPlastic, RollingModel::Epsd, RollingModel::ConstantTorque}) {
    ContactLawParams law = law_of(true, true);
    law.model = ContactModel::HertzMindlin;
    law.youngs_modulus = 1e8;
    law.poisson_ratio = 0.3;
    law.damping_rate_n = law.damping_rate_s = 0;
    law.damping_ratio_n = law.damping_ratio_s = 0.1;
    law.rolling_model = rm;
    law.rolling_damping = 0.3;
    run_case(law, (std::string("Hertz-Mindlin, ") + rolling_model_name(rm)).c_str());
  }
  // Twisting resistance, with and without rolling resistance, with either model.
  for (bool hertz : {false, true})
    for (bool rolling : {false, true}) {
      ContactLawParams law = law_of(rolling, true);
      law.twisting_friction = 0.05;
      if (hertz) {
        law.model = ContactModel::HertzMindlin;
        law.youngs_modulus = 1e8;
        law.poisson_ratio = 0.3;
        law.damping_rate_n = law.damping_rate_s = 0;
        law.damping_ratio_n = law.damping_ratio_s = 0.1;
      }
      run_case(
          law,
          (std::string(hertz ? "Hertz-Mindlin" : "linear") + ", twisting" + (rolling ? " and rolling" : ", no rolling"))
              .c_str());
    }
}

// The springs live in pools by slot (core/contact_list.hpp): a slot given back is handed out
// again with zero springs, and a pair that does not touch reads zero springs.
TEST(ForcesSimd, SpringSlotIsReusedZeroed) {
  PairList pl;
  pl.i = {0, 0};
  pl.j = {1, 2};
  pl.image = {kNoImage, kNoImage};
  pl.rolling = true;
  pl.reset_springs(0);
  pl.take_slot(0);
  pl.touching[0] = 1;
  pl.spring_fs[pl.slot[0]] = Vec3(1, 2, 3);
  pl.spring_mr[pl.slot[0]] = Vec3(4, 5, 6);
  EXPECT_EQ(pl.shear_spring(0), Vec3(1, 2, 3));
  EXPECT_EQ(pl.rolling_spring(0), Vec3(4, 5, 6));
  pl.give_slot(0);
  pl.touching[0] = 0;
  EXPECT_EQ(pl.shear_spring(0), Vec3::Zero());
  pl.take_slot(1);
  pl.touching[1] = 1;
  EXPECT_EQ(pl.slot[1], 0);  // the slot of pair 0, taken again
  EXPECT_EQ(pl.spring_fs.size(), 1u);
  EXPECT_EQ(pl.shear_spring(1), Vec3::Zero());
  EXPECT_EQ(pl.rolling_spring(1), Vec3::Zero());
}

// Over a run in which contacts keep closing and opening, with rebuilds, after every step: each
// touching pair has its own slot, and the touching pairs' slots and the free slots are every
// slot of the pools exactly once (no slot shared, none lost); right after a rebuild the pools
// hold the touching pairs only.
TEST(ForcesSimd, SpringSlotsFollowTheTouchingPairs) {
  for (int lanes : {1, 4}) {
    Simulation sim = dense_sim(law_of(true, true), lanes);
    std::int64_t rebuilds = sim.rebuild_count(), reused = 0, opened_and_closed = 0;
    std::size_t free_before = 0, most_pool = 0, pairs_then = 0, after_rebuild = 0;
    for (int k = 1; k <= 400; ++k) {
      sim.step(false);
      const PairList& pl = sim.pairs();
      const std::size_t n = pl.spring_fs.size();
      ASSERT_EQ(pl.spring_mr.size(), n) << "lanes " << lanes << " step " << k;
      std::vector<int> use(n, 0);
      std::size_t touching = 0;
      for (std::size_t q = 0; q < pl.size(); ++q) {
        if (!pl.touching[q]) continue;
        ++touching;
        ASSERT_TRUE(pl.slot[q] >= 0 && std::size_t(pl.slot[q]) < n) << "step " << k;
        ++use[std::size_t(pl.slot[q])];
      }
      for (Index s : pl.free_slots) {
        ASSERT_TRUE(s >= 0 && std::size_t(s) < n) << "step " << k;
        ++use[std::size_t(s)];
      }
      for (std::size_t s = 0; s < n; ++s) ASSERT_EQ(use[s], 1) << "lanes " << lanes << " step " << k << " slot " << s;
      if (sim.rebuild_count() != rebuilds) {
        rebuilds = sim.rebuild_count();
        // The rebuild handed out the slots afresh: the only free ones are those of the
        // contacts that opened in this step's force loop, a few.
        EXPECT_LE(pl.free_slots.size(), touching / 20) << "lanes " << lanes << " step " << k;
        after_rebuild = std::max(after_rebuild, pl.free_slots.size());
      } else {
        if (pl.free_slots.size() < free_before) ++reused;
        if (pl.free_slots.size() != free_before) ++opened_and_closed;
      }
      free_before = pl.free_slots.size();
      if (n > most_pool) most_pool = n, pairs_then = pl.size();
    }
    std::printf(
        "[spring slots] lanes %d: %lld rebuilds, free slots taken again in %lld steps, the "
        "pools at most %zu slots for %zu list pairs, at most %zu free slots right after a rebuild\n",
        lanes, (long long)sim.rebuild_count(), (long long)reused, most_pool, pairs_then, after_rebuild);
    EXPECT_GT(sim.rebuild_count(), 1);
    EXPECT_GT(reused, 10) << "lanes " << lanes;  // the test saw slots given back and taken again
    EXPECT_GT(opened_and_closed, 10) << "lanes " << lanes;
    EXPECT_LT(most_pool, pairs_then) << "lanes " << lanes;  // springs for fewer than all pairs
  }
}

}  // namespace
}  // namespace fabrica
