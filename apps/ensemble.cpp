#include "apps/ensemble.hpp"

#include "io/errors.hpp"
#include "parallel/guard.hpp"

#include <fmt/core.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace fabrica {

namespace fs = std::filesystem;

int ensemble_groups(const Scene& scene, int ranks) {
  const auto n = std::int64_t(scene.triaxial.seeds.size());
  const std::int64_t g = scene.parallel.groups;
  if (g == 0) {  // "auto": the most groups that divide the ranks, one realisation each at least
    std::int64_t best = 1;
    for (std::int64_t k = 1; k <= std::min<std::int64_t>(ranks, n); ++k)
      if (ranks % k == 0) best = k;
    return int(best);
  }
  const std::string where = scene.path + ": [parallel] groups = " + std::to_string(g) + ": ";
  if (g > ranks) throw InputError(where + "more groups than the " + std::to_string(ranks) + " rank(s) of the run");
  if (ranks % g != 0)
    throw InputError(where + "does not divide the " + std::to_string(ranks) + " ranks of the run into equal groups");
  return int(g);
}

namespace {
std::string seed_dir(const fs::path& out, std::uint64_t seed) {
  return (out / ("seed_" + std::to_string(seed))).string();
}
}  // namespace

int run_ensemble(const MpiContext& mpi, const Scene& scene, const std::string& outdir, const RunScene& run_scene) {
  const std::vector<std::uint64_t>& seeds = scene.triaxial.seeds;
  int groups = 1;
  agree(mpi.comm(), [&] { groups = ensemble_groups(scene, mpi.size()); });
  const int per = mpi.size() / groups, group = mpi.rank() / per;
  MPI_Comm comm = MPI_COMM_NULL;
  MPI_Comm_split(mpi.comm(), group, mpi.rank(), &comm);
  const MpiContext mine(comm);
  if (mpi.rank() == 0) {
    fmt::print("-- {} realisation(s) (seeds", seeds.size());
    for (std::uint64_t s : seeds) fmt::print(" {}", s);
    fmt::print(") in {} group(s) of {} rank(s), each into {}/seed_<seed>/\n", groups, per, outdir);
    std::fflush(stdout);
  }
  // The first rank of each group but the run's first writes its realisations' log into their
  // directories (the terminal is the run's first rank's).
  int rc = 0;
  for (std::size_t k = std::size_t(group); k < seeds.size(); k += std::size_t(groups)) {
    Scene one = scene;
    one.generate.seed = seeds[k];
    one.triaxial.seeds.clear();
    const std::string dir = seed_dir(outdir, seeds[k]);
    if (mine.rank() == 0 && mpi.rank() != 0) {
      std::error_code ec;
      fs::create_directories(dir, ec);
      if (!std::freopen((fs::path(dir) / "run.log").c_str(), "w", stdout))
        throw std::runtime_error(dir + "/run.log: cannot write the realisation's log there: " + std::strerror(errno));
    }
    if (mpi.rank() == 0) fmt::print("-- realisation {} of {}: seed {}, into {}\n", k + 1, seeds.size(), seeds[k], dir);
    rc = std::max(rc, run_scene(mine, one, dir));
  }
  MPI_Comm_free(&comm);
  MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MAX, mpi.comm());
  // OUT/summary.csv: every realisation's rows, with its seed first.
  agree(mpi.comm(), [&] {
    if (mpi.rank() != 0) return;
    const fs::path path = fs::path(outdir) / "summary.csv";
    std::ostringstream all;
    bool header = false;
    for (std::uint64_t s : seeds) {
      const fs::path one = fs::path(seed_dir(outdir, s)) / "summary.csv";
      std::ifstream in(one);
      if (!in) throw std::runtime_error(one.string() + ": cannot read the realisation's summary");
      std::string line;
      bool first = true;
      while (std::getline(in, line)) {
        if (first) {
          if (!header) all << "seed," << line << '\n';
          header = true, first = false;
          continue;
        }
        if (!line.empty()) all << s << ',' << line << '\n';
      }
    }
    std::ofstream out(path);
    out << all.str();
    out.flush();
    if (!out) throw std::runtime_error(path.string() + ": cannot write the ensemble's summary");
    fmt::print("ensemble summary written to {}\n", path.string());
  });
  return rc;
}

}  // namespace fabrica
