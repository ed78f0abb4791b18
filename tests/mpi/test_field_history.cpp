// The previous field instant's positions kept by home rank (io/mpi/field_history.hpp) and their
// checkpoint sections (apps/app_checkpoint.hpp add_field_history, restore_field_history), on the
// rank count of mpiexec:
//  - 500 particles dealt out over the ranks one way at an instant and another way at the next (as
//    migration moves them), one of them gone and a new one come: the motions over all ranks are
//    the 499 particles found at both instants, each once, at its home rank (id mod P), with its
//    position at each instant and its radius bit for bit; an instant of another case has none;
//  - the kept positions saved in a checkpoint and read back on the same ranks (each rank the same
//    ids and positions, bit for bit, and the instant) and on one rank (all 500 at rank 0);
//  - a checkpoint without the sections (taken before the first instant, or by an older build)
//    restores no instant.
#include "apps/app_checkpoint.hpp"
#include "io/mpi/checkpoint.hpp"
#include "io/mpi/field_history.hpp"
#include "tests/temp_dir.hpp"

#include <gtest/gtest.h>

#include <mpi.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace fabrica {
namespace {

constexpr int kCount = 500;

int rank_of(MPI_Comm c) {
  int r = 0;
  MPI_Comm_rank(c, &r);
  return r;
}
int size_of(MPI_Comm c) {
  int s = 1;
  MPI_Comm_size(c, &s);
  return s;
}

// Particle id's position at instant 'k' (0 or 1) and its radius.
Vec3 position(GlobalId id, int k) { return Vec3(1e-3 * id, 0.3 + 2e-3 * id, 0.1 * k + std::sqrt(double(id))); }
double radius(GlobalId id) { return 0.01 + 1e-5 * id; }

// This rank's owned particles at instant k: ids 0 .. kCount - 1 but 17 at k = 1, and kCount at
// k = 1 only, dealt out by a rule that differs between the instants.
Particles owned(int k, MPI_Comm comm) {
  const int P = size_of(comm), me = rank_of(comm);
  Particles p;
  for (GlobalId id = 0; id <= kCount; ++id) {
    if ((k == 0 && id == kCount) || (k == 1 && id == 17)) continue;
    const int owner = k == 0 ? int((id * 7 + 3) % P) : int((id * 13 + 1) % P);
    if (owner == me) p.add({id, radius(id), 2650.0, position(id, k)});
  }
  return p;
}

bool same_bits(const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0; }

TEST(FieldHistory, PairsTheParticlesOfTwoInstantsAtTheirHomeRanks) {
  const MPI_Comm comm = MPI_COMM_WORLD;
  const int P = size_of(comm), me = rank_of(comm);
  FieldHistory h;
  const FieldHistory::Step first = h.advance(comm, owned(0, comm), {"a", 100, Vec3(1, 2, 3)});
  EXPECT_FALSE(first.from.has_value());
  EXPECT_TRUE(first.motions.empty());
  const FieldHistory::Step second = h.advance(comm, owned(1, comm), {"a", 200, Vec3(1, 2, 2.9)});
  ASSERT_TRUE(second.from.has_value());
  EXPECT_EQ(second.from->step, 100);
  EXPECT_EQ(second.from->lengths, Vec3(1, 2, 3));
  std::vector<int> seen(kCount + 1, 0);
  for (const CgMotion& m : second.motions) {
    const GlobalId id = GlobalId(std::llround(m.x0[0] * 1e3));
    ASSERT_TRUE(id >= 0 && id < kCount);
    ++seen[std::size_t(id)];
    EXPECT_EQ(id % P, me) << "particle " << id << " paired away from its home rank";
    EXPECT_TRUE(same_bits(m.x0, position(id, 0)) && same_bits(m.x1, position(id, 1))) << "particle " << id;
    EXPECT_EQ(m.radius, radius(id));
  }
  MPI_Allreduce(MPI_IN_PLACE, seen.data(), int(seen.size()), MPI_INT, MPI_SUM, comm);
  for (GlobalId id = 0; id <= kCount; ++id)
    EXPECT_EQ(seen[std::size_t(id)], id == 17 || id == kCount ? 0 : 1) << "particle " << id;
  // Another case: its first instant, no motions.
  const FieldHistory::Step other = h.advance(comm, owned(0, comm), {"b", 300, Vec3(1, 2, 3)});
  EXPECT_FALSE(other.from.has_value());
  EXPECT_TRUE(other.motions.empty());
}

// A checkpoint of the history 'h' (or, without it, of no history) at a path every rank shares.
std::string write_checkpoint(MPI_Comm comm, const FieldHistory* h, const std::string& name) {
  std::string path = (test::temp_dir() / name).string();
  int n = int(path.size());
  MPI_Bcast(&n, 1, MPI_INT, 0, comm);  // rank 0's scratch directory
  path.resize(std::size_t(n));
  MPI_Bcast(path.data(), n, MPI_CHAR, 0, comm);
  CheckpointWriter w(comm, 1, "stages");
  FieldWriter app;
  app.i32("phase", 1);
  w.add_fields("app", app);
  if (h) add_field_history(w, *h);
  w.write(path);
  return path;
}

TEST(FieldHistory, CheckpointRoundTripOnAnyRankCount) {
  const MPI_Comm comm = MPI_COMM_WORLD;
  FieldHistory h;
  h.advance(comm, owned(0, comm), {"mur_0.2", 400, Vec3(0.3, 0.2, 0.25)});
  const std::string path = write_checkpoint(comm, &h, "history.ckpt");
  {  // the same ranks: each its own home ids back
    const Checkpoint c = Checkpoint::read(comm, path, {});
    FieldHistory r;
    restore_field_history(c, r, comm);
    ASSERT_TRUE(r.instant().has_value());
    EXPECT_EQ(r.instant()->case_name, "mur_0.2");
    EXPECT_EQ(r.instant()->step, 400);
    EXPECT_EQ(r.instant()->lengths, Vec3(0.3, 0.2, 0.25));
    ASSERT_EQ(r.ids().size(), h.ids().size());
    for (std::size_t k = 0; k < r.ids().size(); ++k) {
      EXPECT_EQ(r.ids()[k], h.ids()[k]);
      EXPECT_TRUE(same_bits(r.positions()[k], h.positions()[k]));
    }
  }
  // One rank reads it alone: every position at its home, rank 0.
  MPI_Comm one;
  MPI_Comm_split(comm, rank_of(comm) == 0 ? 0 : MPI_UNDEFINED, 0, &one);
  if (one != MPI_COMM_NULL) {
    const Checkpoint c = Checkpoint::read(one, path, {});
    FieldHistory r;
    restore_field_history(c, r, one);
    ASSERT_EQ(r.ids().size(), std::size_t(kCount));
    for (std::size_t k = 0; k < r.ids().size(); ++k) {
      EXPECT_EQ(r.ids()[k], GlobalId(k));
      EXPECT_TRUE(same_bits(r.positions()[k], position(GlobalId(k), 0)));
    }
    MPI_Comm_free(&one);
  }
  MPI_Barrier(comm);
}

TEST(FieldHistory, ACheckpointWithoutItRestoresNoInstant) {
  const MPI_Comm comm = MPI_COMM_WORLD;
  const std::string path = write_checkpoint(comm, nullptr, "none.ckpt");
  const Checkpoint c = Checkpoint::read(comm, path, {});
  FieldHistory r;
  r.advance(comm, owned(0, comm), {"a", 100, Vec3(1, 1, 1)});  // anything kept goes
  restore_field_history(c, r, comm);
  EXPECT_FALSE(r.instant().has_value());
  EXPECT_TRUE(r.ids().empty());
  // An empty history writes no sections either.
  const std::string empty = write_checkpoint(comm, &r, "empty.ckpt");
  EXPECT_FALSE(Checkpoint::read(comm, empty, {}).has("fields.instant"));
}

}  // namespace
}  // namespace fabrica
