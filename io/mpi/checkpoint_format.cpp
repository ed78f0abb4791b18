#include "io/mpi/checkpoint_format.hpp"

#include "io/mpi/fields.hpp"

#include <cstring>
#include <sstream>

#ifndef FABRICA_VERSION
#define FABRICA_VERSION "unknown"
#endif

namespace fabrica {
namespace {

constexpr char kMagic[8] = {'F', 'A', 'B', 'R', 'C', 'K', 'P', 'T'};

template <class T>
std::uint64_t bits_of(T v) {
  if constexpr (std::is_same_v<T, double>) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    return b;
  } else if constexpr (std::is_signed_v<T>) {
    return std::uint64_t(std::make_unsigned_t<T>(v));
  } else {
    return std::uint64_t(v);
  }
}
template <class T>
T value_of(std::uint64_t b) {
  if constexpr (std::is_same_v<T, double>) {
    double v;
    std::memcpy(&v, &b, 8);
    return v;
  } else {
    return T(std::make_unsigned_t<T>(b));
  }
}

// Writes the header's fields into 'out' from byte 'base' (the header, or a section entry).
struct Encoder {
  std::string& out;
  std::size_t base;
  template <class T>
  void field(const char*, std::size_t at, const T& v) {
    std::string b;
    put_le(b, bits_of(v), int(sizeof(T)));
    out.replace(base + at, sizeof(T), b);
  }
  void text(const char*, std::size_t at, std::size_t width, const std::string& s) {
    for (std::size_t k = 0; k < width; ++k) out[base + at + k] = k < s.size() && k + 1 < width ? s[k] : '\0';
  }
};

// Reads them back.
struct Decoder {
  const std::string& in;
  std::size_t base;
  template <class T>
  void field(const char*, std::size_t at, T& v) {
    v = value_of<T>(get_le(in.data() + base + at, int(sizeof(T))));
  }
  void text(const char*, std::size_t at, std::size_t width, std::string& s) {
    const char* p = in.data() + base + at;
    std::size_t n = 0;
    while (n < width && p[n]) ++n;
    s.assign(p, n);
  }
};

// Their names, types and offsets, as the documentation gives them.
struct Lister {
  std::vector<std::string>& out;
  template <class T>
  void field(const char* name, std::size_t at, const T&) {
    out.push_back(std::string(name) + " " + header_type<T>() + " (" + std::to_string(at));
  }
  void text(const char* name, std::size_t at, std::size_t width, const std::string&) {
    out.push_back(std::string(name) + " text[" + std::to_string(width) + "] (" + std::to_string(at));
  }
};

}  // namespace

std::uint64_t scene_fingerprint(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

std::vector<std::string> header_layout() {
  std::vector<std::string> out;
  Lister l{out};
  const CheckpointHeader h;
  const HeaderWords w;
  header_fields(l, h, w);
  const CheckpointSection s;
  const std::uint32_t kind = 0;
  section_fields(l, s, kind);
  return out;
}

std::string encode_header(const CheckpointHeader& h) {
  std::string out(kHeaderBytes, '\0');
  std::memcpy(out.data(), kMagic, 8);
  const HeaderWords w{std::uint32_t(kHeaderBytes), h.blowup ? kFlagBlowup : 0, std::uint32_t(h.sections.size())};
  Encoder head{out, 0};
  header_fields(head, h, w);
  std::size_t at = kSectionTableFirst;
  for (const CheckpointSection& s : h.sections) {
    Encoder entry{out, at};
    const std::uint32_t kind = std::uint32_t(s.kind);
    section_fields(entry, s, kind);
    at += kSectionEntryBytes;
  }
  return out;
}

std::string decode_header(const std::string& in, CheckpointHeader& h) {
  if (in.size() < 8 || std::memcmp(in.data(), kMagic, 8) != 0)
    return "not a Fabrica checkpoint (no FABRCKPT magic at the start)";
  if (in.size() < kHeaderBytes)
    return "truncated: " + std::to_string(in.size()) + " bytes, shorter than the header (" +
        std::to_string(kHeaderBytes) + " bytes)";
  HeaderWords w;
  Decoder head{in, 0};
  header_fields(head, h, w);
  h.blowup = w.flags & kFlagBlowup;
  if (h.format < kOldestCheckpointFormat || h.format > kCheckpointFormat)
    return "checkpoint format version " + std::to_string(h.format) + ", this build of Fabrica (" + FABRICA_VERSION +
        ") reads versions " + std::to_string(kOldestCheckpointFormat) + " to " + std::to_string(kCheckpointFormat) +
        " only";
  if (w.header_bytes != kHeaderBytes) return "corrupted header (header size)";
  if (w.sections > kMaxSections) return "corrupted header (section count " + std::to_string(w.sections) + ")";
  if (h.ranks < 1) return "corrupted header (writer rank count " + std::to_string(h.ranks) + ")";
  h.sections.clear();
  std::size_t at = kSectionTableFirst;
  for (std::uint32_t k = 0; k < w.sections; ++k, at += kSectionEntryBytes) {
    CheckpointSection s;
    std::uint32_t kind = 0;
    Decoder entry{in, at};
    section_fields(entry, s, kind);
    if (kind > 2) return "corrupted header (kind of section " + s.name + ")";
    s.kind = SectionKind(kind);
    if (s.kind != SectionKind::Global && (s.record_bytes == 0 || s.bytes != s.records * s.record_bytes))
      return "corrupted header (size of section " + s.name + ")";
    h.sections.push_back(s);
  }
  return "";
}

std::uint64_t checksum(const char* data, std::size_t n, std::uint64_t offset) {
  std::uint64_t s = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint64_t w = ((offset + k + 1) * 0x9E3779B97F4A7C15ull) | 1ull;
    s += (std::uint64_t(static_cast<unsigned char>(data[k])) + 1) * w;
  }
  return s;
}

std::string describe(const CheckpointHeader& h, const std::string& path) {
  std::ostringstream s;
  s << "checkpoint " << path << "\n"
    << "  format version    " << h.format << "\n"
    << "  written by        Fabrica " << h.software << " on " << h.ranks << " rank(s)\n"
    << "  application       " << h.app << (h.blowup ? " (blow-up state, not restartable)" : "") << "\n"
    << "  step              " << h.step << "\n";
  s.precision(17);
  s << "  time              " << h.time << " s\n"
    << "  scene fingerprint " << h.scene_fingerprint << "\n"
    << "  size              " << h.file_bytes << " bytes\n"
    << "  sections (name, offset, bytes, records, bytes per record, kind):\n";
  static const char* kinds[3] = {"global", "per-rank", "distributed"};
  for (const CheckpointSection& c : h.sections)
    s << "    " << c.name << " " << c.offset << " " << c.bytes << " " << c.records << " " << c.record_bytes << " "
      << kinds[int(c.kind)] << "\n";
  return s.str();
}

}  // namespace fabrica
