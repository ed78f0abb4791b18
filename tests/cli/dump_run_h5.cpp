// dump_run_h5 FILE: everything the C++ reader (io/mpi/snapshot.hpp) gives for a run file, as text
// with round-trip precision (%.17g), for cli.output.python_reader, which compares it with what
// apps/fabrica_h5.py reads from the same file. One record a line:
//   info <ranks> <version> <git_describe> <scene_path>
//   series <case> <rows> <column,column,...>      then: col <name> v v ...; step s s ...; stage ...
//   snapshot <case> <step> <time> L1 L2 L3 e1 e2 e3 H11 H12 H13 H21 ... H33 <N> <M>
//   particle <id> x y z vx vy vz wx wy wz r        (N lines, after each snapshot line)
//   contact <id1> <id2> n(3) b(3) overlap fn ft(3) mr(3) sliding rolling   (M lines)
#include "io/mpi/snapshot.hpp"

#include <cstdio>
#include <exception>

namespace {

void vec(const fabrica::Vec3& v) { std::printf(" %.17g %.17g %.17g", v[0], v[1], v[2]); }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: dump_run_h5 FILE\n");
    return 2;
  }
  const std::string path = argv[1];
  try {
    const fabrica::RunFileInfo ri = fabrica::read_run_info(path);
    std::printf("info %lld %s %s %s\n", static_cast<long long>(ri.ranks), ri.version.c_str(), ri.git_describe.c_str(),
                ri.scene_path.c_str());
    for (const std::string& c : fabrica::list_series(path)) {
      const fabrica::Series s = fabrica::read_series(path, c);
      std::string cols;
      for (const std::string& n : s.columns) cols += (cols.empty() ? "" : ",") + n;
      std::printf("series %s %zu %s\n", c.c_str(), s.rows(), cols.c_str());
      for (std::size_t k = 0; k < s.columns.size(); ++k) {
        std::printf("col %s", s.columns[k].c_str());
        for (double v : s.values[k]) std::printf(" %.17g", v);
        std::printf("\n");
      }
      std::printf("step");
      for (std::int64_t v : s.step) std::printf(" %lld", static_cast<long long>(v));
      std::printf("\nstage");
      for (const std::string& v : s.stage) std::printf(" %s", v.c_str());
      std::printf("\n");
    }
    for (const fabrica::SnapshotInfo& si : fabrica::list_snapshots(path)) {
      std::printf("snapshot %s %lld %.17g", si.case_name.c_str(), static_cast<long long>(si.step), si.time);
      vec(si.cell_lengths), vec(si.strain);
      for (int r = 0; r < 3; ++r) vec(si.cell_matrix.row(r).transpose());
      std::printf(" %lld %lld\n", static_cast<long long>(si.particles), static_cast<long long>(si.contacts));
      const fabrica::ParticleSnapshot p = fabrica::read_particle_snapshot(path, si.case_name, si.step);
      for (std::size_t i = 0; i < p.id.size(); ++i) {
        std::printf("particle %lld", static_cast<long long>(p.id[i]));
        vec(p.position[i]), vec(p.velocity[i]), vec(p.spin[i]);
        std::printf(" %.17g\n", p.radius[i]);
      }
      const fabrica::ContactSnapshot cs = fabrica::read_contact_snapshot(path, si.case_name, si.step);
      for (const fabrica::ContactRecord& c : cs.contacts) {
        std::printf("contact %lld %lld", static_cast<long long>(c.id1), static_cast<long long>(c.id2));
        vec(c.normal), vec(c.branch);
        std::printf(" %.17g %.17g", c.overlap, c.fn);
        vec(c.ft), vec(c.mr);
        std::printf(" %d %d\n", int(c.sliding), int(c.rolling));
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dump_run_h5: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
