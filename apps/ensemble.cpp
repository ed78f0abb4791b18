#include "apps/ensemble.hpp"

#include "core/errors.hpp"
#include "parallel/guard.hpp"

#include <fmt/core.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

namespace fabrica {

namespace fs = std::filesystem;

namespace {
// One run of the ensemble: a realisation's test, or one of its extra consolidations.
struct Job {
  std::uint64_t seed;
  bool consolidation_only;
  real_t consolidation_friction;
  std::string dir;
};

std::vector<Job> jobs_of(const Scene& scene, const fs::path& out) {
  const TriaxialSpec& tx = scene.triaxial;
  std::vector<std::uint64_t> seeds = tx.seeds;
  if (seeds.empty()) seeds.push_back(scene.generate.seed);
  std::vector<Job> jobs;
  for (std::uint64_t s : seeds) {
    const std::string base = "seed_" + std::to_string(s);
    jobs.push_back({s, false, tx.consolidation_friction, (out / base).string()});
    for (real_t c : tx.consolidation_friction_cases)
      if (c != tx.consolidation_friction)
        jobs.push_back({s, true, c, (out / fmt::format("{}_consolidation_{}", base, c)).string()});
  }
  return jobs;
}

// The last row of a CSV file as name -> text.
std::map<std::string, std::string> last_row(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path.string() + ": cannot read it");
  std::string header, line, last;
  std::getline(in, header);
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  std::map<std::string, std::string> row;
  std::istringstream h(header), v(last);
  std::string name, value;
  while (std::getline(h, name, ',') && std::getline(v, value, ',')) row[name] = value;
  return row;
}
}  // namespace

bool is_ensemble(const Scene& scene) {
  return scene.triaxial.enabled &&
      (scene.triaxial.seeds.size() > 1 || !scene.triaxial.consolidation_friction_cases.empty());
}

int ensemble_groups(const Scene& scene, int ranks) {
  const auto n = std::int64_t(jobs_of(scene, ".").size());
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

int run_ensemble(const MpiContext& mpi, const Scene& scene, const std::string& outdir, bool overwrite, bool resume,
                 const RunScene& run_scene) {
  const std::vector<Job> jobs = jobs_of(scene, outdir);
  int groups = 1;
  agree(mpi.comm(), [&] { groups = ensemble_groups(scene, mpi.size()); });
  const int per = mpi.size() / groups, group = mpi.rank() / per;
  MPI_Comm comm = MPI_COMM_NULL;
  MPI_Comm_split(mpi.comm(), group, mpi.rank(), &comm);
  const MpiContext mine(comm);
  if (mpi.rank() == 0) {
    fmt::print("-- {} run(s) (seeds", jobs.size());
    std::uint64_t prev = ~std::uint64_t(0);
    for (const Job& j : jobs)
      if (j.seed != prev) fmt::print(" {}", j.seed), prev = j.seed;
    fmt::print(") in {} group(s) of {} rank(s), each into {}/seed_<seed>[_consolidation_<mu_s>]/\n", groups, per,
               outdir);
    std::fflush(stdout);
  }
  // The first rank of each group but the run's first writes its realisations' log into their
  // directories (the terminal is the run's first rank's).
  int rc = 0;
  for (std::size_t k = std::size_t(group); k < jobs.size(); k += std::size_t(groups)) {
    const Job& job = jobs[k];
    Scene one = scene;
    one.generate.seed = job.seed;
    one.triaxial.seeds.clear();
    one.triaxial.consolidation_friction_cases.clear();
    one.triaxial.consolidation_friction = job.consolidation_friction;
    one.triaxial.consolidation_only = job.consolidation_only;
    const std::string& dir = job.dir;
    const fs::path done = fs::path(dir) / "finished", ckpt = fs::path(dir) / "checkpoint.ckpt";
    // Resuming: what this run left (the same on the group's ranks: one file system).
    const bool finished = resume && fs::exists(done), from_ckpt = resume && !finished && fs::exists(ckpt);
    if (mine.rank() == 0 && mpi.rank() != 0 && !finished) {
      std::error_code ec;
      fs::create_directories(dir, ec);
      if (!std::freopen((fs::path(dir) / "run.log").c_str(), from_ckpt ? "a" : "w", stdout))
        throw std::runtime_error(dir + "/run.log: cannot write the realisation's log there: " + std::strerror(errno));
    }
    if (mpi.rank() == 0)
      fmt::print("-- run {} of {}: seed {}, {}consolidation mu_s = {}, into {}{}\n", k + 1, jobs.size(), job.seed,
                 job.consolidation_only ? "only the " : "", job.consolidation_friction, dir,
                 finished        ? ": finished before, kept"
                     : from_ckpt ? ": continued from its checkpoint"
                     : resume    ? ": started anew"
                                 : "");
    if (finished) continue;
    // Resumed without a checkpoint: its files from the interrupted start are replaced.
    const int r = run_scene(mine, one, dir, from_ckpt ? ckpt.string() : std::string(), overwrite || resume);
    rc = std::max(rc, r);
    agree(mine.comm(), [&] {
      if (mine.rank() != 0 || r != 0) return;
      std::ofstream f(done);
      f << "seed " << job.seed << ", consolidation mu_s " << job.consolidation_friction << '\n';
      f.flush();
      if (!f) throw std::runtime_error(done.string() + ": cannot mark the run finished");
    });
  }
  MPI_Comm_free(&comm);
  MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MAX, mpi.comm());
  // OUT/summary.csv: every realisation's rows, with its seed first; OUT/consolidations.csv: the
  // consolidated state of every consolidation.
  agree(mpi.comm(), [&] {
    if (mpi.rank() != 0) return;
    std::ostringstream cons;
    cons << "seed,consolidation_friction,step,p,void_ratio,Z,Z_m\n";
    for (const Job& j : jobs) {
      const auto r = last_row(fs::path(j.dir) / "consolidation.csv");
      cons << j.seed << ',' << j.consolidation_friction;
      for (const char* c : {"step", "p", "void_ratio", "Z", "Z_m"}) {
        const auto it = r.find(c);
        if (it == r.end()) throw std::runtime_error(j.dir + "/consolidation.csv: no column " + c);
        cons << ',' << it->second;
      }
      cons << '\n';
    }
    const fs::path cpath = fs::path(outdir) / "consolidations.csv";
    std::ofstream cfile(cpath);
    cfile << cons.str();
    cfile.flush();
    if (!cfile) throw std::runtime_error(cpath.string() + ": cannot write the ensemble's consolidations");
    const fs::path path = fs::path(outdir) / "summary.csv";
    std::ostringstream all;
    bool header = false;
    for (const Job& j : jobs) {
      if (j.consolidation_only) continue;
      const std::uint64_t s = j.seed;
      const fs::path one = fs::path(j.dir) / "summary.csv";
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
    fmt::print("ensemble summary written to {} and {}\n", path.string(), cpath.string());
  });
  return rc;
}

}  // namespace fabrica
