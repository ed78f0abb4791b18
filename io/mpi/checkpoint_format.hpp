// The checkpoint file's frame (docs/checkpoint.md#format): the format version, the header and
// its section table, the trailer and the checksum. The header's fields are declared once, at
// their byte offsets (header_fields, section_fields): encoding, decoding and the comparison
// with the documentation (tests/io/test_checkpoint_format.cpp) follow from that list. Every
// value is little-endian whatever the machine. No MPI here: io/mpi/checkpoint_file.hpp writes
// and reads the frame collectively.
#pragma once
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace fabrica {

// Raise the format version with any change of the file's structure. The fields of a section
// carry their own layout (names and types), so a change of what a section holds is refused by
// the reader naming the field, in any version.
inline constexpr std::uint32_t kCheckpointFormat = 11;
// The oldest format this build reads; what formats 6 to 10 lack and what this build reads in
// its place: io/mpi/checkpoint_older.hpp.
inline constexpr std::uint32_t kOldestCheckpointFormat = 6;
inline constexpr std::size_t kHeaderBytes = 2048;
inline constexpr std::size_t kTrailerBytes = 16;  // "FABREND\0" and the checksum
inline constexpr char kEndMagic[8] = {'F', 'A', 'B', 'R', 'E', 'N', 'D', '\0'};

// FNV-1a (64 bits) of the scene text: a checkpoint of another scene is refused.
std::uint64_t scene_fingerprint(const std::string& text);

enum class SectionKind : std::uint32_t { Global = 0, PerRank = 1, Distributed = 2 };

struct CheckpointSection {
  std::string name;
  std::uint64_t offset = 0, bytes = 0, records = 0;
  std::uint32_t record_bytes = 0;  // 0 for a global section
  SectionKind kind = SectionKind::Global;
};

struct CheckpointHeader {
  std::uint32_t format = 0;
  std::string software;
  std::uint64_t scene_fingerprint = 0;
  std::int32_t ranks = 0;
  bool blowup = false;
  std::int64_t step = 0;
  double time = 0;
  std::string app;
  std::uint64_t file_bytes = 0;
  std::vector<CheckpointSection> sections;
};

// The header's words that follow from the rest (written as they are, checked when read).
struct HeaderWords {
  std::uint32_t header_bytes = kHeaderBytes;
  std::uint32_t flags = 0;  // kFlagBlowup
  std::uint32_t sections = 0;
};
inline constexpr std::uint32_t kFlagBlowup = 1;
inline constexpr std::size_t kSectionTableFirst = 128;  // the section table starts here
inline constexpr std::size_t kSectionNameBytes = 24;
inline constexpr std::size_t kSectionEntryBytes = 56;
inline constexpr std::size_t kMaxSections = (kHeaderBytes - kSectionTableFirst) / kSectionEntryBytes;

// The header after the magic "FABRCKPT" (bytes 0-7), in the documentation's words:
// io.field(name, offset, value) for a number (its C++ type gives its type and size: u32, i32,
// u64, i64, f64), io.text(name, offset, width, string) for a NUL-padded text.
template <class Io, class H, class W>
void header_fields(Io& io, H& h, W& w) {
  io.field("format version", 8, h.format);
  io.field("header size", 12, w.header_bytes);
  io.text("software version", 16, 16, h.software);
  io.field("scene fingerprint", 32, h.scene_fingerprint);
  io.field("writer rank count", 40, h.ranks);
  io.field("flags", 44, w.flags);
  io.field("step", 48, h.step);
  io.field("time", 56, h.time);
  io.text("application", 64, 16, h.app);
  io.field("file size", 80, h.file_bytes);
  io.field("section count", 88, w.sections);
}
// One entry of the section table, at its offset in the entry.
template <class Io, class S, class K>
void section_fields(Io& io, S& s, K& kind) {
  io.text("name", 0, kSectionNameBytes, s.name);
  io.field("offset", 24, s.offset);
  io.field("bytes", 32, s.bytes);
  io.field("records", 40, s.records);
  io.field("bytes per record", 48, s.record_bytes);
  io.field("kind", 52, kind);
}
// The type of a header value as docs/checkpoint.md writes it.
template <class T>
constexpr const char* header_type() {
  if constexpr (std::is_same_v<T, double>) return "f64";
  else if constexpr (std::is_same_v<T, std::uint32_t>) return "u32";
  else if constexpr (std::is_same_v<T, std::int32_t>) return "i32";
  else if constexpr (std::is_same_v<T, std::uint64_t>) return "u64";
  else {
    static_assert(std::is_same_v<T, std::int64_t>, "a header value of a type without a layout");
    return "i64";
  }
}
// "name type (offset" for every field of the header, then of a section entry, as
// docs/checkpoint.md's header row lists them (the test compares).
std::vector<std::string> header_layout();

// The kHeaderBytes of the header (sections included).
std::string encode_header(const CheckpointHeader& h);
// The checks that need only the header's bytes (magic, size, format version, header size,
// counts, section kinds and sizes); returns what is wrong ("" if nothing).
std::string decode_header(const std::string& in, CheckpointHeader& h);

// Position-weighted sum of the bytes at 'offset' in the file, each with an odd weight: a
// changed byte always changes it. Sums of disjoint ranges add up (unsigned wrap-around), so
// ranks checksum their own blocks.
std::uint64_t checksum(const char* data, std::size_t n, std::uint64_t offset);

// Prints the header and the section table (fabrica checkpoint-info).
std::string describe(const CheckpointHeader& h, const std::string& path);

}  // namespace fabrica
