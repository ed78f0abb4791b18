#include "io/serial/lammps_data.hpp"

#include "core/fault.hpp"
#include "io/serial/memory_check.hpp"
#include "io/serial/scene.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <optional>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace fabrica {

namespace {

std::string where(const std::string& path, int line) { return path + ":" + std::to_string(line); }

// The numbers of a data line (comments stripped); strtod, so that nan/inf reach the checks.
bool parse_numbers(const std::string& body, int n, double* val) {
  std::istringstream as(body);
  std::string tok;
  int k = 0;
  while (as >> tok) {
    if (k == n) return false;
    char* end = nullptr;
    val[k] = std::strtod(tok.c_str(), &end);
    if (!end || *end != '\0') return false;
    ++k;
  }
  return k == n;
}

// A whole number written as digits (an optional '+'), e.g. an id or the atom count; nullopt if
// the token is anything else (1.5, 1e3, -2, 99999999999999999999).
std::optional<long long> whole(const std::string& tok) {
  const char* b = tok.data() + (tok.starts_with('+') ? 1 : 0);
  const char* e = tok.data() + tok.size();
  if (b == e || !std::isdigit(static_cast<unsigned char>(*b))) return std::nullopt;
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(b, e, v);
  if (ec != std::errc() || ptr != e) return std::nullopt;
  return v;
}

std::string first_token(const std::string& body) {
  std::istringstream s(body);
  std::string t;
  s >> t;
  return t;
}

}  // namespace

GlobalId parse_particle_id(const std::string& token, const std::string& where) {
  const std::optional<long long> v = whole(token);
  if (!v || *v < 1 || *v > kMaxParticleId)
    throw InputError(where + ": particle id '" + token + "': must be a whole number in [1, " +
                     std::to_string(kMaxParticleId) + "]");
  return GlobalId(*v);
}

DataHeader read_data_header(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path + ": is a directory, not a particle data file");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  const int err = errno;  // what open(2) said (no such file, permission denied)
  if (!in || fault_injected("data"))
    throw InputError(path + ": cannot open the particle data file (" +
                     (in ? fault_text("data") : std::string(err ? std::strerror(err) : "unreadable")) + ")");
  DataHeader h;
  bool have_box[3] = {false, false, false};
  std::string line;
  int lineno = 0;
  std::getline(in, line);  // title line
  ++lineno;
  for (std::streamoff at = in.tellg(); std::getline(in, line); at = in.tellg()) {
    ++lineno;
    const auto hash = line.find('#');
    const std::string body = hash == std::string::npos ? line : line.substr(0, hash);
    std::istringstream ls(body);
    std::string w1, w2, w3;
    if (!(ls >> w1)) continue;
    if (std::isalpha(static_cast<unsigned char>(w1[0]))) {  // the first section
      data_section_keyword(w1, path, lineno);               // refuses any other than Atoms and Velocities
      if (h.natoms < 0)
        throw InputError(where(path, lineno) + ": section '" + w1 + "' before the 'N atoms' line of the header");
      for (int k = 0; k < 3; ++k)
        if (!have_box[k]) {
          const std::string axis(1, char('x' + k));
          throw InputError(where(path, lineno) + ": section '" + w1 + "' before the box bounds '" + axis + "lo " +
                           axis +
                           "hi' of the header (each of x, y, z needs a "
                           "line 'LO HI " +
                           axis + "lo " + axis + "hi')");
        }
      h.body_offset = std::uint64_t(at);
      h.body_line = lineno;
      return h;
    }
    ls >> w2 >> w3;
    auto number = [&](const std::string& t) {
      char* end = nullptr;
      const double v = std::strtod(t.c_str(), &end);
      if (t.empty() || *end != '\0' || !std::isfinite(v))
        throw InputError(where(path, lineno) + ": '" + t + "' is not a finite number in '" + line + "'");
      return v;
    };
    if (w2 == "atoms") {
      const std::optional<long long> n = whole(w1);
      if (!n || *n < 1)
        throw InputError(where(path, lineno) + ": '" + w1 +
                         " atoms': the atom count must be a "
                         "whole number of at least 1, in '" +
                         line + "'");
      h.natoms = *n;
      h.natoms_line = lineno;
    } else if (w3 == "xlo" || w3 == "ylo" || w3 == "zlo") {
      const int k = w3[0] - 'x';
      h.lo[k] = number(w1);
      h.hi[k] = number(w2);
      if (!(h.hi[k] > h.lo[k]))
        throw InputError(where(path, lineno) + ": " + w3[0] + "hi = " + w2 + " must exceed " + w3 + " = " + w1 +
                         ", in '" + line + "'");
      have_box[k] = true;
    }
  }
  if (h.natoms < 0) throw InputError(path + ": no 'N atoms' line in the header");
  for (int k = 0; k < 3; ++k)
    if (!have_box[k]) throw InputError(path + ": missing or empty box bounds along axis " + std::to_string(k + 1));
  h.body_offset = std::uint64_t(std::filesystem::file_size(path, ec));
  h.body_line = lineno + 1;
  return h;
}

DataSection data_section_keyword(const std::string& word, const std::string& path, int lineno) {
  if (word == "Atoms") return DataSection::Atoms;
  if (word == "Velocities") return DataSection::Velocities;
  // Header keywords follow numbers ("N atoms", "lo hi xlo xhi"): a line that starts with a word
  // is a section, and we read no other.
  throw InputError(where(path, lineno) + ": section '" + word +
                   "' is not supported (only Atoms and Velocities of atom_style sphere)");
}

std::string data_line_body(const std::string& line) {
  const auto hash = line.find('#');
  return hash == std::string::npos ? line : line.substr(0, hash);
}

SphereInit parse_atom_line(const std::string& line, const DataHeader& h, const std::string& path, int lineno,
                           const std::vector<std::int64_t>* types) {
  const std::string body = data_line_body(line);
  double val[7];
  if (!parse_numbers(body, 7, val))
    throw InputError(where(path, lineno) + ": expected 'id type diameter density x y z', got '" + line + "'");
  const GlobalId id = parse_particle_id(first_token(body), where(path, lineno));
  const double dia = val[2], rho = val[3];
  auto bad = [&](const char* field, double v, const char* why) {
    std::ostringstream m;
    m << where(path, lineno) << ": particle " << id << " " << field << " = " << v << " " << why;
    throw InputError(m.str());
  };
  if (!std::isfinite(dia) || dia <= 0) bad("diameter", dia, "must be positive and finite");
  if (dia < kMinDiameter || dia > kMaxDiameter) bad("diameter", dia, "must lie in [1e-09, 1000] m");
  if (!std::isfinite(rho) || rho <= 0) bad("density", rho, "must be positive and finite");
  const char* names[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const double xk = val[4 + k];
    if (!std::isfinite(xk)) bad(names[k], xk, "is not finite");
    if (xk < h.lo[k] || xk > h.hi[k]) bad(names[k], xk, "lies outside the box given in the header");
  }
  SphereInit s{id, 0.5 * dia, rho, Vec3(val[4], val[5], val[6]) - h.lo};
  if (types) {  // its material, by its atom type
    const double ty = val[1];
    const auto k = std::find(types->begin(), types->end(), std::int64_t(ty)) - types->begin();
    if (ty != std::floor(ty) || std::size_t(k) == types->size()) {
      std::ostringstream m;
      m << where(path, lineno) << ": particle " << id << " type = " << ty
        << " is the type of no [[material]] of the scene (each atom type of the file needs a material with "
           "type = N)";
      throw InputError(m.str());
    }
    s.material = std::uint8_t(k);
  }
  return s;
}

DataMotion parse_velocity_line(const std::string& line, const std::string& path, int lineno) {
  const std::string body = data_line_body(line);
  double val[7];
  if (!parse_numbers(body, 7, val))
    throw InputError(where(path, lineno) + ": expected 'id vx vy vz wx wy wz', got '" + line + "'");
  const GlobalId id = parse_particle_id(first_token(body), where(path, lineno));
  static const char* vnames[6] = {"vx", "vy", "vz", "wx", "wy", "wz"};
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(val[1 + k])) {
      std::ostringstream m;
      m << where(path, lineno) << ": particle " << id << " " << vnames[k] << " = " << val[1 + k] << " is not finite";
      throw InputError(m.str());
    }
  return {id, Vec3(val[1], val[2], val[3]), Vec3(val[4], val[5], val[6])};
}

std::string data_duplicate_id(const std::string& path, int lineno, GlobalId id, bool velocities) {
  if (velocities)
    return where(path, lineno) + ": particle " + std::to_string(id) + " appears twice in the Velocities section";
  std::ostringstream m;
  m << where(path, lineno) << ": particle " << id << " id = " << double(id) << " appears twice";
  return m.str();
}

DataFile read_lammps_data(const std::string& path, const std::vector<std::int64_t>* types) {
  const DataHeader h = read_data_header(path);
  check_memory(where(path, h.natoms_line) + ": '" + std::to_string(h.natoms) + " atoms'",
               double(h.natoms) * kBytesPerSphere, "200 B per sphere at least");
  std::ifstream in(path, std::ios::binary);
  in.seekg(std::streamoff(h.body_offset));
  DataFile out;
  out.lo = h.lo;
  out.hi = h.hi;
  std::optional<DataSection> section;
  bool seen_atoms = false, seen_velocities = false;
  std::string line;
  int lineno = h.body_line - 1;
  std::unordered_map<GlobalId, std::size_t> index;  // id -> particle index
  struct Motion {
    Vec3 v, w;
    int line;
  };
  std::unordered_map<GlobalId, Motion> motion;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(data_line_body(line));
    std::string w1;
    if (!(ls >> w1)) continue;
    if (std::isalpha(static_cast<unsigned char>(w1[0]))) {
      section = data_section_keyword(w1, path, lineno);
      bool& seen = *section == DataSection::Atoms ? seen_atoms : seen_velocities;
      if (seen) throw InputError(where(path, lineno) + ": section '" + w1 + "' appears twice");
      seen = true;
      // Room for the header's count, so that the arrays do not double past need (up to
      // 2^26 at once: a wrong count cannot request more than that before the data say so).
      if (*section == DataSection::Atoms) out.particles.reserve(std::size_t(std::min<long long>(h.natoms, 1ll << 26)));
      continue;
    }
    if (*section == DataSection::Atoms) {
      const SphereInit s = parse_atom_line(line, h, path, lineno, types);
      if (!index.emplace(s.id, out.particles.n_owned()).second)
        throw InputError(data_duplicate_id(path, lineno, s.id, false));
      out.particles.add(s);
      continue;
    }
    const DataMotion m = parse_velocity_line(line, path, lineno);
    if (!motion.emplace(m.id, Motion{m.v, m.w, lineno}).second)
      throw InputError(data_duplicate_id(path, lineno, m.id, true));
  }
  const long long read = static_cast<long long>(out.particles.n_owned());
  if (read != h.natoms) throw InputError(data_count_error(path, h.natoms, read, false));
  if (seen_velocities) {
    for (const auto& [id, m] : motion) {
      const auto it = index.find(id);
      if (it == index.end()) throw InputError(data_orphan_velocity(path, m.line, id));
      out.particles.v[it->second] = m.v;
      out.particles.w[it->second] = m.w;
    }
    if (static_cast<long long>(motion.size()) != h.natoms)
      throw InputError(data_count_error(path, h.natoms, static_cast<long long>(motion.size()), true));
    out.has_velocities = true;
  }
  return out;
}

std::string data_count_error(const std::string& path, long long natoms, long long read, bool velocities) {
  return path + ": header says " + std::to_string(natoms) + " atoms, " + (velocities ? "Velocities" : "Atoms") +
      " section has " + std::to_string(read);
}

std::string data_orphan_velocity(const std::string& path, int lineno, GlobalId id) {
  return where(path, lineno) + ": Velocities of particle " + std::to_string(id) + ", which is not in the Atoms section";
}

}  // namespace fabrica
