// Unit tests of the contact law function contact_law<Rolling, Viscous> and its helpers
// (docs/verification.md section 11): stiffness constants, Coulomb and rolling caps, carrying the
// springs with the contact plane, dashpots, and slip dissipation.
#include "core/contact_law.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace fabrica {
namespace {

constexpr real_t kPi = std::numbers::pi;
constexpr real_t kInf = std::numeric_limits<real_t>::infinity();

ContactLawParams base_law() {
  ContactLawParams p;
  p.youngs_modulus = 50e6;
  p.stiffness_ratio = 2.0;
  p.friction = 0.4;
  p.rolling_friction = 0.1;
  return p;
}

ContactKinematics kin(const Vec3& n, real_t un, const Vec3& vrel = Vec3::Zero(), const Vec3& w1 = Vec3::Zero(),
                      const Vec3& w2 = Vec3::Zero()) {
  return {n.normalized(), un, vrel, w1, w2};
}

// Pair constants against the formulas of spec section 2 (relative 1e-15).
TEST(ContactLaw, PairConstants) {
  ContactLawParams p = base_law();
  p.damping_ratio_n = 0.3;
  p.damping_ratio_s = 0.1;
  const real_t R1 = 0.02, R2 = 0.005, m1 = 0.7, m2 = 0.011;
  const PairConstants c = pair_constants<true, true>(p, R1, R2, m1, m2);
  const real_t kn = kPi * R2 * R2 * p.youngs_modulus / (R1 + R2), ks = kn / 2.0;
  const real_t rbar = 1.0 / (1.0 / R1 + 1.0 / R2), meff = m1 * m2 / (m1 + m2);
  EXPECT_NEAR(c.kn / kn, 1.0, 1e-15);
  EXPECT_NEAR(c.ks / ks, 1.0, 1e-15);
  EXPECT_NEAR(c.rbar / rbar, 1.0, 1e-15);
  EXPECT_NEAR(c.kr / (ks * rbar * rbar), 1.0, 1e-15);
  EXPECT_NEAR(c.cn / (2 * 0.3 * std::sqrt(meff * kn)), 1.0, 1e-15);
  EXPECT_NEAR(c.cs / (2 * 0.1 * std::sqrt(meff * ks)), 1.0, 1e-15);
  // Wall (R2 = m2 = infinity): k_n = pi R1 E (r = L = R1), Rbar = R1, m_eff = m1.
  const PairConstants w = pair_constants<true, true>(p, R1, kInf, m1, kInf);
  EXPECT_NEAR(w.kn / (kPi * R1 * p.youngs_modulus), 1.0, 1e-15);
  EXPECT_NEAR(w.rbar / R1, 1.0, 1e-15);
  EXPECT_NEAR(w.cn / (2 * 0.3 * std::sqrt(m1 * w.kn)), 1.0, 1e-15);
  // Direct stiffness.
  p.stiffness_mode = NormalStiffnessMode::Direct;
  p.normal_stiffness = 1234.5;
  EXPECT_EQ((pair_constants<false, false>(p, R1, R2, m1, m2).kn), 1234.5);
  // A kernel without rolling / viscosity computes none of it.
  const PairConstants z = pair_constants<false, false>(p, R1, R2, m1, m2);
  EXPECT_EQ(z.kr, 0.0);
  EXPECT_EQ(z.cn, 0.0);
}

// Elastic stick below the cap: f_s = -k_s v_t dt exactly, f_n = k_n u_n, no dissipation.
TEST(ContactLaw, ElasticStickBelowCap) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.01, 1, 1);
  const Vec3 n(0, 0, 1);
  const real_t un = 1e-5, dt = 1e-6;
  const Vec3 vt(0.3, -0.1, 0);  // |k_s v_t dt| far below mu k_n u_n
  ContactHistory h;
  const ContactResult r = contact_law<true, false>(p, c, kin(n, un, vt + 0.05 * n), h, dt);
  EXPECT_DOUBLE_EQ(r.fn, c.kn * un);
  EXPECT_LT((r.fs + c.ks * vt * dt).norm(), 1e-15 * c.ks * vt.norm() * dt);
  EXPECT_FALSE(r.sliding);
  EXPECT_EQ(r.e_friction, 0.0);
  EXPECT_TRUE((h.fs - r.fs).isZero(0));
}

// Coulomb cap: |f_s| == mu k_n u_n while sliding (relative 1e-14), opposite the slip.
TEST(ContactLaw, CoulombCap) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.02, 1, 2);
  const Vec3 n = Vec3(1, -2, 0.5).normalized();
  const real_t un = 2e-5, dt = 1e-5;
  const Vec3 vt = Vec3(0.3, 0.2, 0.4) - Vec3(0.3, 0.2, 0.4).dot(n) * n;
  ContactHistory h;
  const real_t cap = p.friction * c.kn * un;
  int first_slide = -1;
  for (int s = 0; s < 50; ++s) {
    const ContactResult r = contact_law<true, false>(p, c, kin(n, un, vt), h, dt);
    const real_t elastic = c.ks * vt.norm() * (s + 1) * dt;  // |f_s| if it had not slid
    if (elastic <= cap * (1 - 1e-12)) {
      EXPECT_FALSE(r.sliding);
      EXPECT_NEAR(r.fs.norm() / elastic, 1.0, 1e-13);
    } else if (elastic > cap * (1 + 1e-12)) {
      if (first_slide < 0) first_slide = s;
      EXPECT_TRUE(r.sliding);
      EXPECT_NEAR(r.fs.norm() / cap, 1.0, 1e-14);
    }
    EXPECT_NEAR(r.fs.normalized().dot(-vt.normalized()), 1.0, 1e-14);
    EXPECT_NEAR(r.fs.dot(n), 0.0, 1e-14 * cap);
  }
  EXPECT_GT(first_slide, 0);  // it stuck first, then slid
}

// Rolling cap: |m_r| == mu_r Rbar k_n u_n once exceeded (1e-14), opposing the bending part of
// w2 - w1; the twisting part (along n) never loads the rolling spring.
TEST(ContactLaw, RollingCapAndTwistExcluded) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.03, 1, 2);
  const Vec3 n = Vec3(0.2, 1, -0.3).normalized();
  const real_t un = 1e-5, dt = 1e-5;
  const Vec3 bend = Vec3(1, 0, 0) - Vec3(1, 0, 0).dot(n) * n;
  // Relative spin: bending 50 rad/s plus twist 30 rad/s; the mean spin has no component along n
  // (otherwise the stored moment would turn with the pair about n).
  const Vec3 w1 = Vec3(0.1, 0.2, 0.3).cross(n) - 15 * n, w2 = w1 + 50 * bend + 30 * n;
  ContactHistory h;
  const real_t rcap = p.rolling_friction * c.rbar * c.kn * un;
  bool reached = false;
  for (int s = 0; s < 200; ++s) {
    const ContactResult r = contact_law<true, false>(p, c, kin(n, un, Vec3::Zero(), w1, w2), h, dt);
    EXPECT_LE(r.mr.norm(), rcap * (1 + 1e-14));
    EXPECT_NEAR(r.mr.dot(n), 0.0, 1e-12 * rcap);
    if (r.mr.norm() > rcap * (1 - 1e-14)) {
      reached = true;
      EXPECT_TRUE(r.rolling);
      EXPECT_NEAR(r.mr.norm() / rcap, 1.0, 1e-14);
      EXPECT_NEAR(r.mr.normalized().dot(-bend.normalized()), 1.0, 1e-12);
    } else {
      EXPECT_FALSE(r.rolling);
    }
  }
  EXPECT_TRUE(reached);
  // Pure twist: nothing stored.
  ContactHistory h2;
  const ContactResult r2 = contact_law<true, false>(p, c, kin(n, un, Vec3::Zero(), w1, w1 + 40 * n), h2, dt);
  EXPECT_LT(r2.mr.norm(), 1e-15 * rcap);
}

// carry_with_plane keeps the length, makes the vector perpendicular to the new normal and turns
// it about n by atan(phi) in the right-hand sense (tolerance 1e-14).
TEST(ContactLaw, CarryWithPlane) {
  const Vec3 a(0.3, -1.2, 0.7);
  for (const Vec3& n0 : {Vec3(1, 2, 3), Vec3(-0.5, 0.1, 0.2), Vec3(0, 0, 1)}) {
    const Vec3 n = n0.normalized();
    for (real_t phi : {0.0, 1e-3, -0.2}) {
      const Vec3 b = carry_with_plane(a, n, phi);
      EXPECT_NEAR(b.norm() / a.norm(), 1.0, 1e-14);
      EXPECT_NEAR(b.dot(n), 0.0, 1e-14 * a.norm());
      const Vec3 ap = (a - a.dot(n) * n).normalized();
      const real_t angle = std::atan2(ap.cross(b.normalized()).dot(n), ap.dot(b.normalized()));
      EXPECT_NEAR(angle, std::atan(phi), 1e-14);
    }
  }
  EXPECT_TRUE(carry_with_plane(Vec3::Zero(), Vec3::UnitX(), 0.1).isZero(0));
}

// Inside the law: a stored shear spring is carried to a new normal (length kept, perpendicular)
// and a rigid spin of the pair about n turns it with the pair (angle atan(Omega dt)).
TEST(ContactLaw, SpringsFollowTheContactPlane) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.01, 1, 1);
  const real_t un = 1e-4, dt = 1e-6;
  ContactHistory h;
  h.fs = Vec3(0.5, 0.0, 0.0);  // below the cap, in the plane of n = z
  h.mr = Vec3(0.0, 1e-4, 0.0);
  const Vec3 n2 = Vec3(0.1, 0.05, 1).normalized();  // the contact plane tilted
  const real_t l_fs = h.fs.norm(), l_mr = h.mr.norm();
  ASSERT_LT(l_fs, p.friction * c.kn * un);
  ASSERT_LT(l_mr, p.rolling_friction * c.rbar * c.kn * un);
  contact_law<true, false>(p, c, kin(n2, un), h, dt);
  EXPECT_NEAR(h.fs.norm() / l_fs, 1.0, 1e-14);
  EXPECT_NEAR(h.mr.norm() / l_mr, 1.0, 1e-14);
  EXPECT_NEAR(h.fs.dot(n2), 0.0, 1e-14 * l_fs);
  EXPECT_NEAR(h.mr.dot(n2), 0.0, 1e-14 * l_mr);
  // Rigid rotation of both bodies about n2 at Omega: no relative motion at the contact (vrel = 0
  // by construction), and the springs turn about n2 by atan(Omega dt).
  const real_t Omega = 300.0;
  const Vec3 fs0 = h.fs, mr0 = h.mr;
  contact_law<true, false>(p, c, kin(n2, un, Vec3::Zero(), Omega * n2, Omega * n2), h, dt);
  const real_t ang_f = std::atan2(fs0.cross(h.fs).dot(n2), fs0.dot(h.fs));
  const real_t ang_m = std::atan2(mr0.cross(h.mr).dot(n2), mr0.dot(h.mr));
  EXPECT_NEAR(ang_f, std::atan(Omega * dt), 1e-13);
  EXPECT_NEAR(ang_m, std::atan(Omega * dt), 1e-13);
  EXPECT_NEAR(h.fs.norm() / l_fs, 1.0, 1e-14);
}

// Steady sliding: the dissipation booked per step is cap * |v_t| dt, so over N steps it is
// cap times the slip distance (relative 1e-12); same for rolling slip with the rolling cap.
// Started from unloaded springs, the total is cap (D - cap/k) up to one step's energy
// cap |du| (the step in which the cap is reached).
TEST(ContactLaw, SlipDissipationEqualsCapTimesSlip) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.02, 1, 2);
  const Vec3 n = Vec3(1, 1, 0).normalized();
  const real_t un = 3e-5, dt = 1e-5;
  const Vec3 vt = 0.2 * Vec3(1, -1, 0).normalized();
  const Vec3 wb = 40.0 * Vec3(0, 0, 1);  // bending relative spin (perpendicular to n)
  const real_t cap = p.friction * c.kn * un, rcap = p.rolling_friction * c.rbar * c.kn * un;
  const int N = 1000;
  {  // springs already at their caps
    ContactHistory h;
    h.fs = -cap * vt.normalized();
    h.mr = -rcap * wb.normalized();
    real_t ef = 0, er = 0;
    for (int s = 0; s < N; ++s) {
      const ContactResult r = contact_law<true, false>(p, c, kin(n, un, vt, Vec3::Zero(), wb), h, dt);
      EXPECT_TRUE(r.sliding && r.rolling);
      ef += r.e_friction, er += r.e_rolling;
    }
    EXPECT_NEAR(ef / (cap * vt.norm() * N * dt), 1.0, 1e-12);
    EXPECT_NEAR(er / (rcap * wb.norm() * N * dt), 1.0, 1e-12);
  }
  {  // from unloaded springs
    ContactHistory h;
    real_t ef = 0, er = 0;
    for (int s = 0; s < N; ++s) {
      const ContactResult r = contact_law<true, false>(p, c, kin(n, un, vt, Vec3::Zero(), wb), h, dt);
      ef += r.e_friction, er += r.e_rolling;
    }
    const real_t D = vt.norm() * N * dt, TH = wb.norm() * N * dt;
    std::printf(
        "[contact law] from unloaded springs: friction energy error %.2e of cap |du|, "
        "rolling %.2e of rcap |dtheta|\n",
        (ef - cap * (D - cap / c.ks)) / (cap * vt.norm() * dt),
        (er - rcap * (TH - rcap / c.kr)) / (rcap * wb.norm() * dt));
    EXPECT_NEAR(ef, cap * (D - cap / c.ks), cap * vt.norm() * dt);
    EXPECT_NEAR(er, rcap * (TH - rcap / c.kr), rcap * wb.norm() * dt);
    EXPECT_GT(ef, 0.9 * cap * D);
  }
}

// Normal dashpot f_n = k_n u_n - c_n v_n, clamped at zero (no tension); the shear dashpot acts
// only while the contact sticks; the Coulomb cap uses the elastic force k_n u_n.
TEST(ContactLaw, Dashpots) {
  ContactLawParams p = base_law();
  p.damping_ratio_n = 0.4;
  p.damping_ratio_s = 0.2;
  const PairConstants c = pair_constants<false, true>(p, 0.01, 0.01, 0.01, 0.01);
  const Vec3 n = Vec3::UnitX();
  const real_t un = 1e-5, dt = 1e-7;
  {  // approaching (v_n < 0): f_n = k u + c |v_n|; small v_t: stick, f_s = -k_s du - c_s v_t
    ContactHistory h;
    const Vec3 vt(0, 1e-4, 0);
    const ContactResult r = contact_law<false, true>(p, c, kin(n, un, -0.1 * n + vt), h, dt);
    EXPECT_NEAR(r.fn / (c.kn * un + c.cn * 0.1), 1.0, 1e-14);
    ASSERT_FALSE(r.sliding);
    EXPECT_LT((r.fs - (-c.ks * vt * dt - c.cs * vt)).norm(), 1e-14 * r.fs.norm());
    EXPECT_TRUE((h.fs + c.ks * vt * dt).isZero(1e-20));  // the dashpot is not stored
    EXPECT_NEAR(r.e_viscous, (c.cn * 0.01 + c.cs * vt.squaredNorm()) * dt, 1e-14 * r.e_viscous);
  }
  {  // separating fast: clamped to zero
    ContactHistory h;
    const ContactResult r = contact_law<false, true>(p, c, kin(n, un, 10.0 * n), h, dt);
    EXPECT_EQ(r.fn, 0.0);
  }
  {  // sliding: shear dashpot off, |f_s| = mu k_n u_n even though f_n includes the dashpot
    ContactHistory h;
    const Vec3 vt(0, 0, 200.0);
    const ContactResult r = contact_law<false, true>(p, c, kin(n, un, -0.1 * n + vt), h, dt);
    ASSERT_TRUE(r.sliding);
    EXPECT_NEAR(r.fs.norm() / (p.friction * c.kn * un), 1.0, 1e-14);
  }
}

// Spring energies: 1/2 k_n u_n^2, 1/2 |f_s|^2 / k_s, 1/2 |m_r|^2 / k_r.
TEST(ContactLaw, SpringEnergies) {
  const ContactLawParams p = base_law();
  const PairConstants c = pair_constants<true, false>(p, 0.01, 0.02, 1, 2);
  ContactHistory h;
  h.fs = Vec3(1, 2, 0);
  h.mr = Vec3(0, 0, 1e-3);
  EXPECT_DOUBLE_EQ(spring_energy_normal(c, 1e-5), 0.5 * c.kn * 1e-10);
  EXPECT_DOUBLE_EQ(spring_energy_shear(c, h), 0.5 * 5.0 / c.ks);
  EXPECT_DOUBLE_EQ(spring_energy_rolling(c, h), 0.5 * 1e-6 / c.kr);
}

}  // namespace
}  // namespace fabrica
