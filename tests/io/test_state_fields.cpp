// The particle records of a checkpoint read by the layout they name (io/mpi/checkpoint_older.hpp
// ParticleRecordReader): this build's, format 6's with the three values this build derives,
// and the refusals, each naming the field.
#include "core/errors.hpp"
#include "io/mpi/checkpoint_older.hpp"
#include "io/mpi/state_fields.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace fabrica {
namespace {

Particles two() {
  Particles p;
  p.add({11, 0.004, 2650.0, Vec3(0.1, 0.2, 0.3), Vec3(1, 2, 3), Vec3(4, 5, 6)});
  p.add({12, 0.007, 1500.0, Vec3(0.4, 0.5, 0.6), Vec3(-1, -2, -3), Vec3(-4, -5, -6)});
  p.f[1] = Vec3(7, 8, 9);
  p.t[0] = Vec3(-7, -8, -9);
  return p;
}

void put(std::string& s, double v) {
  char b[8];
  std::memcpy(b, &v, 8);
  s.append(b, 8);  // little-endian machines only, as the test runs on
}
void put(std::string& s, const Vec3& v) {
  for (int k = 0; k < 3; ++k) put(s, v[k]);
}

std::string what(const std::string& schema) {
  try {
    ParticleRecordReader r(schema, "ck.ckpt: section sim.global");
  } catch (const InputError& e) { return e.what(); }
  return "";
}

TEST(ParticleRecords, ThisBuildsLayoutRoundTrips) {
  const Particles p = two();
  std::string bytes;
  write_particles(p, bytes);
  const ParticleRecordReader r(particle_record_schema(), "here");
  ASSERT_EQ(r.bytes(), particle_record_bytes());
  ASSERT_EQ(r.bytes(), 144u);
  Particles q;
  r.read(bytes.data(), 2, q);
  ASSERT_EQ(q.n_owned(), 2u);
  for (std::size_t a = 0; a < 2; ++a) {
    EXPECT_EQ(q.id[a], p.id[a]);
    EXPECT_EQ(q.x[a], p.x[a]);
    EXPECT_EQ(q.v[a], p.v[a]);
    EXPECT_EQ(q.w[a], p.w[a]);
    EXPECT_EQ(q.f[a], p.f[a]);
    EXPECT_EQ(q.t[a], p.t[a]);
    EXPECT_EQ(q.radius[a], p.radius[a]);
    EXPECT_EQ(q.mass[a], p.mass[a]);
  }
}

TEST(ParticleRecords, FormatSixSkipsTheDerivedValues) {
  // A format-6 record (168 B) as the builds before 8c0493c wrote it, with the derived values
  // set to garbage: they are skipped, and what this build derives is from mass and radius.
  const Particles p = two();
  const std::string v6 =
      "x:f64[3];v:f64[3];w:f64[3];radius:f64;mass:f64;inertia:f64;inv_mass:f64;inv_inertia:f64;"
      "id:i64;f:f64[3];t:f64[3]";
  std::string bytes;
  for (std::size_t a = 0; a < 2; ++a) {
    put(bytes, p.x[a]);
    put(bytes, p.v[a]);
    put(bytes, p.w[a]);
    put(bytes, p.radius[a]);
    put(bytes, p.mass[a]);
    put(bytes, 1e30);
    put(bytes, -1.0);
    put(bytes, 0.0);
    const std::int64_t id = p.id[a];
    bytes.append(reinterpret_cast<const char*>(&id), 8);
    put(bytes, p.f[a]);
    put(bytes, p.t[a]);
  }
  const ParticleRecordReader r(v6, "here");
  ASSERT_EQ(r.bytes(), 168u);
  ASSERT_EQ(bytes.size(), 2 * r.bytes());
  Particles q;
  r.read(bytes.data(), 2, q);
  for (std::size_t a = 0; a < 2; ++a) {
    EXPECT_EQ(q.id[a], p.id[a]);
    EXPECT_EQ(q.x[a], p.x[a]);
    EXPECT_EQ(q.t[a], p.t[a]);
    EXPECT_EQ(q.mass[a], p.mass[a]);
    EXPECT_EQ(q.inertia(a), p.inertia(a));
    EXPECT_EQ(q.inv_inertia(a), p.inv_inertia(a));
  }
}

TEST(ParticleRecords, OtherLayoutsAreRefusedNamingTheField) {
  const std::string mine = particle_record_schema();
  EXPECT_NE(what(mine + ";charge:f64").find("field 'charge:f64' is not one this build reads"), std::string::npos)
      << what(mine + ";charge:f64");
  EXPECT_NE(what(mine + ";mass:f64").find("field 'mass:f64' given twice"), std::string::npos);
  std::string no_mass = mine;
  no_mass.erase(no_mass.find("mass:f64;"), 9);
  EXPECT_NE(what(no_mass).find("have no field 'mass:f64'"), std::string::npos) << what(no_mass);
  std::string single = mine;
  single.replace(single.find("radius:f64"), 10, "radius:f32");
  EXPECT_NE(what(single).find("field 'radius:f32'"), std::string::npos);
  EXPECT_EQ(what(single).rfind("ck.ckpt: section sim.global: ", 0), 0u) << what(single);
  EXPECT_EQ(what(mine), "");
}

}  // namespace
}  // namespace fabrica
