// bench_io: write bandwidth of one snapshot (particles and contacts, io/mpi/run_output.hpp) of the
// shared dense-13584 packing, on however many ranks it is started.
//
//   mpirun -np P bench_io [REPS=7] [DIR=/tmp] [scene.toml]
//
// The scene's data file (benchmarks/dense-13584.toml: ../shared/bench/dense-13584/dense.data)
// is read with io/serial/lammps_data, decomposed over the ranks and advanced 10 steps so that the
// contact list is built. Then REPS snapshots are written into DIR/bench_io-npP/run.h5, each as
// its own case, each timed from a barrier to the end of RunOutput::snapshot (which includes the
// redistribution by id, the collective writes, the H5Fflush and the XDMF rewrite). Bandwidth =
// bytes of data written / time; the median over the repetitions is reported. The last line is
// a machine-readable summary. The repetitions alternate between datasets with HDF5's Fletcher-32
// checksum (as Fabrica writes them) and without (h5::set_checksums(false)), so that the cost of
// the checksum is measured in the same sitting: seconds_median is with it, _nock without. Then
// rank 0 reads the whole file back verifying every checksum (io/mpi/verify.hpp).
#include "benchmarks/median.hpp"
#include "io/mpi/run_output.hpp"
#include "io/mpi/verify.hpp"
#include "io/serial/setup.hpp"
#include "parallel/mpi_context.hpp"
#include "parallel/mpi_domain.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

using bench::median;
}  // namespace

int main(int argc, char** argv) {
  MpiContext mpi(argc, argv);
  const bool root = mpi.rank() == 0;
  try {
    const int reps = argc > 1 ? std::atoi(argv[1]) : 7;
    const std::string dir = argc > 2 ? argv[2] : "/tmp";
    const std::string path = argc > 3 ? argv[3] : std::string(FABRICA_SOURCE_DIR) + "/benchmarks/dense-13584.toml";
    if (reps < 1) {
      if (root) std::fprintf(stderr, "usage: bench_io [REPS>=1] [DIR] [scene.toml]\n");
      return 2;
    }
    Scene scene = load_scene(path);
    Setup s = make_setup(scene);
    std::unique_ptr<MpiDomain> domain;
    if (mpi.size() > 1) domain = std::make_unique<MpiDomain>(mpi.comm(), MpiDomainOptions{});
    Simulation sim(std::move(s.particles), s.cell, s.params, domain.get());
    for (int k = 0; k < 10; ++k) sim.step(k == 9);
    const std::string out = (std::filesystem::path(dir) / ("bench_io-np" + std::to_string(mpi.size()))).string();
    const char* io = std::getenv("OMPI_MCA_io");
    if (root)
      std::printf("bench_io: %s\n  %lld spheres, %lld contacts, %d rank(s), MPI-IO component %s, file %s\n",
                  path.c_str(), (long long)sim.macro().particles, (long long)sim.macro().contacts, mpi.size(),
                  io ? io : "(Open MPI default)", RunOutput::file_name(out).c_str());
    std::vector<double> secs, mbps, secs_nock;
    double bytes = 0;
    {
      RunOutput output(mpi.comm(), scene, out, true);
      for (int r = 0; r < 2 * reps; ++r) {
        const bool checked = r % 2 == 0;
        h5::set_checksums(checked);
        const double b0 = output.bytes();
        MPI_Barrier(mpi.comm());
        const auto t0 = std::chrono::steady_clock::now();
        output.snapshot("rep_" + std::to_string(r), sim, Vec3::Zero());
        MPI_Barrier(mpi.comm());
        const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        bytes = output.bytes() - b0;
        if (checked) {
          secs.push_back(t);
          mbps.push_back(bytes / t / 1e6);
        } else {
          secs_nock.push_back(t);
        }
        if (root)
          std::printf("rep %d (%s checksum): %.2f MB in %.4f s = %.1f MB/s\n", r / 2 + 1, checked ? "with" : "without",
                      bytes / 1e6, t, bytes / t / 1e6);
      }
      output.close();
    }
    h5::set_checksums(true);
    VerifyReport ver;
    if (root) ver = verify_run_file(RunOutput::file_name(out));
    if (root) {
      std::printf(
          "RESULT bench=io ranks=%d particles=%lld contacts=%lld mb_per_snapshot=%.3f "
          "seconds_median=%.4f mb_per_s_median=%.1f seconds_median_nock=%.4f "
          "checksum_cost_percent=%.1f verify_mb_per_s=%.1f reps=%d\n",
          mpi.size(), (long long)sim.macro().particles, (long long)sim.macro().contacts, bytes / 1e6, median(secs),
          median(mbps), median(secs_nock), 100 * (median(secs) / median(secs_nock) - 1), ver.bytes / ver.seconds / 1e6,
          reps);
      std::filesystem::remove_all(out);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_io: error on rank %d: %s\n", mpi.rank(), e.what());
    MPI_Abort(mpi.comm(), 1);
  }
  return 1;
}
