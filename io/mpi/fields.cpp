#include "io/mpi/fields.hpp"

#include "core/errors.hpp"

#include <cstring>

namespace fabrica {

void put_le(std::string& out, std::uint64_t bits, int bytes) {
  for (int k = 0; k < bytes; ++k) out.push_back(char((bits >> (8 * k)) & 0xffu));
}

std::uint64_t get_le(const char* in, int bytes) {
  std::uint64_t v = 0;
  for (int k = 0; k < bytes; ++k) v |= std::uint64_t(static_cast<unsigned char>(in[k])) << (8 * k);
  return v;
}

namespace {
std::uint64_t bits_of(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}
double double_of(std::uint64_t b) {
  double v;
  std::memcpy(&v, &b, sizeof v);
  return v;
}
std::string entry_text(const char* name, const char* type, int n) {
  std::string e = std::string(name) + ":" + type;
  if (n != 1) e += "[" + std::to_string(n) + "]";
  return e;
}
}  // namespace

void FieldWriter::entry(const char* name, const char* type, int n) {
  if (!schema_.empty()) schema_ += ';';
  schema_ += entry_text(name, type, n);
}

FieldWriter& FieldWriter::u8(const char* name, std::uint8_t v) {
  entry(name, "u8", 1);
  put_le(bytes_, v, 1);
  return *this;
}
FieldWriter& FieldWriter::i32(const char* name, std::int32_t v) {
  entry(name, "i32", 1);
  put_le(bytes_, std::uint32_t(v), 4);
  return *this;
}
FieldWriter& FieldWriter::u32(const char* name, std::uint32_t v) {
  entry(name, "u32", 1);
  put_le(bytes_, v, 4);
  return *this;
}
FieldWriter& FieldWriter::i64(const char* name, std::int64_t v) {
  entry(name, "i64", 1);
  put_le(bytes_, std::uint64_t(v), 8);
  return *this;
}
FieldWriter& FieldWriter::u64(const char* name, std::uint64_t v) {
  entry(name, "u64", 1);
  put_le(bytes_, v, 8);
  return *this;
}
FieldWriter& FieldWriter::f64(const char* name, double v) {
  entry(name, "f64", 1);
  put_le(bytes_, bits_of(v), 8);
  return *this;
}
FieldWriter& FieldWriter::vec3(const char* name, const Vec3& v) {
  entry(name, "f64", 3);
  for (int k = 0; k < 3; ++k) put_le(bytes_, bits_of(v[k]), 8);
  return *this;
}
FieldWriter& FieldWriter::mat3(const char* name, const Mat3& m) {
  entry(name, "f64", 9);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) put_le(bytes_, bits_of(m(r, c)), 8);
  return *this;
}
FieldWriter& FieldWriter::text(const char* name, const std::string& v) {
  entry(name, "text", 1);
  put_le(bytes_, v.size(), 8);
  bytes_ += v;
  return *this;
}

FieldReader::FieldReader(const std::string& schema, const char* bytes, std::size_t size, std::string where)
    : where_(std::move(where)), data_(bytes), size_(size) {
  std::size_t at = 0;
  while (at <= schema.size() && !schema.empty()) {
    const std::size_t end = std::min(schema.find(';', at), schema.size());
    fields_.push_back(schema.substr(at, end - at));
    at = end + 1;
  }
}

void FieldReader::expect(const char* name, const char* type, int n) {
  const std::string want = entry_text(name, type, n);
  if (field_ >= fields_.size())
    throw InputError(where_ + ": no field '" + want + "' (the file's layout ends after " +
                     std::to_string(fields_.size()) + " fields): written by another version");
  if (fields_[field_] != want)
    throw InputError(where_ + ": field " + std::to_string(field_ + 1) + " is '" + fields_[field_] +
                     "', this build reads '" + want + "' there: written by another version");
  ++field_;
}

const char* FieldReader::take(std::size_t n) {
  if (size_ - pos_ < n) throw InputError(where_ + ": ends early, in field '" + fields_[field_ - 1] + "' (corrupted)");
  const char* p = data_ + pos_;
  pos_ += n;
  return p;
}

std::uint8_t FieldReader::u8(const char* name) {
  expect(name, "u8", 1);
  return std::uint8_t(get_le(take(1), 1));
}
std::int32_t FieldReader::i32(const char* name) {
  expect(name, "i32", 1);
  return std::int32_t(std::uint32_t(get_le(take(4), 4)));
}
std::uint32_t FieldReader::u32(const char* name) {
  expect(name, "u32", 1);
  return std::uint32_t(get_le(take(4), 4));
}
std::int64_t FieldReader::i64(const char* name) {
  expect(name, "i64", 1);
  return std::int64_t(get_le(take(8), 8));
}
std::uint64_t FieldReader::u64(const char* name) {
  expect(name, "u64", 1);
  return get_le(take(8), 8);
}
double FieldReader::f64(const char* name) {
  expect(name, "f64", 1);
  return double_of(get_le(take(8), 8));
}
Vec3 FieldReader::vec3(const char* name) {
  expect(name, "f64", 3);
  Vec3 v;
  for (int k = 0; k < 3; ++k) v[k] = double_of(get_le(take(8), 8));
  return v;
}
Mat3 FieldReader::mat3(const char* name) {
  expect(name, "f64", 9);
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = double_of(get_le(take(8), 8));
  return m;
}
std::string FieldReader::text(const char* name) {
  expect(name, "text", 1);
  const std::uint64_t n = get_le(take(8), 8);
  if (n > size_ - pos_)
    throw InputError(where_ + ": field '" + std::string(name) + "' claims " + std::to_string(n) +
                     " bytes, more than remain (corrupted)");
  return std::string(take(std::size_t(n)), std::size_t(n));
}

void FieldReader::done() const {
  if (field_ != fields_.size())
    throw InputError(where_ + ": field " + std::to_string(field_ + 1) + " '" + fields_[field_] +
                     "' is not read by this build: written by another version");
  if (pos_ != size_)
    throw InputError(where_ + ": " + std::to_string(size_ - pos_) + " bytes after the last field (corrupted)");
}

}  // namespace fabrica
