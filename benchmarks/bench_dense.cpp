// bench_dense: the shared dense-13584 scene (13,584 spheres, 2000 steps, fixed periodic box),
// timed the way the peers' "Loop time" is: the step loop only, divided by N x steps.
//
//   bench_dense [REPS=5] [PHASE_REPS=1] [scene.toml]
//
// Every repetition starts from the same initial state (the scene's data file, no contact
// history), builds a fresh Simulation outside the timer, then times the 2000 steps, measuring
// the macro state every output_every steps as the peers' thermo output does. After the REPS
// plain repetitions, PHASE_REPS more run with Simulation's phase timers on (integration,
// neighbour check, rebuild, forces). The last line is a machine-readable summary.
#include "benchmarks/median.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

struct RunResult {
  double seconds = 0;
  std::int64_t rebuilds = 0;  // during the loop (the constructor's first build not counted)
  MacroState start;           // after construction (step 0)
  MacroState end;             // at the last step
  double ke_trans = 0;        // translational kinetic energy at the end [J] (the peers' "ke")
  PhaseTimes phases;
};

// How the cell deforms during the timed steps: not at all (the default, the peers' scene), at
// axial strain rates (-r, r/2, r/2) as in a triaxial test, or in simple shear G21 = r (a
// sheared cell, issue 42), r making a strain of 1 % over the steps.
enum class Deform { None, Axial, Shear };

RunResult run_once(const Scene& scene, const Setup& setup, bool phases, Deform deform) {
  Simulation sim(setup.particles, setup.cell, setup.params);  // copies: same start every time
  const real_t rate = 0.01 / (double(scene.steps) * setup.params.dt);
  if (deform == Deform::Axial) sim.cell().set_strain_rate(Vec3(-rate, 0.5 * rate, 0.5 * rate));
  if (deform == Deform::Shear) {
    Mat3 g = Mat3::Zero();
    g(1, 0) = rate;
    sim.cell().set_velocity_gradient(g);
  }
  RunResult r;
  r.start = sim.macro();
  sim.enable_phase_timers(phases);
  const std::int64_t rebuilds0 = sim.rebuild_count();
  const auto t0 = std::chrono::steady_clock::now();
  for (std::int64_t k = 1; k <= scene.steps; ++k) sim.step(k % scene.output_every == 0 || k == scene.steps);
  const auto t1 = std::chrono::steady_clock::now();
  r.seconds = std::chrono::duration<double>(t1 - t0).count();
  r.rebuilds = sim.rebuild_count() - rebuilds0;
  r.end = sim.macro();
  r.phases = sim.phase_times();
  const Particles& p = sim.particles();
  for (std::size_t a = 0; a < p.n_owned(); ++a) r.ke_trans += 0.5 * p.mass[a] * p.v[a].squaredNorm();
  return r;
}

using bench::median;
}  // namespace

int main(int argc, char** argv) {
  try {
    const int reps = argc > 1 ? std::atoi(argv[1]) : 5;
    const int phase_reps = argc > 2 ? std::atoi(argv[2]) : 1;
    const std::string path = argc > 3 ? argv[3] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
    const std::string how = argc > 4 ? argv[4] : "none";
    const Deform deform = how == "axial" ? Deform::Axial : how == "shear" ? Deform::Shear : Deform::None;
    if (reps < 1 || phase_reps < 0 || (deform == Deform::None && how != "none")) {
      std::fprintf(stderr, "usage: bench_dense [REPS>=1] [PHASE_REPS>=0] [scene.toml] [none|axial|shear]\n");
      return 2;
    }
    const Scene scene = load_scene(path);
    const Setup setup = make_setup(scene);
    const std::size_t n = setup.particles.n_owned();
    const double ps = double(n) * double(scene.steps);  // particle-steps per repetition
    std::printf(
        "bench_dense: %s\n  %zu spheres, %lld steps, dt %.6e s, skin %g m, 1 rank "
        "(no domain decomposition yet)\n",
        path.c_str(), n, (long long)scene.steps, setup.params.dt, setup.params.skin);

    std::vector<double> us;
    RunResult first;
    bool identical = true;
    for (int r = 0; r < reps; ++r) {
      const RunResult res = run_once(scene, setup, false, deform);
      us.push_back(res.seconds * 1e6 / ps);
      std::printf(
          "rep %d: %.3f s loop, %.4f us/particle-step, %lld rebuilds, %lld contacts, "
          "p %.6f Pa\n",
          r + 1, res.seconds, us.back(), (long long)res.rebuilds, (long long)res.end.contacts, res.end.p);
      if (r == 0) first = res;
      identical = identical && res.end.p == first.end.p && res.end.contacts == first.end.contacts &&
          res.end.kinetic == first.end.kinetic;
    }

    std::vector<double> ph_int, ph_chk, ph_reb, ph_frc, ph_tot;
    for (int r = 0; r < phase_reps; ++r) {
      const RunResult res = run_once(scene, setup, true, deform);
      const PhaseTimes& t = res.phases;
      const double k = 1e6 / ps;
      ph_int.push_back(t.integrate * k);
      ph_chk.push_back(t.check * k);
      ph_reb.push_back(t.rebuild * k);
      ph_frc.push_back(t.force * k);
      ph_tot.push_back(res.seconds * k);
      std::printf(
          "phase rep %d: %.4f us/particle-step = force %.4f + integrate %.4f + "
          "check %.4f + rebuild %.4f (+ %.4f outside the phases)\n",
          r + 1, ph_tot.back(), ph_frc.back(), ph_int.back(), ph_chk.back(), ph_reb.back(),
          ph_tot.back() - ph_frc.back() - ph_int.back() - ph_chk.back() - ph_reb.back());
      identical = identical && res.end.p == first.end.p && res.end.contacts == first.end.contacts;
    }

    const MacroState& m = first.end;
    const double med = median(us), mn = *std::min_element(us.begin(), us.end());
    std::printf("\nstart state (step 0): p = %.10e Pa, contacts = %lld\n", first.start.p,
                (long long)first.start.contacts);
    std::printf(
        "end state (step %lld): p = %.15e Pa, q = %.6e Pa, contacts = %lld, Z = %.6f, "
        "Z_m = %.6f,\n  kinetic energy = %.15e J (translational %.6e J), sliding = %lld, "
        "rolling = %lld, rebuilds in the loop = %lld;\n  repetitions bitwise "
        "identical: %s\n",
        (long long)scene.steps, m.p, m.q, (long long)m.contacts, m.coordination, m.mech_coordination, m.kinetic,
        first.ke_trans, (long long)m.sliding, (long long)m.rolling, (long long)first.rebuilds,
        identical ? "yes" : "NO");
    std::printf("us per particle-step over %d reps: median %.4f, min %.4f, max %.4f\n", reps, med, mn,
                *std::max_element(us.begin(), us.end()));
    if (phase_reps > 0) {
      const double tot = median(ph_tot);
      auto pct = [&](double x) { return 100.0 * x / tot; };
      std::printf(
          "phases (median of %d timed reps), us per particle-step: force %.4f (%.0f %%), "
          "integrate %.4f (%.0f %%),\n  neighbour check %.4f (%.0f %%), rebuild %.4f "
          "(%.0f %%), total %.4f\n",
          phase_reps, median(ph_frc), pct(median(ph_frc)), median(ph_int), pct(median(ph_int)), median(ph_chk),
          pct(median(ph_chk)), median(ph_reb), pct(median(ph_reb)), tot);
    }
    std::printf(
        "RESULT bench=dense-13584 deform=%s ranks=1 n=%zu steps=%lld reps=%d "
        "us_per_particle_step_median=%.4f min=%.4f rebuilds=%lld contacts=%lld "
        "p_Pa=%.10e ke_J=%.10e ke_trans_J=%.6e p0_Pa=%.10e",
        how.c_str(), n, (long long)scene.steps, reps, med, mn, (long long)first.rebuilds, (long long)m.contacts, m.p,
        m.kinetic, first.ke_trans, first.start.p);
    if (phase_reps > 0)
      std::printf(" force=%.4f integrate=%.4f check=%.4f rebuild=%.4f", median(ph_frc), median(ph_int), median(ph_chk),
                  median(ph_reb));
    std::printf("\n");
    return identical ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_dense: error: %s\n", e.what());
    return 1;
  }
}
