// bench_kernel: the contact kernel alone, on contacts taken from the dense-13584 scene.
//
//   contact_law/rolling=R/viscous=V   core/contact_law.hpp contact_law<R,V> over every touching
//                                      contact of the scene (constants and kinematics precomputed,
//                                      history read from one array and written to another, so
//                                      every iteration does the same work; called out of line)
//   compute_forces/rolling=R/viscous=V compute_forces (core/forces.cpp) over the scene's whole
//                                      Verlet list, no integration; the springs are restored
//                                      between iterations outside the timer
//
//   bare_forces[_inlined|_external_call] a comparison kernel written here without the optional
//                                      features at all: no rolling, no dashpot, no measurement,
//                                      no wall loop, no dispatch table; otherwise the pair loop
//                                      of forces.cpp line for line (prefetch, friction and
//                                      contact-opening energy included). Its forces, torques,
//                                      springs and dissipation are checked to be bitwise equal to
//                                      compute_forces with mu_r = 0, no dashpots, no walls and no
//                                      measurement before any timing. Against
//                                      compute_forces/rolling=0/viscous=0 it shows what the
//                                      unused features cost when they are off. It calls the law
//                                      out of line through a local wrapper; _inlined inlines it;
//                                      _external_call calls the template instance through a
//                                      pointer, with the full calling convention, as
//                                      compute_forces does (GCC keeps it out of line there).
//
// The state is the one bench_dense ends with: the scene run for its 2000 steps, so springs and
// velocities are those of a real run. Counters (time per item, CPU time): per_contact (touching
// contacts), per_particle_step (time / N, i.e. this part's share of one step), and for
// compute_forces per_pair (entries of the Verlet list, touching or not).
// Default: 10 repetitions, aggregates only (mean, median, stddev, cv, min); the usual flags
// override it (--benchmark_repetitions=N, --benchmark_report_aggregates_only=false,
// --benchmark_filter=contact_law, --benchmark_format=json, ...).
#include "core/forces.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

struct Dense {
  SimulationParams par;
  Particles p;
  PeriodicCell cell;
  PairList pairs;
  WallContactList walls;
  // Touching contacts, in Verlet-list order.
  std::vector<Index> ci, cj;
  std::vector<ContactKinematics> kin;
  std::vector<ContactHistory> hist;
};

Dense make_dense() {
  const Scene scene = load_scene(std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml");
  Setup s = make_setup(scene);
  Simulation sim(std::move(s.particles), s.cell, s.params);
  for (std::int64_t k = 1; k <= scene.steps; ++k) sim.step(k == scene.steps);
  Dense d;
  d.par = sim.params();
  d.p = sim.particles();
  d.cell = sim.cell();
  d.pairs = sim.pairs();
  d.walls = sim.wall_contacts();
  // The kinematics exactly as core/forces.cpp pair_forces computes them.
  const Vec3& L = d.cell.lengths();
  const Vec3& edot = d.cell.strain_rate();
  for (std::size_t q = 0; q < d.pairs.size(); ++q) {
    const Index i = d.pairs.i[q], j = d.pairs.j[q];
    const Vec3 dv = d.p.x[j] + image_offset(d.pairs.image[q], L) - d.p.x[i];
    const real_t sum_r = d.p.radius[i] + d.p.radius[j];
    const real_t r2 = dv.squaredNorm();
    if (r2 >= sum_r * sum_r) continue;
    const real_t dist = std::sqrt(r2);
    ContactKinematics k;
    k.n = dv / dist;
    k.un = sum_r - dist;
    const real_t a1 = d.p.radius[i] - 0.5 * k.un, a2 = d.p.radius[j] - 0.5 * k.un;
    k.w1 = d.p.w[i];
    k.w2 = d.p.w[j];
    k.vrel = d.p.v[j] - d.p.v[i] + edot.cwiseProduct(dv) - (a2 * d.p.w[j] + a1 * d.p.w[i]).cross(k.n);
    ContactHistory h;
    h.fs = d.pairs.shear_spring(q);
    h.mr = d.pairs.rolling_spring(q);
    d.ci.push_back(i);
    d.cj.push_back(j);
    d.kin.push_back(k);
    d.hist.push_back(h);
  }
  const MacroState m = sim.macro();
  std::fprintf(stderr,
               "dense-13584 after %lld steps: %zu spheres, %zu pairs in the Verlet list, %zu "
               "touching (%lld contacts by the measure), %lld sliding\n",
               (long long)scene.steps, d.p.n_owned(), d.pairs.size(), d.kin.size(), (long long)m.contacts,
               (long long)m.sliding);
  return d;
}

const Dense& dense() {
  static const Dense d = make_dense();
  return d;
}

ContactLawParams variant_law(ContactLawParams law, bool rolling, bool viscous) {
  if (!rolling) law.rolling_friction = 0;
  if (!viscous) law.damping_rate_n = law.damping_rate_s = law.damping_ratio_n = law.damping_ratio_s = 0;
  return law;
}

// Seconds per item: an iteration-invariant rate of items per second, inverted. The console
// shows it with an SI prefix and the unit s ("11.5ns"); JSON and CSV hold seconds.
benchmark::Counter per_item(double items) {
  return benchmark::Counter(items, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

template <bool Rolling, bool Viscous>
void BM_ContactLaw(benchmark::State& state) {
  const Dense& d = dense();
  const ContactLawParams law = variant_law(d.par.law, Rolling, Viscous);
  const real_t dt = d.par.dt;
  const std::size_t nc = d.kin.size();
  std::vector<PairConstants> c(nc);
  for (std::size_t q = 0; q < nc; ++q)
    c[q] = pair_constants<Rolling, Viscous>(law, d.p.radius[d.ci[q]], d.p.radius[d.cj[q]], d.p.mass[d.ci[q]],
                                            d.p.mass[d.cj[q]]);
  std::vector<ContactHistory> out(nc);
  const ContactKinematics* k = d.kin.data();
  const ContactHistory* h0 = d.hist.data();
  // Called through a pointer the compiler cannot see through, so that every variant is an
  // out-of-line call, as in the pair loop of forces.cpp (GCC 12 keeps all four out of line
  // there); inlined here, some variants would be and others not.
  auto* law_fn = &contact_law<Rolling, Viscous>;
  benchmark::DoNotOptimize(law_fn);
  for (auto _ : state) {
    Vec3 acc = Vec3::Zero();
    for (std::size_t q = 0; q < nc; ++q) {
      ContactHistory h = h0[q];
      const ContactResult r = law_fn(law, c[q], k[q], h, dt);
      out[q] = h;
      acc += r.fn * k[q].n + r.fs + r.mr;
    }
    benchmark::DoNotOptimize(acc);
    benchmark::ClobberMemory();
  }
  state.counters["per_contact"] = per_item(double(nc));
  state.counters["per_particle_step"] = per_item(double(d.p.n_owned()));
}

template <bool Rolling, bool Viscous>
void BM_ComputeForces(benchmark::State& state) {
  const Dense& d = dense();
  const ContactLawParams law = variant_law(d.par.law, Rolling, Viscous);
  Particles p = d.p;
  PairList pairs = d.pairs;
  if (!Rolling) pairs.set_rolling(false);
  WallContactList walls = d.walls;
  Dissipation diss;
  const ForceContext ctx{law, d.par.walls, d.par.gravity, d.par.dt};
  for (auto _ : state) {
    compute_forces(p, d.cell, ctx, pairs, walls, diss, nullptr);
    benchmark::ClobberMemory();
    state.PauseTiming();
    pairs = d.pairs;  // the springs and slots of the saved state
    if (!Rolling) pairs.set_rolling(false);
    state.ResumeTiming();
  }
  benchmark::DoNotOptimize(p.f.data());
  state.counters["per_contact"] = per_item(double(d.kin.size()));
  state.counters["per_pair"] = per_item(double(d.pairs.size()));
  state.counters["per_particle_step"] = per_item(double(d.p.n_owned()));
}

// contact_law<false, false> called out of line, as GCC 12 compiles it in core/forces.cpp (two
// calls per contact in the disassembly of pair_forces<false, false, false>); in this file it
// would inline it, which is a different program.
ContactResult (*volatile law_pointer)(const ContactLawParams&, const PairConstants&, const ContactKinematics&,
                                      ContactHistory&, real_t) = &contact_law<false, false>;

[[gnu::noinline]] ContactResult law_out_of_line(const ContactLawParams& p, const PairConstants& c,
                                                const ContactKinematics& k, ContactHistory& h, real_t dt) {
  return contact_law<false, false>(p, c, k, h, dt);
}

// The pair loop of core/forces.cpp with the optional features removed (see the header).
// Mode 0: the law out of line through a local wrapper (GCC may specialise its calling
// convention); 1: inlined; 2: called through a pointer to the external template instance, i.e.
// with the full C++ calling convention (the 96-byte ContactResult returned through memory), as
// compute_forces calls it.
template <int Mode>
void bare_forces(Particles& P, const PeriodicCell& cell, const ContactLawParams& law, real_t dt, PairList& pl,
                 Dissipation& diss) {
  const std::size_t n = P.size();
  for (std::size_t a = 0; a < n; ++a) P.f[a].setZero();
  for (std::size_t a = 0; a < n; ++a) P.t[a].setZero();
  const Vec3& L = cell.lengths();
  const Vec3& edot = cell.strain_rate();
  std::array<Vec3, 27> shift;
  for (int c = 0; c < 27; ++c) shift[c] = image_offset(c, L);
  const Vec3* x = P.x.data();
  const Vec3* v = P.v.data();
  const Vec3* w = P.w.data();
  const real_t* R = P.radius.data();
  const real_t* m = P.mass.data();
  Vec3* f = P.f.data();
  Vec3* t = P.t.data();
  const Index* pi = pl.i.data();
  const Index* pj = pl.j.data();
  const std::uint8_t* img = pl.image.data();
  std::uint8_t* touching = pl.touching.data();
  real_t e_fric = 0;
  const std::size_t np = pl.size();
  const std::size_t n_owned = P.n_owned();
  constexpr std::size_t kAhead = 8;
  for (std::size_t q = 0; q < np; ++q) {
    if (q + kAhead < np) {
      const Index ia = pi[q + kAhead], ja = pj[q + kAhead];
      __builtin_prefetch(&x[ia]);
      __builtin_prefetch(&x[ja]);
      __builtin_prefetch(&R[ia]);
      __builtin_prefetch(&R[ja]);
    }
    const Index i = pi[q], j = pj[q];
    const Vec3 d = x[j] + shift[img[q]] - x[i];
    const real_t sum_r = R[i] + R[j];
    const real_t r2 = d.squaredNorm();
    if (r2 >= sum_r * sum_r) {
      if (touching[q]) {
        touching[q] = 0;
        const PairConstants c = pair_constants<false, false>(law, R[i], R[j], m[i], m[j]);
        const real_t own_i = std::size_t(i) < n_owned ? 1.0 : 0.0;
        e_fric += own_i * 0.5 * pl.spring_fs[pl.slot[q]].squaredNorm() / c.ks;
        pl.give_slot(q);
      }
      continue;
    }
    if (!touching[q]) pl.take_slot(q);
    touching[q] = 1;
    Vec3& spring = pl.spring_fs[pl.slot[q]];
    const real_t dist = std::sqrt(r2);
    ContactKinematics k;
    k.n = d / dist;
    k.un = sum_r - dist;
    const real_t a1 = R[i] - 0.5 * k.un, a2 = R[j] - 0.5 * k.un;
    k.w1 = w[i];
    k.w2 = w[j];
    k.vrel = v[j] - v[i] + edot.cwiseProduct(d) - (a2 * w[j] + a1 * w[i]).cross(k.n);
    const PairConstants c = pair_constants<false, false>(law, R[i], R[j], m[i], m[j]);
    ContactHistory h;
    h.fs = spring;
    ContactResult r;
    if constexpr (Mode == 1) r = contact_law<false, false>(law, c, k, h, dt);
    else if constexpr (Mode == 0) r = law_out_of_line(law, c, k, h, dt);
    else r = law_pointer(law, c, k, h, dt);
    spring = h.fs;
    const Vec3 F = r.fn * k.n + r.fs;
    const Vec3 nxfs = k.n.cross(r.fs);
    f[j] += F;
    f[i] -= F;
    t[j] -= a2 * nxfs;
    t[i] -= a1 * nxfs;
    const real_t own_i = std::size_t(i) < n_owned ? 1.0 : 0.0;
    e_fric += own_i * r.e_friction;
  }
  diss.friction += e_fric;
}

// The shear spring of every list pair, wherever the list keeps it.
std::vector<Vec3> shear_springs(const PairList& pl) {
  std::vector<Vec3> s(pl.size());
  for (std::size_t q = 0; q < pl.size(); ++q) s[q] = pl.shear_spring(q);
  return s;
}

// bare_forces and compute_forces (features off) from the same state: bitwise the same result.
void check_bare_equals_engine(const Dense& d) {
  const ContactLawParams law = variant_law(d.par.law, false, false);
  Particles p1 = d.p, p2 = d.p;
  PairList l1 = d.pairs, l2 = d.pairs;
  l1.set_rolling(false), l2.set_rolling(false);
  WallContactList walls;  // none
  Dissipation d1, d2;
  const std::vector<Wall> no_walls;
  const ForceContext ctx{law, no_walls, Vec3::Zero(), d.par.dt};
  compute_forces(p1, d.cell, ctx, l1, walls, d1, nullptr);
  bare_forces<0>(p2, d.cell, law, d.par.dt, l2, d2);
  const bool same = p1.f == p2.f && p1.t == p2.t && shear_springs(l1) == shear_springs(l2) &&
      l1.touching == l2.touching && d1.friction == d2.friction;
  std::fprintf(stderr,
               "bare_forces against compute_forces (mu_r = 0, no dashpots, no walls, no "
               "measurement): %s\n",
               same ? "bitwise identical" : "DIFFERENT");
  if (!same) std::exit(1);
  Particles p3 = d.p;
  PairList l3 = d.pairs;
  l3.set_rolling(false);
  Dissipation d3;
  bare_forces<1>(p3, d.cell, law, d.par.dt, l3, d3);
  const bool same3 =
      p1.f == p3.f && p1.t == p3.t && shear_springs(l1) == shear_springs(l3) && d1.friction == d3.friction;
  std::fprintf(stderr, "bare_forces_inlined against compute_forces: %s\n",
               same3 ? "bitwise identical" : "different in the last bits (FMA contraction)");
}

template <int Mode>
void BM_BareForces(benchmark::State& state) {
  const Dense& d = dense();
  const ContactLawParams law = variant_law(d.par.law, false, false);
  Particles p = d.p;
  PairList pairs = d.pairs;
  pairs.set_rolling(false);
  Dissipation diss;
  for (auto _ : state) {
    bare_forces<Mode>(p, d.cell, law, d.par.dt, pairs, diss);
    benchmark::ClobberMemory();
    state.PauseTiming();
    pairs = d.pairs;
    pairs.set_rolling(false);
    state.ResumeTiming();
  }
  benchmark::DoNotOptimize(p.f.data());
  state.counters["per_contact"] = per_item(double(d.kin.size()));
  state.counters["per_pair"] = per_item(double(d.pairs.size()));
  state.counters["per_particle_step"] = per_item(double(d.p.n_owned()));
}

double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

void add(const std::string& name, void (*fn)(benchmark::State&)) {
  benchmark::RegisterBenchmark(name.c_str(), fn)->ComputeStatistics("min", min_of)->Unit(benchmark::kMicrosecond);
}

}  // namespace

int main(int argc, char** argv) {
  add("contact_law/rolling=0/viscous=0", BM_ContactLaw<false, false>);
  add("contact_law/rolling=0/viscous=1", BM_ContactLaw<false, true>);
  add("contact_law/rolling=1/viscous=0", BM_ContactLaw<true, false>);
  add("contact_law/rolling=1/viscous=1", BM_ContactLaw<true, true>);
  add("compute_forces/rolling=0/viscous=0", BM_ComputeForces<false, false>);
  add("compute_forces/rolling=0/viscous=1", BM_ComputeForces<false, true>);
  add("compute_forces/rolling=1/viscous=0", BM_ComputeForces<true, false>);
  add("compute_forces/rolling=1/viscous=1", BM_ComputeForces<true, true>);
  add("bare_forces", BM_BareForces<0>);
  add("bare_forces_inlined", BM_BareForces<1>);
  add("bare_forces_external_call", BM_BareForces<2>);
  // Defaults, before the user's flags (a later flag wins): 10 repetitions, aggregates only.
  std::vector<char*> args{argv[0]};
  char reps[] = "--benchmark_repetitions=10";
  char aggr[] = "--benchmark_report_aggregates_only=true";
  args.push_back(reps);
  args.push_back(aggr);
  for (int a = 1; a < argc; ++a) args.push_back(argv[a]);
  argc = int(args.size());
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  check_bare_equals_engine(dense());  // prepares the state before any timing
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
