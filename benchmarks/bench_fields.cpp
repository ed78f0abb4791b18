// bench_fields: the cost of one coarse-grained field instant (core/coarse_grain.hpp) at paper
// scale, on the shared dense-13584 packing (13,584 spheres; its contact forces after 200 steps,
// with a friction of 0.3 and mu_r 0.05 so that sliding and rolling contacts exist), serial, as a
// run with [fields] computes it (io/mpi/run_fields.cpp): the particles and the particle-particle
// contact records passed to coarse_grain(). Each figure is the median of REPS repetitions:
//   records    listing the contact records (for_each_contact_record) into CgContacts;
//   grid       coarse_grain() of nothing: the grid's fixed costs (allocation, reduction, fields);
//   particles  coarse_grain() of the particles alone (no contacts);
//   stress     particles and contacts without the networks (quantities without a network one);
//   all        particles, contacts and the 15 networks (every quantity, the default);
//   reused     the same with the previous result's storage reused (as a run does);
//   one time step of the same simulation, for comparison (median over 200 steps).
// The grid and kernel: a Gaussian of width w = WIDTH mean diameters cut at 3 w, spacing
// h = SPACING mean diameters (default 1 and 1).
//
//   bench_fields [REPS=5] [WIDTH=1] [SPACING=1] [scene.toml]
//
// It also prints the volume integral of the contact stress against the Love-Weber sum
// (relative) and a hash of every field's bits (to compare builds). The last line is a
// machine-readable summary.
#include "benchmarks/median.hpp"
#include "core/coarse_grain.hpp"
#include "core/contact_snapshot.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <unordered_map>
#include <vector>

using namespace fabrica;

namespace {
using clock_type = std::chrono::steady_clock;
double since(clock_type::time_point t0) { return std::chrono::duration<double>(clock_type::now() - t0).count(); }
using bench::median;

std::uint64_t hash_fields(const FieldsResult& r) {
  std::uint64_t h = 1469598103934665603ull;
  for (const Field& f : r.fields)
    for (double v : f.values) {
      std::uint64_t b;
      std::memcpy(&b, &v, sizeof b);
      h = (h ^ b) * 1099511628211ull;
    }
  return h;
}
}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::atoi(argv[1]) : 5;
  const double width_d = argc > 2 ? std::atof(argv[2]) : 1.0;
  const double spacing_d = argc > 3 ? std::atof(argv[3]) : 1.0;
  const std::string path = argc > 4 ? argv[4] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
  Scene scene = load_scene(path);
  scene.law.friction = 0.3;
  scene.law.rolling_friction = 0.05;
  Setup setup = make_setup(scene);
  Simulation sim(setup.particles, setup.cell, setup.params);
  const int steps = 200;
  const auto ts = clock_type::now();
  for (int k = 0; k < steps; ++k) sim.step(k == steps - 1);
  const double step_seconds = since(ts) / steps;

  const Simulation& cs = sim;
  const Particles& p = cs.particles();
  std::vector<CgParticle> parts(p.n_owned());
  std::unordered_map<GlobalId, std::size_t> index;
  double dsum = 0;
  for (std::size_t i = 0; i < p.n_owned(); ++i) {
    parts[i] = {p.x[i], p.v[i], p.w[i], p.radius[i], p.mass[i]};
    index.emplace(p.id[i], i);
    dsum += 2 * p.radius[i];
  }
  const double d = dsum / double(p.n_owned());
  std::vector<CgContact> conts;
  std::vector<double> t_rec;
  for (int k = 0; k < reps; ++k) {
    const auto t0 = clock_type::now();
    conts.clear();
    for_each_contact_record(
        p, cs.cell(), cs.params().law, cs.pairs(),
        [&](const ContactRecord& c) {
          const std::size_t i = index.at(c.id1);
          conts.push_back({c, p.x[i], p.radius[i]});
        },
        &cs.params().materials);
    t_rec.push_back(since(t0));
  }

  FieldGrid grid;
  grid.lengths = cs.cell().lengths();
  for (int a = 0; a < 3; ++a) grid.n[a] = int(std::max(1.0, std::round(grid.lengths[a] / (spacing_d * d))));
  FieldKernel kernel;
  kernel.width = width_d * d;
  Domain& dom = sim.domain();
  FieldOptions plain, all;
  plain.networks = false;
  std::vector<double> t_grid, t_part, t_stress, t_all, t_reuse;
  FieldsResult r;
  for (int k = 0; k < reps; ++k) {
    // Each call after the previous result is freed, as at a run's field instants.
    r = FieldsResult{};
    auto t0 = clock_type::now();
    r = coarse_grain(grid, kernel, {}, {}, all, dom);
    t_grid.push_back(since(t0));
    r = FieldsResult{};
    t0 = clock_type::now();
    r = coarse_grain(grid, kernel, parts, {}, all, dom);
    t_part.push_back(since(t0));
    r = FieldsResult{};
    t0 = clock_type::now();
    r = coarse_grain(grid, kernel, parts, conts, plain, dom);
    t_stress.push_back(since(t0));
    r = FieldsResult{};
    t0 = clock_type::now();
    r = coarse_grain(grid, kernel, parts, conts, all, dom);
    t_all.push_back(since(t0));
    // As a run does (io/mpi/run_output.cpp): the previous instant's storage reused.
    FieldsResult spare = std::move(r);
    t0 = clock_type::now();
    r = coarse_grain(grid, kernel, parts, conts, all, dom, &spare);
    t_reuse.push_back(since(t0));
  }
  // The volume integral of the contact stress against the Love-Weber sum.
  Mat3 lw = Mat3::Zero(), integral = Mat3::Zero();
  for (const CgContact& c : conts) lw += c.rec.force() * c.rec.branch.transpose();
  const Field& con = r.field("contact_stress");
  for (std::size_t g = 0; g < grid.nodes(); ++g)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) integral(i, j) += con.values[9 * g + 3 * i + j] * grid.cell_volume();
  const double rel = (integral - lw).norm() / lw.norm();

  const double rec_s = median(t_rec), grid_s = median(t_grid), part_s = median(t_part), stress_s = median(t_stress),
               all_s = median(t_all), reuse_s = median(t_reuse);
  const double np = double(parts.size()), nc = double(conts.size());
  const double us_particle = 1e6 * (part_s - grid_s) / np, us_contact_stress = 1e6 * (stress_s - part_s) / nc,
               us_contact_all = 1e6 * (all_s - part_s) / nc;
  std::printf("dense-13584 (%s): %zu particles, %zu contacts, grid %d x %d x %d, Gaussian w = %.3g d, h = %.3g d\n",
              path.c_str(), parts.size(), conts.size(), grid.n[0], grid.n[1], grid.n[2], width_d, spacing_d);
  std::printf(
      "records %.2f ms, grid %.2f ms, +particles %.2f ms, +contact stress %.2f ms, +networks %.2f ms (medians of %d)\n",
      1e3 * rec_s, 1e3 * grid_s, 1e3 * (part_s - grid_s), 1e3 * (stress_s - part_s), 1e3 * (all_s - stress_s), reps);
  std::printf("per particle %.2f us, per contact %.2f us (stress) %.2f us (with the networks)\n", us_particle,
              us_contact_stress, us_contact_all);
  std::printf("all %.2f ms, all with the storage reused %.2f ms\n", 1e3 * all_s, 1e3 * reuse_s);
  std::printf(
      "one step %.2f ms: one instant (reused) costs %.1f steps; volume integral vs Love-Weber %.2e; hash %016llx\n",
      1e3 * step_seconds, (rec_s + reuse_s) / step_seconds, rel, (unsigned long long)hash_fields(r));
  std::printf(
      "summary: particles=%zu contacts=%zu records_ms=%.3f grid_ms=%.3f particles_ms=%.3f stress_ms=%.3f all_ms=%.3f "
      "reused_ms=%.3f step_ms=%.3f us_per_particle=%.3f us_per_contact=%.3f instant_in_steps=%.2f\n",
      parts.size(), conts.size(), 1e3 * rec_s, 1e3 * grid_s, 1e3 * part_s, 1e3 * stress_s, 1e3 * all_s, 1e3 * reuse_s,
      1e3 * step_seconds, us_particle, us_contact_all, (rec_s + reuse_s) / step_seconds);
  return 0;
}
