#include "io/lammps_data.hpp"

#include "io/fault.hpp"
#include "io/memory_check.hpp"
#include "io/scene.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <optional>
#include <cmath>
#include <cstdlib>
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

DataFile read_lammps_data(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": is a directory, not a particle data file");
  std::ifstream in(path);
  if (!in || fault_injected("data"))
    throw InputError(path + ": cannot open the particle data file" +
                     (in ? " (" + fault_text("data") + ")" : std::string()));
  DataFile out;
  long long natoms = -1;
  bool have_box[3] = {false, false, false};
  enum class Section { Header, Atoms, Velocities } section = Section::Header;
  bool seen_atoms = false, seen_velocities = false;
  std::string line;
  int lineno = 0;
  std::unordered_map<GlobalId, std::size_t> index;  // id -> particle index
  struct Motion { Vec3 v, w; int line; };
  std::unordered_map<GlobalId, Motion> motion;
  std::getline(in, line);  // title line
  ++lineno;
  while (std::getline(in, line)) {
    ++lineno;
    const auto hash = line.find('#');
    const std::string body = hash == std::string::npos ? line : line.substr(0, hash);
    std::istringstream ls(body);
    std::string w1, w2, w3;
    if (!(ls >> w1)) continue;
    if (std::isalpha(static_cast<unsigned char>(w1[0]))) {  // a section keyword
      if (w1 == "Atoms" || w1 == "Velocities") {
        if (natoms < 0) throw InputError(where(path, lineno) + ": section '" + w1 +
                                         "' before the 'N atoms' line of the header");
        for (int k = 0; k < 3; ++k)
          if (!have_box[k]) {
            const std::string axis(1, char('x' + k));
            throw InputError(where(path, lineno) + ": section '" + w1 + "' before the box bounds '" +
                             axis + "lo " + axis + "hi' of the header (each of x, y, z needs a "
                             "line 'LO HI " + axis + "lo " + axis + "hi')");
          }
        bool& seen = w1 == "Atoms" ? seen_atoms : seen_velocities;
        if (seen) throw InputError(where(path, lineno) + ": section '" + w1 + "' appears twice");
        seen = true;
        section = w1 == "Atoms" ? Section::Atoms : Section::Velocities;
        // Room for the header's count, so that the arrays do not double past need (up to
        // 2^26 at once: a wrong count cannot request more than that before the data say so).
        if (section == Section::Atoms)
          out.particles.reserve(std::size_t(std::min<long long>(natoms, 1ll << 26)));
        continue;
      }
      // Header keywords follow numbers ("N atoms", "lo hi xlo xhi"): a line that starts with a
      // word is a section, and we read no other.
      throw InputError(where(path, lineno) + ": section '" + w1 +
                       "' is not supported (only Atoms and Velocities of atom_style sphere)");
    }
    if (section == Section::Header) {
      ls >> w2 >> w3;
      auto number = [&](const std::string& s) {
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || *end != '\0' || !std::isfinite(v))
          throw InputError(where(path, lineno) + ": '" + s + "' is not a finite number in '" +
                           line + "'");
        return v;
      };
      if (w2 == "atoms") {
        const std::optional<long long> n = whole(w1);
        if (!n || *n < 1)
          throw InputError(where(path, lineno) + ": '" + w1 + " atoms': the atom count must be a "
                           "whole number of at least 1, in '" + line + "'");
        check_memory(where(path, lineno) + ": '" + w1 + " atoms'", double(*n) * kBytesPerSphere,
                     "320 B per sphere at least");
        natoms = *n;
      } else if (w3 == "xlo" || w3 == "ylo" || w3 == "zlo") {
        const int k = w3[0] - 'x';
        out.lo[k] = number(w1);
        out.hi[k] = number(w2);
        if (!(out.hi[k] > out.lo[k]))
          throw InputError(where(path, lineno) + ": " + w3[0] + "hi = " + w2 + " must exceed " + w3 +
                           " = " + w1 + ", in '" + line + "'");
        have_box[k] = true;
      }
      continue;
    }
    if (section == Section::Atoms) {
      double val[7];
      if (!parse_numbers(body, 7, val))
        throw InputError(where(path, lineno) +
                         ": expected 'id type diameter density x y z', got '" + line + "'");
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
        if (xk < out.lo[k] || xk > out.hi[k])
          bad(names[k], xk, "lies outside the box given in the header");
      }
      if (!index.emplace(GlobalId(id), out.particles.n_owned()).second)
        bad("id", double(id), "appears twice");
      out.particles.add({GlobalId(id), 0.5 * dia, rho, Vec3(val[4], val[5], val[6]) - out.lo});
      continue;
    }
    // Velocities section.
    double val[7];
    if (!parse_numbers(body, 7, val))
      throw InputError(where(path, lineno) + ": expected 'id vx vy vz wx wy wz', got '" + line + "'");
    const GlobalId id = parse_particle_id(first_token(body), where(path, lineno));
    static const char* vnames[6] = {"vx", "vy", "vz", "wx", "wy", "wz"};
    for (int k = 0; k < 6; ++k)
      if (!std::isfinite(val[1 + k])) {
        std::ostringstream m;
        m << where(path, lineno) << ": particle " << id << " " << vnames[k] << " = " << val[1 + k]
          << " is not finite";
        throw InputError(m.str());
      }
    if (!motion.emplace(GlobalId(id), Motion{Vec3(val[1], val[2], val[3]),
                                              Vec3(val[4], val[5], val[6]), lineno}).second)
      throw InputError(where(path, lineno) + ": particle " + std::to_string(id) +
                       " appears twice in the Velocities section");
  }
  if (natoms < 0) throw InputError(path + ": no 'N atoms' line in the header");
  for (int k = 0; k < 3; ++k)
    if (!have_box[k] || !(out.hi[k] > out.lo[k]))
      throw InputError(path + ": missing or empty box bounds along axis " + std::to_string(k + 1));
  const long long read = static_cast<long long>(out.particles.n_owned());
  if (read != natoms)
    throw InputError(path + ": header says " + std::to_string(natoms) + " atoms, Atoms section has " +
                     std::to_string(read));
  if (seen_velocities) {
    for (const auto& [id, m] : motion) {
      const auto it = index.find(id);
      if (it == index.end())
        throw InputError(where(path, m.line) + ": Velocities of particle " + std::to_string(id) +
                         ", which is not in the Atoms section");
      out.particles.v[it->second] = m.v;
      out.particles.w[it->second] = m.w;
    }
    if (static_cast<long long>(motion.size()) != natoms)
      throw InputError(path + ": header says " + std::to_string(natoms) +
                       " atoms, Velocities section has " + std::to_string(motion.size()));
    out.has_velocities = true;
  }
  return out;
}

}  // namespace fabrica
