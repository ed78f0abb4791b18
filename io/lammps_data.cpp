#include "io/lammps_data.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <unordered_set>

namespace fabrica {

namespace {
std::string where(const std::string& path, int line) { return path + ":" + std::to_string(line); }
}  // namespace

DataFile read_lammps_data(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the particle data file");
  DataFile out;
  long long natoms = -1;
  bool have_box[3] = {false, false, false};
  std::string line;
  int lineno = 0;
  bool in_atoms = false;
  long long read = 0;
  std::unordered_set<GlobalId> seen;
  std::getline(in, line);  // title line
  ++lineno;
  while (std::getline(in, line)) {
    ++lineno;
    const auto hash = line.find('#');
    const std::string body = hash == std::string::npos ? line : line.substr(0, hash);
    std::istringstream ls(body);
    std::string w1, w2, w3, w4;
    if (!(ls >> w1)) continue;
    if (!in_atoms) {
      if (w1 == "Atoms") {
        in_atoms = true;
        continue;
      }
      ls >> w2 >> w3 >> w4;
      auto number = [&](const std::string& s) {
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (s.empty() || *end != '\0' || !std::isfinite(v))
          throw InputError(where(path, lineno) + ": '" + s + "' is not a finite number in '" +
                           line + "'");
        return v;
      };
      if (w2 == "atoms") {
        natoms = static_cast<long long>(number(w1));
      } else if (w3 == "xlo" || w3 == "ylo" || w3 == "zlo") {
        const int k = w3[0] - 'x';
        out.lo[k] = number(w1);
        out.hi[k] = number(w2);
        have_box[k] = true;
      } else if (w1 == "Velocities" || w1 == "Masses" || w1 == "Bonds") {
        throw InputError(where(path, lineno) + ": section '" + w1 +
                         "' is not supported (only the Atoms section of atom_style sphere)");
      }
      continue;
    }
    // Atoms section: id type diameter density x y z
    if (std::isalpha(static_cast<unsigned char>(w1[0]))) break;  // next section
    // Tokens are converted with strtod so that nan/inf reach the checks below.
    std::istringstream as(body);
    std::string tok[7];
    int ntok = 0;
    while (ntok < 7 && as >> tok[ntok]) ++ntok;
    double val[7];
    bool ok = ntok == 7;
    for (int q = 0; ok && q < 7; ++q) {
      char* end = nullptr;
      val[q] = std::strtod(tok[q].c_str(), &end);
      ok = end && *end == '\0';
    }
    if (!ok)
      throw InputError(where(path, lineno) +
                       ": expected 'id type diameter density x y z', got '" + line + "'");
    const long long id = static_cast<long long>(val[0]);
    const double dia = val[2], rho = val[3], x = val[4], y = val[5], z = val[6];
    auto bad = [&](const char* field, double v, const char* why) {
      std::ostringstream m;
      m << where(path, lineno) << ": particle " << id << " " << field << " = " << v << " " << why;
      throw InputError(m.str());
    };
    if (!std::isfinite(dia) || dia <= 0) bad("diameter", dia, "must be positive and finite");
    if (!std::isfinite(rho) || rho <= 0) bad("density", rho, "must be positive and finite");
    const double xs[3] = {x, y, z};
    const char* names[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(xs[k])) bad(names[k], xs[k], "is not finite");
      if (xs[k] < out.lo[k] || xs[k] > out.hi[k])
        bad(names[k], xs[k], "lies outside the box given in the header");
    }
    if (!seen.insert(id).second) bad("id", double(id), "appears twice");
    out.particles.add({GlobalId(id), 0.5 * dia, rho, Vec3(x, y, z) - out.lo});
    ++read;
  }
  if (natoms < 0) throw InputError(path + ": no 'N atoms' line in the header");
  for (int k = 0; k < 3; ++k)
    if (!have_box[k] || !(out.hi[k] > out.lo[k]))
      throw InputError(path + ": missing or empty box bounds along axis " + std::to_string(k + 1));
  if (read != natoms)
    throw InputError(path + ": header says " + std::to_string(natoms) + " atoms, Atoms section has " +
                     std::to_string(read));
  return out;
}

}  // namespace fabrica
