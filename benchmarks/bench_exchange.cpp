// The cost of a ghost exchange between two ranks of one node, apart from Fabrica: the floor
// under the 2-rank step's communication (benchmarks/README.md, "What bounds the 2-rank
// efficiency").
//
//   mpirun -np 2 bench_exchange messages|shared [BYTES] [PARTS] [TOUCHED] [STEPS]
//
// Each step, as Fabrica's does: both ranks touch TOUCHED bytes of other data (the step's own
// work, which pushes MPI's buffers and state out of the caches), write BYTES of fresh data
// (the packing of the ghosts' velocities and spins), and exchange them with the other rank
// around a 3-double MPI_Allreduce (the rebuild check):
//   messages: MPI_Irecv / MPI_Isend of the BYTES in PARTS messages, the reduction, MPI_Waitall;
//   shared:   the BYTES written into this rank's half of an MPI_Win_allocate_shared window
//             (two buffers, by step parity, so that a rank never overwrites what the other has
//             not read yet), the reduction as the barrier (MPI_Win_sync either side), then the
//             other rank's BYTES copied out of its window.
// Prints the mean time per step of each part (us, rank 0, the first 100 steps left out) and
// checks that every step received the other rank's data of that step.
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

struct Times {
  double post = 0, reduce = 0, finish = 0;
};

int fail(const char* what) {
  std::fprintf(stderr, "bench_exchange: %s\n", what);
  MPI_Abort(MPI_COMM_WORLD, 2);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const std::string mode = argc > 1 ? argv[1] : "messages";
  const std::size_t bytes = argc > 2 ? std::strtoul(argv[2], nullptr, 10) : 62000;
  const int parts = argc > 3 ? std::atoi(argv[3]) : 2;
  const std::size_t touched = argc > 4 ? std::strtoul(argv[4], nullptr, 10) : 3200000;
  const int steps = argc > 5 ? std::atoi(argv[5]) : 3000;
  if (size != 2) return fail("run it on 2 ranks (mpirun -np 2)");
  if ((mode != "messages" && mode != "shared") || bytes < 8 || parts < 1 || bytes % std::size_t(parts) != 0 ||
      steps <= 100)
    return fail("usage: bench_exchange messages|shared [BYTES] [PARTS dividing BYTES] [TOUCHED] [STEPS > 100]");
  const int other = 1 - rank;
  const bool shared = mode == "shared";

  std::vector<double> work(touched / sizeof(double) + 1, 1.0);
  std::vector<unsigned char> packed(bytes), received(bytes);
  const std::size_t part = bytes / std::size_t(parts);
  std::vector<MPI_Request> requests(2 * std::size_t(parts));

  MPI_Comm node = MPI_COMM_NULL;
  MPI_Win win = MPI_WIN_NULL;
  unsigned char* mine = nullptr;
  unsigned char* theirs = nullptr;
  if (shared) {
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    int node_size = 0;
    MPI_Comm_size(node, &node_size);
    if (node_size != 2) return fail("'shared' needs both ranks on one node");
    MPI_Win_allocate_shared(MPI_Aint(2 * bytes), 1, MPI_INFO_NULL, node, &mine, &win);
    MPI_Aint their_size = 0;
    int unit = 0;
    MPI_Win_shared_query(win, other, &their_size, &unit, &theirs);
    MPI_Win_lock_all(MPI_MODE_NOCHECK, win);
  }

  Times t;
  double sink = 0;
  const double in[3] = {1, 2, 3};
  double out[3];
  for (int k = 0; k < steps; ++k) {
    for (double& x : work) x = x * 1.0000001 + 1e-9;  // the step's own work
    const unsigned char tag = static_cast<unsigned char>(k * 7 + rank + 1);
    std::memset(packed.data(), tag, bytes);  // the packing
    const double t0 = MPI_Wtime();
    if (shared) {
      std::memcpy(mine + std::size_t(k & 1) * bytes, packed.data(), bytes);
      MPI_Win_sync(win);
    } else {
      for (int m = 0; m < parts; ++m)
        MPI_Irecv(received.data() + std::size_t(m) * part, int(part), MPI_BYTE, other, m, MPI_COMM_WORLD,
                  &requests[std::size_t(m)]);
      for (int m = 0; m < parts; ++m)
        MPI_Isend(packed.data() + std::size_t(m) * part, int(part), MPI_BYTE, other, m, MPI_COMM_WORLD,
                  &requests[std::size_t(parts + m)]);
    }
    const double t1 = MPI_Wtime();
    MPI_Allreduce(in, out, 3, MPI_DOUBLE, MPI_MAX, shared ? node : MPI_COMM_WORLD);
    if (shared) MPI_Win_sync(win);
    const double t2 = MPI_Wtime();
    if (shared) std::memcpy(received.data(), theirs + std::size_t(k & 1) * bytes, bytes);
    else MPI_Waitall(int(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
    const double t3 = MPI_Wtime();
    const unsigned char expect = static_cast<unsigned char>(k * 7 + other + 1);
    if (received.front() != expect || received.back() != expect) return fail("stale data received");
    if (k >= 100) t.post += t1 - t0, t.reduce += t2 - t1, t.finish += t3 - t2;
  }
  for (double x : work) sink += x;

  if (shared) {
    MPI_Win_unlock_all(win);
    MPI_Win_free(&win);
    MPI_Comm_free(&node);
  }
  const double n = steps - 100;
  if (rank == 0)
    std::printf(
        "exchange %s: %zu B in %d part(s), %zu B touched between steps: post %.1f, reduction %.1f, "
        "%s %.1f, total %.1f us per step (checksum %g)\n",
        mode.c_str(), bytes, shared ? 1 : parts, touched, 1e6 * t.post / n, 1e6 * t.reduce / n,
        shared ? "copy" : "wait", 1e6 * t.finish / n, 1e6 * (t.post + t.reduce + t.finish) / n, sink > 0 ? 1.0 : 0.0);
  MPI_Finalize();
  return 0;
}
