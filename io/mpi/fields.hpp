// Named, typed values in a fixed byte order, for files another build must read or refuse
// clearly (the checkpoint, docs/checkpoint.md#format).
//
// A FieldWriter appends values, each little-endian whatever the machine (integers as their two's
// complement bytes, doubles as the bytes of their IEEE 754 binary64 pattern), and records a
// schema: "name:type" entries joined by ';', type one of u8 i32 u32 i64 u64 f64, with "[n]" for
// n values (a Vec3 is f64[3], a Mat3 f64[9] in row-major order). There is no padding. A
// FieldReader reads the values back in the same order and checks each request against the
// schema stored with them, so that a file whose fields differ from this build's (another
// version, a field added or retyped) is refused with the first field that differs.
#pragma once
#include "core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace fabrica {

class FieldWriter {
 public:
  FieldWriter& u8(const char* name, std::uint8_t v);
  FieldWriter& i32(const char* name, std::int32_t v);
  FieldWriter& u32(const char* name, std::uint32_t v);
  FieldWriter& i64(const char* name, std::int64_t v);
  FieldWriter& u64(const char* name, std::uint64_t v);
  FieldWriter& f64(const char* name, double v);
  FieldWriter& vec3(const char* name, const Vec3& v);
  FieldWriter& mat3(const char* name, const Mat3& m);
  FieldWriter& text(const char* name, const std::string& v);  // u64 length, then the bytes
  // One name for every type, so that one list of fields serves writing and reading
  // (FieldReader::field takes the same arguments by reference).
  FieldWriter& field(const char* name, std::uint8_t v) { return u8(name, v); }
  FieldWriter& field(const char* name, std::int32_t v) { return i32(name, v); }
  FieldWriter& field(const char* name, std::int64_t v) { return i64(name, v); }
  FieldWriter& field(const char* name, std::uint64_t v) { return u64(name, v); }
  FieldWriter& field(const char* name, double v) { return f64(name, v); }
  FieldWriter& field(const char* name, const Vec3& v) { return vec3(name, v); }
  FieldWriter& field(const char* name, const Mat3& v) { return mat3(name, v); }
  FieldWriter& field(const char* name, const std::string& v) { return text(name, v); }

  const std::string& schema() const { return schema_; }
  const std::string& bytes() const { return bytes_; }
  std::string take_bytes() { return std::move(bytes_); }
  // Only the values (for records of a fixed layout: the schema is recorded once).
  void clear_bytes() { bytes_.clear(); }

 private:
  void entry(const char* name, const char* type, int n);
  std::string schema_, bytes_;
};

// Reads from 'bytes' (not owned: it must outlive the reader) against 'schema'. Every mismatch or
// shortage throws InputError naming 'where', the field, and what was found.
class FieldReader {
 public:
  FieldReader(const std::string& schema, const char* bytes, std::size_t size, std::string where);

  std::uint8_t u8(const char* name);
  std::int32_t i32(const char* name);
  std::uint32_t u32(const char* name);
  std::int64_t i64(const char* name);
  std::uint64_t u64(const char* name);
  double f64(const char* name);
  Vec3 vec3(const char* name);
  Mat3 mat3(const char* name);
  std::string text(const char* name);
  // The counterparts of FieldWriter::field: read into v.
  void field(const char* name, std::uint8_t& v) { v = u8(name); }
  void field(const char* name, std::int32_t& v) { v = i32(name); }
  void field(const char* name, std::int64_t& v) { v = i64(name); }
  void field(const char* name, std::uint64_t& v) { v = u64(name); }
  void field(const char* name, double& v) { v = f64(name); }
  void field(const char* name, Vec3& v) { v = vec3(name); }
  void field(const char* name, Mat3& v) { v = mat3(name); }
  void field(const char* name, std::string& v) { v = text(name); }

  // Throws unless every field and byte has been read.
  void done() const;
  // For records: reads the next record's values against the schema from its start.
  void rewind_schema() { field_ = 0; }
  std::size_t position() const { return pos_; }
  // Whether the next field is called 'name' (of any type): for fields a format added, which an
  // older file lacks.
  bool next_is(const char* name) const {
    return field_ < fields_.size() && fields_[field_].rfind(std::string(name) + ":", 0) == 0;
  }

 private:
  void expect(const char* name, const char* type, int n);
  const char* take(std::size_t n);
  std::string where_;
  std::vector<std::string> fields_;  // the schema's entries
  std::size_t field_ = 0;
  const char* data_;
  std::size_t size_, pos_ = 0;
};

// Encodes / decodes one value little-endian (the checkpoint's header and records).
void put_le(std::string& out, std::uint64_t bits, int bytes);
std::uint64_t get_le(const char* in, int bytes);

}  // namespace fabrica
