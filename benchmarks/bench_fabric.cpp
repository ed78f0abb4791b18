// bench_fabric: the cost of one fabric analysis (core/fabric.hpp) at paper scale, on the shared
// dense-13584 packing (13,584 spheres; its contact forces after 200 steps, with a friction of
// 0.3 and mu_r 0.05 so that sliding and rolling contacts exist), serial:
//   contact_records (listing the contacts) and analyse_fabric (classification, three exact
//   reductions, derived quantities), each the median of REPS repetitions;
//   one time step of the same simulation, for comparison (median over 200 steps).
//
//   bench_fabric [REPS=20] [scene.toml]
//
// The last line is a machine-readable summary.
#include "benchmarks/median.hpp"
#include "core/contact_snapshot.hpp"
#include "core/fabric.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace fabrica;

namespace {
using clock_type = std::chrono::steady_clock;
double since(clock_type::time_point t0) { return std::chrono::duration<double>(clock_type::now() - t0).count(); }
using bench::median;
}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::atoi(argv[1]) : 20;
  const std::string path = argc > 2 ? argv[2] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
  Scene scene = load_scene(path);
  scene.law.friction = 0.3;
  scene.law.rolling_friction = 0.05;
  Setup setup = make_setup(scene);
  Simulation sim(setup.particles, setup.cell, setup.params);
  const int steps = 200;
  const auto ts = clock_type::now();
  for (int k = 0; k < steps; ++k) sim.step(k == steps - 1);
  const double step_seconds = since(ts) / steps;
  std::vector<double> t_rec, t_ana;
  FabricResult r;
  std::size_t contacts = 0;
  for (int k = 0; k < reps; ++k) {
    auto t0 = clock_type::now();
    const auto rec = contact_records(sim.particles(), sim.cell(), sim.params().law, sim.pairs());
    t_rec.push_back(since(t0));
    t0 = clock_type::now();
    r = analyse_fabric(rec, sim.cell().volume(), FabricOptions{}, sim.domain());
    t_ana.push_back(since(t0));
    contacts = rec.size();
  }
  const double rec_s = median(t_rec), ana_s = median(t_ana);
  std::printf(
      "dense-13584 (%s): %zu contacts (%lld sliding, %lld rolling per the engine), "
      "q/p %.4f, (q/p)* %.4f\n",
      path.c_str(), contacts, (long long)sim.macro().sliding, (long long)sim.macro().rolling, r.q_p,
      r.q_p_star[kPartAll]);
  std::printf(
      "records %.2f ms, analysis %.2f ms (%.2f us per contact), one step %.2f ms: one "
      "analysis costs %.1f steps\n",
      1e3 * rec_s, 1e3 * ana_s, 1e6 * ana_s / double(contacts), 1e3 * step_seconds, (rec_s + ana_s) / step_seconds);
  std::printf(
      "summary: contacts=%zu records_ms=%.3f analysis_ms=%.3f step_ms=%.3f "
      "analysis_in_steps=%.2f\n",
      contacts, 1e3 * rec_s, 1e3 * ana_s, 1e3 * step_seconds, (rec_s + ana_s) / step_seconds);
  return 0;
}
