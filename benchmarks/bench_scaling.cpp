// bench_scaling: MPI scaling on the shared dense-13584 scene.
//
//   mpirun -np P bench_scaling strong|weak [REPS=3] [STEPS=2000] [SCENE=dense-13584.toml] [CUT]
//
// strong: the scene's spheres (by default the 13,584 of dense-13584) on P ranks, set up as a run
// sets them up (each rank reads only its share). weak: P copies of the packing stacked along its
// long axis (13,584 spheres per rank; the Cartesian decomposition gives each rank one copy's worth).
// Each repetition builds a fresh Simulation (outside the timer) and times the step loop; the
// time is the slowest rank's. One rank runs the serial code (no MPI domain), as a user's
// one-rank run does. Per phase: the slowest rank's seconds per step. Bytes: sent by all ranks
// per step (ghost updates every step, migration and ghost rebuilds amortised). CUT (work or
// even; by default the scene's [parallel] cut) places the Cartesian runs of bins by the work or
// in equal lengths; the "balance" line gives, for the last repetition, the ranks' max/mean of
// list pairs at the end and of work (1 + list pairs per particle) at the last check of the runs,
// before and after it, and the peak resident memory of the largest rank. The last line is
// machine-readable.
#include "benchmarks/median.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "io/serial/setup.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/mpi_domain.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

double max_all(MPI_Comm c, double v) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, c);
  return v;
}
double sum_all(MPI_Comm c, double v) {
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, c);
  return v;
}
using bench::median;
// P copies of the packing along axis 3, ids shifted by k N.
Setup replicate(const Setup& s, int copies) {
  Setup r = s;
  if (copies == 1) return r;
  const Vec3 L = s.cell.lengths();
  Particles p;
  const std::size_t n = s.particles.n_owned();
  p.reserve(n * copies);
  for (int k = 0; k < copies; ++k)
    for (std::size_t a = 0; a < n; ++a) {
      const real_t R = s.particles.radius[a];
      const real_t rho = s.particles.mass[a] / (4.0 / 3.0 * 3.14159265358979323846 * R * R * R);
      p.add({s.particles.id[a] + GlobalId(k) * GlobalId(n) * 10, R, rho, s.particles.x[a] + Vec3(0, 0, k * L[2])});
    }
  r.particles = std::move(p);
  r.cell = PeriodicCell(Vec3(L[0], L[1], L[2] * copies));
  return r;
}

int run_benchmark(MpiContext& mpi, int argc, char** argv) {
  const MPI_Comm comm = mpi.comm();
  const std::string mode = argc > 1 ? argv[1] : "strong";
  const int reps = argc > 2 ? std::atoi(argv[2]) : 3;
  const int steps = argc > 3 ? std::atoi(argv[3]) : 2000;
  const std::string path = argc > 4 ? argv[4] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
  const Scene scene = load_scene(path);
  const std::string cut = argc > 5 ? argv[5] : scene.parallel.cut;
  if ((mode != "strong" && mode != "weak") || reps < 1 || steps < 1 || (cut != "work" && cut != "even")) {
    if (mpi.rank() == 0) std::fprintf(stderr, "usage: bench_scaling strong|weak [REPS] [STEPS] [SCENE] [work|even]\n");
    return 2;
  }
  MpiDomainOptions options;
  options.balance_work = cut == "work";
  // strong: the run's own set-up (make_run_setup: on several ranks each reads or makes only
  // its share, as `mpirun fabrica run` does, so the peak memory per rank is a run's); weak: the
  // whole packing on every rank, copied P times (13,584 spheres per rank by default).
  Setup setup = mode == "weak" ? replicate(make_setup(scene), mpi.size()) : make_run_setup(scene, comm, options);
  const double n = setup.holding == Holding::Share ? sum_all(comm, double(setup.particles.n_owned()))
                                                   : double(setup.particles.n_owned());
  std::vector<double> us;
  PhaseTimes ph;
  double bytes_per_step = 0, rebuilds = 0, pair_imbalance = 1;
  DomainStats last;
  for (int rep = 0; rep < reps; ++rep) {
    std::unique_ptr<MpiDomain> domain;
    if (mpi.size() > 1) domain = std::make_unique<MpiDomain>(comm, options);
    // The last repetition takes the particles over (no copy held: peak memory as in a run).
    Simulation sim(rep + 1 < reps ? Particles(setup.particles) : std::move(setup.particles), setup.cell, setup.params,
                   domain.get(), setup.holding);
    sim.enable_phase_timers(true);
    const std::int64_t r0 = sim.rebuild_count();
    const DomainStats st0 = domain ? domain->stats() : DomainStats{};
    MPI_Barrier(comm);
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 1; k <= steps; ++k) sim.step(k % 1000 == 0 || k == steps);
    const double secs = max_all(comm, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    us.push_back(secs * 1e6 / (n * steps));
    const PhaseTimes& t = sim.phase_times();
    ph.integrate += max_all(comm, t.integrate) / (reps * steps);
    ph.ghost += max_all(comm, t.ghost) / (reps * steps);
    ph.check += max_all(comm, t.check) / (reps * steps);
    ph.rebuild += max_all(comm, t.rebuild) / (reps * steps);
    ph.migrate += max_all(comm, t.migrate) / (reps * steps);
    ph.force += max_all(comm, t.force) / (reps * steps);
    ph.reduce += max_all(comm, t.reduce) / (reps * steps);
    rebuilds += double(sim.rebuild_count() - r0) / reps;
    if (rep + 1 == reps) {  // every rank's own phases of the last repetition (us per step)
      double touching = 0;
      for (std::uint8_t b : sim.pairs().touching) touching += b;
      const double own[10] = {t.integrate,
                              t.ghost,
                              t.check,
                              t.rebuild,
                              t.migrate,
                              t.force,
                              t.reduce,
                              double(sim.particles().n_owned()),
                              double(sim.pairs().size()),
                              touching};
      std::vector<double> all(10 * std::size_t(mpi.size()));
      MPI_Gather(own, 10, MPI_DOUBLE, all.data(), 10, MPI_DOUBLE, 0, comm);
      for (int r = 0; mpi.rank() == 0 && r < mpi.size(); ++r) {
        const double* a = &all[10 * std::size_t(r)];
        const double f = 1e6 / steps;
        std::printf(
            "rank %d phases (us per step): integrate %.1f, ghost %.1f, check %.1f, rebuild %.1f, "
            "migrate %.1f, force %.1f, reduce %.1f; owned %.0f, list pairs %.0f, touching %.0f\n",
            r, a[0] * f, a[1] * f, a[2] * f, a[3] * f, a[4] * f, a[5] * f, a[6] * f, a[7], a[8], a[9]);
      }
    }
    if (domain) {
      const DomainStats& st = domain->stats();
      const double b = double(st.bytes_forward - st0.bytes_forward) + double(st.bytes_migrated - st0.bytes_migrated) +
          double(st.bytes_ghost_build - st0.bytes_ghost_build);
      bytes_per_step += sum_all(comm, b) / (reps * steps);
      const double pairs = double(sim.pairs().size());
      pair_imbalance = max_all(comm, pairs) / (sum_all(comm, pairs) / mpi.size());
      last = st;
    }
    if (mpi.rank() == 0)
      std::printf("rep %d: %.4f us per particle-step (%.3f s for %d steps of %.0f spheres)\n", rep + 1, us.back(), secs,
                  steps, n);
  }
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const double rss_mb = max_all(comm, double(ru.ru_maxrss) / 1024.0);  // ru_maxrss: KiB on Linux
  if (mpi.rank() == 0) {
    std::printf(
        "balance: cut %s, list pairs max/mean %.4f at the end; work max/mean %.4f before and %.4f "
        "after the last check of the runs (%lld checks, %lld moves); peak RSS %.1f MB (largest rank)\n",
        cut.c_str(), pair_imbalance, last.work_imbalance_before, last.work_imbalance, (long long)last.cut_checks,
        (long long)last.cuts_moved, rss_mb);
    std::printf(
        "phases (slowest rank, us per step): integrate %.1f, ghost update %.1f, rebuild check "
        "(allreduce) %.1f, neighbour build %.1f, migration + ghost build %.1f, force %.1f, "
        "reduction %.1f; %.1f rebuilds\n",
        ph.integrate * 1e6, ph.ghost * 1e6, ph.check * 1e6, ph.rebuild * 1e6, ph.migrate * 1e6, ph.force * 1e6,
        ph.reduce * 1e6, rebuilds);
    std::printf(
        "RESULT bench=scaling mode=%s ranks=%d particles=%.0f steps=%d us_per_particle_step_median=%.4f "
        "min=%.4f bytes_per_step=%.0f bytes_per_rank_step=%.0f\n",
        mode.c_str(), mpi.size(), n, steps, median(us), *std::min_element(us.begin(), us.end()), bytes_per_step,
        bytes_per_step / mpi.size());
  }
  return 0;
}

}  // namespace

// A bad scene or data file ends every rank with its message (no abort trace, no hang).
int main(int argc, char** argv) {
  MpiContext mpi(argc, argv);
  try {
    return run_benchmark(mpi, argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_scaling: %s\n", e.what());
    MPI_Abort(mpi.comm(), 1);
  }
  return 1;
}
