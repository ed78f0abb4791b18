// bench_checkpoint: the cost of a checkpoint of the shared dense-13584 scene (or of SCENE, e.g.
// a tiled packing of benchmarks/make_tiled.py).
//
//   mpirun -np P bench_checkpoint [REPS=5] [DIR=.] [SCENE]
//
// The scene runs to its first neighbour rebuild after 100 steps (one rank: the serial domain,
// as a one-rank run of fabrica; several: the MPI domain), then REPS times: writes DIR/bench.ckpt
// (collective MPI-IO, sync, atomic rename), reads and checks it (each rank the header and its
// 1/P of the records with MPI-IO, the checksum summed over the ranks), and builds the restored
// Simulation from it (the records to their owners, decomposition, lists). Times are the
// slowest rank's, between barriers; the minimum and the median over REPS are printed, with a
// mean step of the run for scale. The last line is machine-readable.
#include "benchmarks/median.hpp"
#include "core/simulation.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/serial/scene.hpp"
#include "io/mpi/distributed_setup.hpp"
#include "io/serial/setup.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/mpi_domain.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

using namespace fabrica;

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
// Seconds of fn on the slowest rank.
template <class F>
double timed(MPI_Comm c, F&& fn) {
  MPI_Barrier(c);
  const double t0 = now();
  fn();
  double t = now() - t0;
  MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPI_DOUBLE, MPI_MAX, c);
  return t;
}
using bench::median;
}  // namespace

int main(int argc, char** argv) {
  MpiContext mpi(argc, argv);
  const int reps = argc > 1 ? std::atoi(argv[1]) : 5;
  const std::string dir = argc > 2 ? argv[2] : ".";
  const std::string scene_path = argc > 3 ? argv[3] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
  const Scene scene = load_scene(scene_path);
  // Each rank its share (the data file read in byte ranges on several ranks), as fabrica does.
  Setup s = make_run_setup(scene, mpi.comm(), MpiDomainOptions{});
  const std::int64_t spheres = specimen_totals(s.particles, mpi.comm()).count;
  std::unique_ptr<MpiDomain> domain = mpi.size() > 1 ? std::make_unique<MpiDomain>(mpi.comm()) : nullptr;
  Simulation sim(std::move(s.particles), s.cell, s.params, domain.get(), s.holding);
  const double t_steps = timed(mpi.comm(), [&] {
    while (sim.step_count() < 100 || !sim.rebuilt_last_step()) sim.step(false);
  });
  const double per_step = t_steps / double(sim.step_count());
  const std::string path = (std::filesystem::path(dir) / "bench.ckpt").string();
  std::vector<double> tw, tr, tb;
  std::uint64_t bytes = 0;
  for (int r = 0; r < reps; ++r) {
    tw.push_back(timed(mpi.comm(), [&] {
      CheckpointWriter w(mpi.comm(), scene_fingerprint(scene.text), "run");
      w.add_simulation("sim", sim);
      bytes = w.write(path);
    }));
    std::unique_ptr<Checkpoint> c;
    tr.push_back(timed(mpi.comm(), [&] {
      Checkpoint::Expect ex;
      ex.scene_text = &scene.text;
      c = std::make_unique<Checkpoint>(Checkpoint::read(mpi.comm(), path, ex));
    }));
    std::unique_ptr<MpiDomain> d2 = mpi.size() > 1 ? std::make_unique<MpiDomain>(mpi.comm()) : nullptr;
    tb.push_back(timed(mpi.comm(), [&] { Simulation restored(c->simulation("sim", mpi.comm()), d2.get()); }));
  }
  if (mpi.rank() == 0) {
    std::filesystem::remove(path);
    std::printf("%s (%lld spheres) on %d rank(s), step %lld: checkpoint of %.2f MB\n", scene_path.c_str(),
                (long long)spheres, mpi.size(), (long long)sim.step_count(), double(bytes) / 1e6);
    std::printf("  write (MPI-IO, sync, rename): min %.4f s, median %.4f s\n", *std::min_element(tw.begin(), tw.end()),
                median(tw));
    std::printf("  read and check (each rank its part, checksum summed): min %.4f s, median %.4f s\n",
                *std::min_element(tr.begin(), tr.end()), median(tr));
    std::printf("  restore (to the owners, decomposition, contact lists): min %.4f s, median %.4f s\n",
                *std::min_element(tb.begin(), tb.end()), median(tb));
    std::printf("  one time step of the run: %.4f s\n", per_step);
    std::printf("bench_checkpoint ranks=%d bytes=%llu write_s=%.4f read_s=%.4f restore_s=%.4f step_s=%.5f\n",
                mpi.size(), (unsigned long long)bytes, median(tw), median(tr), median(tb), per_step);
  }
  return 0;
}
