// io/mpi/fields: named, typed, little-endian values, checked against their layout when read.
#include "core/errors.hpp"
#include "io/mpi/fields.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

using namespace fabrica;

namespace {
std::string hex(const std::string& b) {
  static const char* d = "0123456789abcdef";
  std::string s;
  for (unsigned char c : b) s += {d[c >> 4], d[c & 15]};
  return s;
}
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) { return e.what(); }
  return "";
}
}  // namespace

TEST(Fields, BytesAreLittleEndianWithoutPadding) {
  FieldWriter w;
  w.u8("a", 0x12).i32("b", -2).u64("c", 0x0102030405060708ull).f64("d", 1.0);
  // IEEE 754 binary64 1.0 is 0x3ff0000000000000; -2 in two's complement is 0xfffffffe.
  EXPECT_EQ(hex(w.bytes()),
            "12"
            "feffffff"
            "0807060504030201"
            "000000000000f03f");
  EXPECT_EQ(w.schema(), "a:u8;b:i32;c:u64;d:f64");
}

TEST(Fields, RoundTripIsExact) {
  const Vec3 v(0.1, -1e-300, std::numeric_limits<double>::infinity());
  Mat3 m;
  m << 1, 2, 3, 4, 5, 6, 7, 8, std::nextafter(9.0, 10.0);
  FieldWriter w;
  w.vec3("v", v).mat3("m", m).i64("i", std::numeric_limits<std::int64_t>::min()).text("t", "a;b:c");
  w.u32("u", 4000000000u).f64("nan", std::nan(""));
  EXPECT_EQ(w.schema(), "v:f64[3];m:f64[9];i:i64;t:text;u:u32;nan:f64");
  FieldReader r(w.schema(), w.bytes().data(), w.bytes().size(), "test");
  EXPECT_EQ(r.vec3("v"), v);
  EXPECT_EQ(r.mat3("m"), m);  // row-major: m(2,2) is the last value
  EXPECT_EQ(r.i64("i"), std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(r.text("t"), "a;b:c");
  EXPECT_EQ(r.u32("u"), 4000000000u);
  EXPECT_TRUE(std::isnan(r.f64("nan")));
  r.done();
}

TEST(Fields, AnotherLayoutIsRefusedNamingTheField) {
  FieldWriter w;
  w.f64("law.friction", 0.3).f64("law.rolling_friction", 0.1);
  // A build that reads another field in second place.
  FieldReader r(w.schema(), w.bytes().data(), w.bytes().size(), "ck.ckpt: section sim.global");
  r.f64("law.friction");
  EXPECT_EQ(error_of([&] { r.f64("law.damping"); }),
            "ck.ckpt: section sim.global: field 2 is 'law.rolling_friction:f64', this build reads "
            "'law.damping:f64' there: written by another version");
  // The same name with another type.
  FieldReader t(w.schema(), w.bytes().data(), w.bytes().size(), "x");
  EXPECT_NE(error_of([&] { t.i64("law.friction"); })
                .find("is 'law.friction:f64', this build reads "
                      "'law.friction:i64'"),
            std::string::npos);
  // A field this build does not read, or one the file lacks.
  FieldReader u(w.schema(), w.bytes().data(), w.bytes().size(), "x");
  u.f64("law.friction");
  EXPECT_NE(error_of([&] { u.done(); }).find("field 2 'law.rolling_friction:f64' is not read"), std::string::npos);
  u.f64("law.rolling_friction");
  EXPECT_NE(error_of([&] { u.f64("more"); }).find("no field 'more:f64'"), std::string::npos);
}

TEST(Fields, ShortOrLongBytesAreCorruption) {
  FieldWriter w;
  w.f64("a", 1).text("b", "hello");
  const std::string b = w.bytes();
  FieldReader s(w.schema(), b.data(), 5, "x");
  EXPECT_NE(error_of([&] { s.f64("a"); }).find("ends early, in field 'a:f64'"), std::string::npos);
  FieldReader l(w.schema(), b.data(), b.size() - 2, "x");
  l.f64("a");
  EXPECT_NE(error_of([&] { l.text("b"); }).find("claims 5 bytes"), std::string::npos);
  const std::string longer = b + "zz";
  FieldReader e(w.schema(), longer.data(), longer.size(), "x");
  e.f64("a");
  e.text("b");
  EXPECT_NE(error_of([&] { e.done(); }).find("2 bytes after the last field"), std::string::npos);
}
