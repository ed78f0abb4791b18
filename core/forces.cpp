#include "core/forces.hpp"

#include <unsupported/Eigen/MatrixFunctions>

#include "core/contact_law.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <numbers>
#include <utility>

#include <unistd.h>

namespace fabrica {
namespace {

#if defined(__AVX2__)
// Left-pack tables of the pass-1 loop: for a 4-bit mask of touching lanes, the permutation
// (of 32-bit elements) that moves the set lanes of 4 doubles (kPack64) or of 4 ints (kPack32)
// to the front, in order; and the 4 touching bytes of the mask.
struct PackTables {
  alignas(32) std::int32_t p64[16][8];
  alignas(32) std::int32_t p32[16][8];
  std::uint32_t bytes[16];
};
constexpr PackTables make_pack_tables() {
  PackTables t{};
  for (int m = 0; m < 16; ++m) {
    int k = 0;
    t.bytes[m] = 0;
    for (int l = 0; l < 4; ++l) {
      if (!(m >> l & 1)) continue;
      t.p64[m][2 * k] = 2 * l, t.p64[m][2 * k + 1] = 2 * l + 1;
      t.p32[m][k] = l;
      t.bytes[m] |= 1u << (8 * l);
      ++k;
    }
    for (int r = k; r < 4; ++r) t.p64[m][2 * r] = t.p64[m][2 * r + 1] = 0;
    for (int r = k; r < 8; ++r) t.p32[m][r] = 0;
  }
  return t;
}
constexpr PackTables kPackTables = make_pack_tables();
constexpr const auto& kPack64 = kPackTables.p64;
constexpr const auto& kPack32 = kPackTables.p32;
constexpr const auto& kTouchBytes = kPackTables.bytes;
#endif

// Out of the loop's way: reached only by an overlap beyond the geometric limit.
[[gnu::cold, gnu::noinline]] void note_overlap(OverlapAlarm* alarm, real_t un, real_t radius, GlobalId a, GlobalId b) {
  if (!alarm) return;
  const real_t ratio = un / radius;
  if (ratio > alarm->ratio) *alarm = OverlapAlarm{ratio, un, radius, a, b};
}

// One contact of the model, in the scalar form the wall loop uses.
template <class Model, int Roll, bool Twist, bool Viscous>
ContactResult evaluate_one(const ContactLawParams& law, const typename Model::template Pair<real_t>& c,
                           const ContactKinematics& k, ContactHistory& h, real_t dt) {
  constexpr bool Rolling = Roll != kNoRolling;
  using simd::from_vec, simd::to_vec;
  const ContactKinematicsL<real_t> kl{from_vec(k.n), k.un, from_vec(k.vrel), from_vec(k.w1), from_vec(k.w2), k.un_prev};
  ContactHistoryL<real_t> hl{from_vec(h.fs), from_vec(h.mr), h.mt};
  const ContactResultL<real_t> rl = Model::template evaluate<Roll, Viscous, real_t, Twist>(law, c, kl, hl, dt);
  h.fs = to_vec(hl.fs);
  if constexpr (Rolling) h.mr = to_vec(hl.mr);
  if constexpr (Twist) h.mt = hl.mt;
  return ContactResult{rl.fn,         to_vec(rl.fs), to_vec(rl.mr), rl.sliding, rl.rolling,
                       rl.e_friction, rl.e_rolling,  rl.e_viscous,  rl.mt};
}

// The second line of a 24-byte vector: a quarter of them straddle two cache lines, and a
// fetch of the first byte alone leaves the second line to a miss. Changes no result.
inline const char* last_byte(const Vec3* v) { return reinterpret_cast<const char*>(v) + sizeof(Vec3) - 1; }

// Whether the pair loop fetches everything a contact reads ahead of it (both lines of every
// vector, the mass and the springs) or only the first lines of the partner's position, radius,
// velocity, spin, force and torque: true once the particles' hot fields (x, v, w, f, t, R, m:
// 136 bytes each) outgrow the second-level cache: beyond it the fetches shorten the force phase,
// within it they are extra instructions with nothing to wait for (benchmarks/README.md, "Every
// line a contact reads, fetched ahead past the second-level cache").
bool fetch_all_ahead(std::size_t particles) {
  static const long l2 = [] {
    const long b = sysconf(_SC_LEVEL2_CACHE_SIZE);
    return b > 0 ? b : 1L << 20;
  }();
  return particles * 136 > std::size_t(l2);
}

// The pair loop, in two passes over each block of the Verlet list (run() below):
//  1. the distance test of every pair, in list order (four pairs at a time with AVX2): the
//     pairs that touch are collected (with their branch vectors) into pl.work, the contacts
//     that open are closed (springs zeroed, the energy left in them noted with its place);
//  2. the contact law for the touching pairs, simd::Lanes<T>::n at a time (T = simd::d4: four
//     contacts per instruction; the rest and lanes = 1 with T = double), then the forces and
//     torques added to both bodies contact by contact, in list order.
// Every sum into a particle's force or torque and into the energy books is therefore done in
// the order of the one-pass loop (contact-opening energies merged back at their place), and
// the law gives the same bits on every lane (core/simd.hpp): lanes = 1 and lanes = 4 give the
// same results bit for bit (tests/unit/test_forces_simd.cpp), and so does the rank count.
// What the pair loop sums besides the forces: nothing, only ContactSums::fb (a straining step
// that does not measure: the boundary work needs the diagonal of the stress), or everything.
constexpr int kNone = 0, kVirial = 1, kFull = 2;

// Mixed: a scene of several materials, the law of each contact that of its pair of materials
// (ctx.materials), lane by lane (LawLanes: each lane of the SIMD law its own numbers).
template <class Model, int Roll, bool Twist, bool Viscous, bool Mixed, int Measure>
struct PairKernel {
  static constexpr bool Rolling = Roll != kNoRolling;
  static constexpr bool Moments = Rolling || Twist;  // a moment beside the shear force's
  using Pair = typename Model::template Pair<real_t>;
  Particles& P;
  const ForceContext& ctx;
  PairList& pl;
  ContactSums* sums;
  std::array<Vec3, 27> shift;
  Vec3 edot;
  std::size_t n_owned;
  Vec3 unscale = Vec3::Ones();  // 1 / the cell's scaling of this step, exp(-edot dt)
  // A sheared cell: the velocity gradient's off-diagonal terms (its diagonal is edot) and the
  // inverse of the step's deformation, exp(-G dt).
  bool sheared = false;
  Mat3 g_off = Mat3::Zero();
  Mat3 unmap = Mat3::Identity();
  real_t e_fric = 0, e_roll = 0, e_visc = 0;
  std::size_t next_opening = 0;  // the first opening not yet booked
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::size_t next_before = kNone;  // its place (kNone: none left)
  static constexpr std::size_t kBodyAhead = 8;
  std::size_t body_ahead_end = 0;  // contacts in the work arrays (the prefetch's bound)
  bool fetch_all = false;          // fetch_all_ahead(): every line a contact reads

  // The law of a contact of bodies i and j.
  const ContactLawParams& law_of(Index i, Index j) const {
    if constexpr (Mixed) return ctx.materials->pair(P.material[i], P.material[j]);
    else return ctx.law;
  }
  // Mixed: each pair of materials' law as the lanes take it (a * materials + b), made once per call.
  std::vector<LawLanes<real_t>> pair_lanes;
  void make_pair_lanes() {
    const Materials& m = *ctx.materials;
    pair_lanes.resize(m.pairs.size());
    for (std::size_t q = 0; q < m.pairs.size(); ++q) {
      const ContactLawParams& l = m.pairs[q];
      LawLanes<real_t>& o = pair_lanes[q];
      o.model = l.model, o.stiffness_mode = l.stiffness_mode, o.rolling_model = l.rolling_model;
      o.youngs_modulus = l.youngs_modulus, o.normal_stiffness = l.normal_stiffness;
      o.stiffness_ratio = l.stiffness_ratio, o.friction = l.friction, o.rolling_friction = l.rolling_friction;
      o.twisting_friction = l.twisting_friction, o.rolling_damping = l.rolling_damping;
      o.damping_ratio_n = l.damping_ratio_n, o.damping_ratio_s = l.damping_ratio_s;
      o.damping_rate_n = l.damping_rate_n, o.damping_rate_s = l.damping_rate_s;
      o.estar = HertzMindlin::effective_modulus(l), o.gstar = HertzMindlin::effective_shear_modulus(l);
    }
  }
  // The laws of contacts ci[0..n), lane by lane.
  template <class T>
  LawLanes<T> lanes_of(const Index* ci, const Index* cj) const {
    LawLanes<T> L;
    L.model = ctx.law.model, L.stiffness_mode = ctx.law.stiffness_mode, L.rolling_model = ctx.law.rolling_model;
    const std::size_t n = ctx.materials->size();
    for (int l = 0; l < simd::Lanes<T>::n; ++l) {
      const LawLanes<real_t>& q = pair_lanes[std::size_t(P.material[ci[l]]) * n + P.material[cj[l]]];
      using simd::set_lane;
      set_lane(L.youngs_modulus, l, q.youngs_modulus), set_lane(L.normal_stiffness, l, q.normal_stiffness);
      set_lane(L.stiffness_ratio, l, q.stiffness_ratio), set_lane(L.friction, l, q.friction);
      set_lane(L.rolling_friction, l, q.rolling_friction), set_lane(L.twisting_friction, l, q.twisting_friction);
      set_lane(L.rolling_damping, l, q.rolling_damping), set_lane(L.damping_ratio_n, l, q.damping_ratio_n);
      set_lane(L.damping_ratio_s, l, q.damping_ratio_s), set_lane(L.damping_rate_n, l, q.damping_rate_n);
      set_lane(L.damping_rate_s, l, q.damping_rate_s), set_lane(L.estar, l, q.estar);
      set_lane(L.gstar, l, q.gstar);
    }
    return L;
  }

  // The contact of pair q (bodies i, j) opens after nc touching pairs of this block: the
  // energy left in its springs is lost, and its spring slot is given back.
  [[gnu::noinline]] void open_contact(std::size_t q, Index i, Index j, std::size_t nc) {
    const real_t* R = P.radius.data();
    const real_t* m = P.mass.data();
    // The springs' energy at the opening overlap, u_n = 0 (Hertz-Mindlin: none is left).
    const ContactLawParams& law = law_of(i, j);
    const Pair c = Model::template constants<Roll, false>(law, R[i], R[j], m[i], m[j]);
    const real_t own_i = std::size_t(i) < n_owned ? 1.0 : 0.0;
    const Index s = pl.slot[q];
    PairList::Work::Opening o{nc, own_i * Model::energy_shear(c, 0.0, pl.spring_fs[s]), 0.0};
    if constexpr (Rolling) o.e_rolling = own_i * Model::energy_rolling(law, c, 0.0, pl.spring_mr[s]);
    if constexpr (Twist) o.e_rolling += own_i * Model::energy_twisting(c, 0.0, pl.spring_mt[s]);
    pl.give_slot(q);
    pl.work.openings.push_back(o);
  }

  // Pass 1 over pairs [q0, q1), appending the touching ones to pl.work from slot nc; returns
  // the new count.
  std::size_t collect_touching(std::size_t q0, std::size_t q1, std::size_t nc) {
    const Vec3* x = P.x.data();
    const real_t* R = P.radius.data();
    const Index* pi = pl.i.data();
    const Index* pj = pl.j.data();
    const std::uint8_t* img = pl.image.data();
    std::uint8_t* touching = pl.touching.data();
    PairList::Work& W = pl.work;
    const std::size_t np = pl.size();
    // The pairs follow a space-filling curve (neighbor.hpp), so most partners are near in
    // memory, but the curve's jumps and the second body of each pair are not: fetch the
    // positions and radii of the pair kAhead places on. Changes no result. This loop takes a
    // few ns per pair, so the fetch must start many pairs ahead to cover a trip to memory
    // (benchmarks/README.md, "The pair loop's prefetch distance").
    constexpr std::size_t kAhead = 64;
    Index* ws = W.s.data();
    const Index* slot = pl.slot.data();
    Index* wi = W.i.data();
    Index* wj = W.j.data();
    real_t* wdx = W.dx.data();
    real_t* wdy = W.dy.data();
    real_t* wdz = W.dz.data();
    real_t* wr2 = W.r2.data();
    std::size_t q = q0;
#if defined(__AVX2__)
    if (ctx.lanes == 4) {
      // Four pairs at a time: the same operations on each lane as the loop below, the
      // touching pairs packed to the front of the lanes with a permutation (left-pack table).
      const std::array<Vec3, 27>& sh = shift;
      for (; q + 4 <= q1; q += 4) {
        using simd::d4;
        if (q + kAhead + 4 <= np)
          for (int l = 0; l < 4; ++l) {
            __builtin_prefetch(&x[pj[q + kAhead + l]]);
            if (fetch_all) __builtin_prefetch(last_byte(&x[pj[q + kAhead + l]]));
            __builtin_prefetch(&R[pj[q + kAhead + l]]);
          }
        const Index im[4] = {img[q], img[q + 1], img[q + 2], img[q + 3]};
        const simd::V3<d4> xi = simd::gather3<d4>(x, pi + q), xj = simd::gather3<d4>(x, pj + q);
        const simd::V3<d4> s4 = simd::gather3<d4>(sh.data(), im);
        const simd::V3<d4> d = xj + s4 - xi;
        const d4 sum_r = simd::gather<d4>(R, pi + q) + simd::gather<d4>(R, pj + q);
        const d4 r2 = simd::squared_norm(d);
        const unsigned apart = unsigned(_mm256_movemask_pd(reinterpret_cast<__m256d>(r2 >= sum_r * sum_r)));
        const unsigned touch = ~apart & 0xFu;
        std::uint32_t was;
        __builtin_memcpy(&was, touching + q, 4);
        const unsigned was_bits = (was & 1u) | ((was >> 7) & 2u) | ((was >> 14) & 4u) | ((was >> 21) & 8u);
        if (was_bits != touch) [[unlikely]] {
          std::size_t before = nc;
          for (int l = 0; l < 4; ++l) {
            if (touch >> l & 1u) {
              ++before;
              if (!(was_bits >> l & 1u)) pl.take_slot(q + l);  // a contact closes
            } else if (was_bits >> l & 1u) {
              open_contact(q + l, pi[q + l], pj[q + l], before);
            }
          }
        }
        const std::uint32_t now = kTouchBytes[touch];
        __builtin_memcpy(touching + q, &now, 4);
        const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kPack64[touch]));
        const __m256i perm32 = _mm256_load_si256(reinterpret_cast<const __m256i*>(kPack32[touch]));
        auto pack_d = [&](real_t* dst, d4 v) {
          _mm256_storeu_pd(dst + nc, _mm256_castsi256_pd(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(v), perm)));
        };
        auto pack_i = [&](Index* dst, __m128i v) {
          _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + nc),
                           _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castsi128_si256(v), perm32)));
        };
        pack_i(ws, _mm_loadu_si128(reinterpret_cast<const __m128i*>(slot + q)));
        pack_i(wi, _mm_loadu_si128(reinterpret_cast<const __m128i*>(pi + q)));
        pack_i(wj, _mm_loadu_si128(reinterpret_cast<const __m128i*>(pj + q)));
        pack_d(wdx, d.x);
        pack_d(wdy, d.y);
        pack_d(wdz, d.z);
        pack_d(wr2, r2);
        nc += unsigned(__builtin_popcount(touch));
      }
    }
#endif
    for (; q < q1; ++q) {
      if (q + kAhead < np) {
        const Index ia = pi[q + kAhead], ja = pj[q + kAhead];
        __builtin_prefetch(&x[ia]);
        __builtin_prefetch(&x[ja]);
        if (fetch_all) __builtin_prefetch(last_byte(&x[ja]));
        __builtin_prefetch(&R[ia]);
        __builtin_prefetch(&R[ja]);
      }
      const Index i = pi[q], j = pj[q];
      const Vec3 d = x[j] + shift[img[q]] - x[i];
      const real_t sum_r = R[i] + R[j];
      const real_t r2 = d.squaredNorm();
      // Without a branch on the test (about half the pairs touch, so it would be mispredicted
      // half the time): every pair is written to the next slot, which only a touching one
      // keeps.
      const bool touch = !(r2 >= sum_r * sum_r);
      if (touching[q] != std::uint8_t(touch)) [[unlikely]] {
        if (touch) pl.take_slot(q);  // a contact closes
        else open_contact(q, i, j, nc);
      }
      ws[nc] = slot[q];
      wi[nc] = i;
      wj[nc] = j;
      wdx[nc] = d[0];
      wdy[nc] = d[1];
      wdz[nc] = d[2];
      wr2[nc] = r2;
      touching[q] = touch;
      nc += touch;
    }
    return nc;
  }

  // Books the contact-opening energies that came before touching contact number c.
  void book_openings(std::size_t c) {
    const auto& o = pl.work.openings;
    for (; next_opening < o.size() && o[next_opening].before <= c; ++next_opening) {
      e_fric += o[next_opening].e_friction;
      if constexpr (Moments) e_roll += o[next_opening].e_rolling;
    }
    next_before = next_opening < o.size() ? o[next_opening].before : kNone;
  }

  // Touching contacts c, ..., c + n - 1 (n the lanes of T). One SIMD pass of the pair kernel:
  // its length is its nature (loads, the law, the stores, in lanes), so it is not cut in pieces.
  // function-length: exempt
  template <class T>
  void contacts(std::size_t c) {
    using namespace simd;
    constexpr int kLanes = Lanes<T>::n;
    const real_t dt = ctx.dt;
    const PairList::Work& W = pl.work;
    const Index* ci = W.i.data() + c;
    const Index* cj = W.j.data() + c;
    // The scene's law, or (several materials) each lane's pair's.
    const auto law_lanes = [&]() -> decltype(auto) {
      if constexpr (Mixed) return lanes_of<T>(ci, cj);
      else return (ctx.law);
    };
    const auto& law = law_lanes();
    const Index* cs = W.s.data() + c;
    const real_t* R = P.radius.data();
    // The second bodies of the contacts kBodyAhead on: their velocities, spins, forces and
    // torques are four more lines each that pass 1 did not bring (at 10^6 spheres most are
    // out of the cache); with fetch_all, also their second lines, the masses and the springs.
    // Changes no result.
    if (c + kBodyAhead + kLanes <= body_ahead_end)
      for (int l = 0; l < kLanes; ++l) {
        const Index b = cj[kBodyAhead + std::size_t(l)];
        __builtin_prefetch(&P.v[b]);
        __builtin_prefetch(&P.w[b]);
        __builtin_prefetch(&P.f[b], 1);
        __builtin_prefetch(&P.t[b], 1);
        if (fetch_all) {
          __builtin_prefetch(last_byte(&P.v[b]));
          __builtin_prefetch(last_byte(&P.w[b]));
          __builtin_prefetch(last_byte(&P.f[b]), 1);
          __builtin_prefetch(last_byte(&P.t[b]), 1);
          if constexpr (Viscous) __builtin_prefetch(&P.mass[b]);
          const Index sl = cs[kBodyAhead + std::size_t(l)];
          __builtin_prefetch(&pl.spring_fs[sl], 1);
          __builtin_prefetch(last_byte(&pl.spring_fs[sl]), 1);
          if constexpr (Rolling) {
            __builtin_prefetch(&pl.spring_mr[sl], 1);
            __builtin_prefetch(last_byte(&pl.spring_mr[sl]), 1);
          }
          if constexpr (Twist) __builtin_prefetch(&pl.spring_mt[sl], 1);
        }
      }
    const V3<T> d{load<T>(W.dx.data() + c), load<T>(W.dy.data() + c), load<T>(W.dz.data() + c)};
    const T r2 = load<T>(W.r2.data() + c);
    const T Ri = gather<T>(R, ci), Rj = gather<T>(R, cj);
    const T sum_r = Ri + Rj;
    const T dist = simd::sqrt(r2);
    ContactKinematicsL<T> k;
    k.n = d / dist;
    k.un = sum_r - dist;
    const T rmin = select(Rj < Ri, Rj, Ri);  // std::min(R_i, R_j)
    const mask_t<T> over = k.un > kMaxOverlapRatio * rmin;
    if (any(over)) [[unlikely]]
      for (int l = 0; l < kLanes; ++l)
        if (lane(over, l) && std::size_t(ci[l]) < n_owned)
          note_overlap(ctx.alarm, lane(k.un, l), lane(rmin, l), P.id[ci[l]], P.id[cj[l]]);
    const T a1 = Ri - 0.5 * k.un, a2 = Rj - 0.5 * k.un;
    k.w1 = gather3<T>(P.w.data(), ci);
    k.w2 = gather3<T>(P.w.data(), cj);
    V3<T> e_d{edot[0] * d.x, edot[1] * d.y, edot[2] * d.z};
    if (sheared) [[unlikely]]  // the same for every contact: predicted
      e_d = e_d +
          V3<T>{g_off(0, 1) * d.y + g_off(0, 2) * d.z, g_off(1, 0) * d.x + g_off(1, 2) * d.z,
                g_off(2, 0) * d.x + g_off(2, 1) * d.y};
    const V3<T> vj = gather3<T>(P.v.data(), cj), vi = gather3<T>(P.v.data(), ci);
    k.vrel = vj - vi + e_d - cross(a2 * k.w2 + a1 * k.w1, k.n);
    if constexpr (Model::kPreviousOverlap) {
      // The branch vector before this step's drift: positions drifted by v dt, then scaled with
      // the cell (core/integrator.cpp), so d_prev = d / s - (v_j - v_i) dt.
      V3<T> d0{d.x * unscale[0], d.y * unscale[1], d.z * unscale[2]};
      if (sheared) [[unlikely]]
        d0 = V3<T>{unmap(0, 0) * d.x + unmap(0, 1) * d.y + unmap(0, 2) * d.z,
                   unmap(1, 0) * d.x + unmap(1, 1) * d.y + unmap(1, 2) * d.z,
                   unmap(2, 0) * d.x + unmap(2, 1) * d.y + unmap(2, 2) * d.z};
      const V3<T> dp = d0 - (vj - vi) * ctx.dt;
      k.un_prev = sum_r - simd::sqrt(squared_norm(dp));
    }
    // The model's constants of two spheres, lane by lane.
    T mi{}, mj{};
    if constexpr (Viscous) mi = gather<T>(P.mass.data(), ci), mj = gather<T>(P.mass.data(), cj);
    const auto pc = Model::template pair<Roll, Viscous, T>(law, Ri, Rj, rmin, sum_r, mi, mj);
    ContactHistoryL<T> h;
    h.fs = gather3<T>(pl.spring_fs.data(), cs);
    if constexpr (Rolling) h.mr = gather3<T>(pl.spring_mr.data(), cs);
    if constexpr (Twist) h.mt = gather<T>(pl.spring_mt.data(), cs);
    const ContactResultL<T> r = Model::template evaluate<Roll, Viscous, T, Twist>(law, pc, k, h, dt);
    scatter3(pl.spring_fs.data(), cs, h.fs);
    if constexpr (Rolling) scatter3(pl.spring_mr.data(), cs, h.mr);
    if constexpr (Twist) scatter(pl.spring_mt.data(), cs, h.mt);

    const V3<T> F = r.fn * k.n + r.fs;  // on j
    const V3<T> nxfs = cross(k.n, r.fs);
    // Added to t_j and subtracted from t_i (without a moment: subtracted from both).
    V3<T> tj, ti;
    if constexpr (Moments) {
      tj = r.mr - a2 * nxfs;
      ti = r.mr + a1 * nxfs;
    } else {
      tj = a2 * nxfs;
      ti = a1 * nxfs;
    }
    // Rows of 4 doubles per lane (simd::to_rows), read back as Vec3 for the scatter.
    alignas(32) real_t rows_f[16], rows_tj[16], rows_ti[16];
    to_rows(F, rows_f);
    to_rows(tj, rows_tj);
    to_rows(ti, rows_ti);
    // A pair between an owned particle and a ghost is computed on both ranks; its energy and
    // its share of the measures belong to the rank that owns body i (the lower id). The
    // products own_i e are taken lane by lane, the sums in contact order below.
    T own{};
    for (int l = 0; l < kLanes; ++l) set_lane(own, l, std::size_t(ci[l]) < n_owned ? 1.0 : 0.0);
    alignas(32) real_t ef[kLanes], er[kLanes], ev[kLanes];
    store(ef, own * r.e_friction);
    if constexpr (Moments) store(er, own * r.e_rolling);
    if constexpr (Viscous) store(ev, own * r.e_viscous);
    Vec3* f = P.f.data();
    Vec3* t = P.t.data();
    for (int l = 0; l < kLanes; ++l) {
      const Index i = ci[l], j = cj[l];
      if (c + l >= next_before) [[unlikely]]
        book_openings(c + l);
      const Eigen::Map<const Vec3> Fl(rows_f + 4 * l), Tj(rows_tj + 4 * l), Ti(rows_ti + 4 * l);
      f[j] += Fl;
      f[i] -= Fl;
      if constexpr (Moments) t[j] += Tj;
      else t[j] -= Tj;
      t[i] -= Ti;
      e_fric += ef[l];
      if constexpr (Moments) e_roll += er[l];
      if constexpr (Viscous) e_visc += ev[l];
      if constexpr (Measure == kVirial) {  // the same sum, in the same order, as below
        if (lane(own, l) != 0.0) sums->fb.noalias() += Fl * lane(d, l).transpose();
      }
      if constexpr (Measure == kFull) {
        const real_t own_i = lane(own, l);
        if (own_i != 0.0) {
          const Pair cl = Model::lane(pc, l);
          const real_t un = lane(k.un, l);
          sums->fb.noalias() += Fl * lane(d, l).transpose();
          ++sums->contacts;
          sums->sliding += lane(r.sliding, l);
          sums->rolling += lane(r.rolling, l);
          sums->e_normal += Model::energy_normal(cl, un);
          sums->e_shear += Model::energy_shear(cl, un, lane(h.fs, l));
          if constexpr (Rolling) sums->e_rolling += Model::energy_rolling(law_of(i, j), cl, un, lane(h.mr, l));
          if constexpr (Twist) sums->e_rolling += Model::energy_twisting(cl, un, lane(h.mt, l));
          sums->sum_contact_force += Fl.norm();
          ++sums->contacts_per_particle[i];
          sums->sum_overlap += un;
          const real_t ratio = un / lane(rmin, l);
          if (ratio > sums->max_overlap_ratio) {
            sums->max_overlap_ratio = ratio;
            sums->max_overlap_a = P.id[i];
            sums->max_overlap_b = P.id[j];
          }
        }
        if (std::size_t(j) < n_owned) ++sums->contacts_per_particle[j];
      }
    }
  }

  // The passes alternate over blocks of kBlock pairs, so that the work arrays stay in the
  // first-level cache and the particles of a block are still near when the law runs; the
  // contacts left over from a block (fewer than the lanes) go first into the next one.
  static constexpr std::size_t kBlock = 512;
  void run() {
    using simd::d4;
    PairList::Work& W = pl.work;
    const std::size_t np = pl.size();
    W.resize(std::min(np, kBlock) + 8);  // + the lanes the packed stores may write past the end
    W.openings.clear();
    std::size_t nc = 0;  // contacts in the work arrays
    for (std::size_t q0 = 0; q0 < np; q0 += kBlock) {
      const std::size_t q1 = std::min(np, q0 + kBlock);
      nc = collect_touching(q0, q1, nc);
      next_before = next_opening < W.openings.size() ? W.openings[next_opening].before : kNone;
      body_ahead_end = nc;
      std::size_t c = 0;
      if (ctx.lanes == 4)
        for (; c + 4 <= nc; c += 4) contacts<d4>(c);
      if (ctx.lanes != 4 || q1 == np)
        for (; c < nc; ++c) contacts<real_t>(c);
      // Carry contacts [c, nc) and the openings not booked yet to the front.
      for (std::size_t k = c; k < nc; ++k) {
        W.s[k - c] = W.s[k], W.i[k - c] = W.i[k], W.j[k - c] = W.j[k];
        W.dx[k - c] = W.dx[k], W.dy[k - c] = W.dy[k], W.dz[k - c] = W.dz[k], W.r2[k - c] = W.r2[k];
      }
      W.openings.erase(W.openings.begin(), W.openings.begin() + std::ptrdiff_t(next_opening));
      for (auto& o : W.openings) o.before -= c;
      next_opening = 0;
      nc -= c;
    }
    book_openings(std::numeric_limits<std::size_t>::max());
  }
};

template <class Model, int Roll, bool Twist, bool Viscous, bool Mixed, int Measure>
void pair_forces(Particles& P, const PeriodicCell& cell, const ForceContext& ctx, PairList& pl, Dissipation& diss,
                 ContactSums* sums) {
  PairKernel<Model, Roll, Twist, Viscous, Mixed, Measure> K{P, ctx, pl, sums, {}, cell.strain_rate(), P.n_owned()};
  for (int c = 0; c < 27; ++c) K.shift[c] = image_offset(c, cell);
  K.fetch_all = ctx.fetch_ahead < 0 ? fetch_all_ahead(P.size()) : ctx.fetch_ahead > 0;
  if constexpr (Mixed) K.make_pair_lanes();
  if (cell.sheared()) {
    K.sheared = true;
    K.g_off = cell.velocity_gradient();
    K.g_off.diagonal().setZero();
    if constexpr (Model::kPreviousOverlap) K.unmap = Mat3(-cell.velocity_gradient() * ctx.dt).exp();
  } else if constexpr (Model::kPreviousOverlap) {
    for (int a = 0; a < 3; ++a) K.unscale[a] = std::exp(-K.edot[a] * ctx.dt);
  }
  K.run();
  diss.friction += K.e_fric;
  diss.rolling += K.e_roll;
  diss.viscous += K.e_visc;
}

// Sphere (body 1) against a plane (body 2) moving at the wall's velocity, with the law of the
// sphere's and the wall's materials, the wall's own law, or the scene's (Mixed: the sphere's
// material's).
template <class Model, int Roll, bool Twist, bool Viscous, bool Mixed, int Measure>
void wall_forces(Particles& P, const ForceContext& ctx, WallContactList& wl, Dissipation& diss, ContactSums* sums,
                 real_t* wall_power) {
  constexpr bool Rolling = Roll != kNoRolling;
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  real_t power = 0;
  for (std::size_t q = 0; q < wl.size(); ++q) {
    const Index i = wl.i[q];
    const Wall& W = ctx.walls[wl.wall[q]];
    const ContactLawParams& law = W.material >= 0 ? ctx.materials->pair(P.material[i], std::size_t(W.material))
        : W.own_law                               ? W.law
        : Mixed                                   ? ctx.materials->pair(P.material[i], P.material[i])
                                                  : ctx.law;
    const real_t dist = (P.x[i] - W.point).dot(W.normal);
    const real_t R = P.radius[i];
    if (dist >= R) {
      if (wl.touching[q]) {  // the contact opens: the energy left in its springs is lost
        wl.touching[q] = 0;
        const auto c = Model::template constants<Roll, false>(law, R, inf, P.mass[i], inf);
        diss.friction += Model::energy_shear(c, 0.0, wl.fs[q]);
        wl.fs[q].setZero();
        if constexpr (Rolling) {
          diss.rolling += Model::energy_rolling(law, c, 0.0, wl.mr[q]);
          wl.mr[q].setZero();
        }
        if constexpr (Twist) {
          diss.rolling += Model::energy_twisting(c, 0.0, wl.mt[q]);
          wl.mt[q] = 0;
        }
      }
      continue;
    }
    wl.touching[q] = 1;
    ContactKinematics k;
    k.n = -W.normal;
    k.un = R - dist;
    if (k.un > kMaxOverlapRatio * R) [[unlikely]]
      note_overlap(ctx.alarm, k.un, R, P.id[i], GlobalId(-1 - wl.wall[q]));
    const real_t a1 = R - 0.5 * k.un;
    k.w1 = P.w[i];
    k.w2 = Vec3::Zero();
    k.vrel = W.velocity - P.v[i] - a1 * P.w[i].cross(k.n);
    // Before this step's drift the sphere was v dt and the plane W.velocity dt back (walls stand
    // in a cell at rest).
    if constexpr (Model::kPreviousOverlap) k.un_prev = k.un + (P.v[i] - W.velocity).dot(W.normal) * ctx.dt;
    const auto c = Model::template constants<Roll, Viscous>(law, R, inf, P.mass[i], inf);
    ContactHistory h;
    h.fs = wl.fs[q];
    if constexpr (Rolling) h.mr = wl.mr[q];
    if constexpr (Twist) h.mt = wl.mt[q];
    const ContactResult r = evaluate_one<Model, Roll, Twist, Viscous>(law, c, k, h, ctx.dt);
    wl.fs[q] = h.fs;
    if constexpr (Rolling) wl.mr[q] = h.mr;
    if constexpr (Twist) wl.mt[q] = h.mt;
    const Vec3 F = r.fn * k.n + r.fs;  // on the wall
    P.f[i] -= F;
    P.t[i] -= r.mr + a1 * k.n.cross(r.fs);
    power -= F.dot(W.velocity);
    if (ctx.wall_load) {  // elastic push (the servo's own speed not fed back); a non-finite
      const real_t push = Model::normal_force(c, k.un);  // value is left to the guards
      if (std::isfinite(push)) {
        ctx.wall_load->add(2 * std::size_t(wl.wall[q]), push);
        ctx.wall_load->add(2 * std::size_t(wl.wall[q]) + 1, Model::normal_stiffness(c, k.un));
      }
    }
    diss.friction += r.e_friction;
    diss.rolling += r.e_rolling;
    diss.viscous += r.e_viscous;
    if constexpr (Measure == kFull) {
      ++sums->wall_contacts;
      sums->fb_walls.noalias() += F * (a1 * k.n).transpose();
      sums->wall_force[wl.wall[q]] += F;
      sums->sum_contact_force += F.norm();  // walls count in the mean contact force too
      if (k.un / R > sums->max_overlap_ratio) {
        sums->max_overlap_ratio = k.un / R;
        sums->max_overlap_a = P.id[i];
        sums->max_overlap_b = -1 - wl.wall[q];
      }
      sums->e_normal += Model::energy_normal(c, k.un);
      sums->e_shear += Model::energy_shear(c, k.un, h.fs);
      if constexpr (Rolling) sums->e_rolling += Model::energy_rolling(law, c, k.un, h.mr);
      if constexpr (Twist) sums->e_rolling += Model::energy_twisting(c, k.un, h.mt);
      ++sums->contacts_per_particle[i];
    }
  }
  if (wall_power) *wall_power = power;
}

template <class Model, int Roll, bool Twist, bool Viscous, bool Mixed, int Measure>
void all_forces(Particles& p, const PeriodicCell& cell, const ForceContext& ctx, PairList& pl, WallContactList& wl,
                Dissipation& diss, ContactSums* sums, real_t* wall_power) {
  pair_forces<Model, Roll, Twist, Viscous, Mixed, Measure>(p, cell, ctx, pl, diss, sums);
  if (wl.size() != 0) wall_forces<Model, Roll, Twist, Viscous, Mixed, Measure>(p, ctx, wl, diss, sums, wall_power);
  else if (wall_power) *wall_power = 0;
}

using Kernel = void (*)(Particles&, const PeriodicCell&, const ForceContext&, PairList&, WallContactList&, Dissipation&,
                        ContactSums*, real_t*);

// One table per model, indexed by (((roll * 2 + twist) * 2 + viscous) * 2 + mixed) * 3 +
// measure (roll: kNoRolling or a rolling model, core/contact/rolling.hpp; mixed: several
// materials; measure: kNone, kVirial, kFull).
template <class Model, std::size_t... K>
constexpr std::array<Kernel, sizeof...(K)> make_kernels(std::index_sequence<K...>) {
  return {all_forces<Model, int(K / 24), (K / 12) % 2 == 1, (K / 6) % 2 == 1, (K / 3) % 2 == 1, int(K % 3)>...};
}
template <class Model>
constexpr std::array<Kernel, 96> kKernels = make_kernels<Model>(std::make_index_sequence<96>{});

}  // namespace

void compute_forces(Particles& p, const PeriodicCell& cell, const ForceContext& ctx, PairList& pairs,
                    WallContactList& wall_contacts, Dissipation& diss, ContactSums* sums, real_t* wall_power) {
  const std::size_t n = p.size();
  const std::size_t first = ctx.owned_ready ? p.n_owned() : 0;
  if (ctx.gravity.isZero()) {
    for (std::size_t a = first; a < n; ++a) p.f[a].setZero();
  } else {
    for (std::size_t a = first; a < n; ++a) p.f[a] = p.mass[a] * ctx.gravity;
  }
  for (std::size_t a = first; a < n; ++a) p.t[a].setZero();
  const int measure = !sums ? kNone : ctx.virial_only ? kVirial : kFull;
  if (measure == kVirial) {
    sums->fb.setZero();
  } else if (measure == kFull) {
    *sums = ContactSums{};
    sums->contacts_per_particle.assign(n, 0);
    sums->wall_force.assign(ctx.walls.size(), Vec3::Zero());
  }
  // A wall's own law may need rolling resistance or dashpots that the scene's does not: the
  // pair loop then runs with them at the scene's zero values (mu_r = 0: no rolling moment).
  // Walls share the scene's rolling model (io/serial/scene.cpp).
  bool rolling = ctx.law.rolling(), twisting = ctx.law.twisting(), viscous = ctx.law.viscous();
  for (const Wall& w : ctx.walls)
    if (w.own_law)
      rolling = rolling || w.law.rolling(), twisting = twisting || w.law.twisting(),
      viscous = viscous || w.law.viscous();
  const bool mixed = ctx.materials && !ctx.materials->empty();
  if (mixed) {  // every pair of materials, walls' included
    rolling = rolling || ctx.materials->any([](const ContactLawParams& l) { return l.rolling(); });
    twisting = twisting || ctx.materials->any([](const ContactLawParams& l) { return l.twisting(); });
    viscous = viscous || ctx.materials->any([](const ContactLawParams& l) { return l.viscous(); });
  }
  const int roll = rolling ? 1 + int(ctx.law.rolling_model) : kNoRolling;
  const std::size_t k = std::size_t((((roll * 2 + twisting) * 2 + viscous) * 2 + mixed) * 3 + measure);
  // Walls share the scene's model (io/serial/scene.cpp refuses another).
  with_model(ctx.law.model, [&](auto model) {
    kKernels<decltype(model)>[k](p, cell, ctx, pairs, wall_contacts, diss, sums, wall_power);
  });
  if (measure == kFull)
    for (std::size_t a = 0; a < p.n_owned(); ++a) sums->sum_particle_force += p.f[a].norm();
}

}  // namespace fabrica
