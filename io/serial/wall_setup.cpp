#include "io/serial/wall_setup.hpp"

#include "core/timestep.hpp"
#include "core/errors.hpp"

#include <algorithm>
#include <limits>
#include <sstream>

namespace fabrica {
namespace {

std::string vec(const Vec3& v) {
  std::ostringstream s;
  s.precision(6);
  s << '[' << v[0] << ", " << v[1] << ", " << v[2] << ']';
  return s.str();
}
std::string where(const Scene& sc, std::size_t k) { return sc.path + ": [wall #" + std::to_string(k + 1) + "] "; }
int axis_of(const Vec3& n) { return n[0] != 0 ? 0 : (n[1] != 0 ? 1 : 2); }

}  // namespace

std::vector<Wall> scene_walls(const Scene& sc, const PeriodicCell& cell) {
  const Vec3& L = cell.lengths();
  std::vector<Wall> walls;
  for (std::size_t k = 0; k < sc.walls.size(); ++k) {
    const WallSpec& s = sc.walls[k];
    const int a = axis_of(s.normal);
    if (s.point[a] < 0 || s.point[a] > L[a])
      throw InputError(where(sc, k) + "point = " + vec(s.point) + ": its plane (coordinate " + std::to_string(a + 1) +
                       " = " + number_text(s.point[a]) + ") lies outside the cell [0, " + number_text(L[a]) + "] m");
    Wall w{s.point, s.normal, s.velocity, s.own_law, s.law};
    w.material = sc.materials.size() > 1 ? s.material : -1;  // one material: the scene's law
    w.servo_pressure = s.pressure;
    w.servo_relaxation = s.servo_relaxation;
    w.servo_max_speed = s.max_speed;  // 0 until set_servo_speed_caps (the time step unknown here)
    walls.push_back(w);
  }
  // Facing walls of one axis: a floor (normal +e) below a ceiling (normal -e), closer than L.
  for (std::size_t i = 0; i < walls.size(); ++i)
    for (std::size_t j = 0; j < walls.size(); ++j) {
      const int a = axis_of(walls[i].normal);
      if (axis_of(walls[j].normal) != a || !(walls[i].normal[a] > 0 && walls[j].normal[a] < 0)) continue;
      const real_t gap = walls[j].point[a] - walls[i].point[a];
      if (gap <= 0)
        throw InputError(where(sc, j) + "point = " + vec(walls[j].point) + ": this wall faces [wall #" +
                         std::to_string(i + 1) + "] along axis " + std::to_string(a + 1) +
                         " but lies behind it: no room between them");
      if (gap >= L[a])
        throw InputError(where(sc, j) + "point = " + vec(walls[j].point) + ": with [wall #" + std::to_string(i + 1) +
                         "] it spans the whole cell along axis " + std::to_string(a + 1) + " (" + number_text(gap) +
                         " m of " + number_text(L[a]) +
                         " m); the cell is periodic along every axis: make it longer than the distance "
                         "between the walls");
    }
  return walls;
}

void set_servo_speed_caps(std::vector<Wall>& walls, real_t rmin, real_t dt) {
  for (Wall& w : walls)
    if (w.servo() && w.servo_max_speed == 0) w.servo_max_speed = kServoStepFraction * rmin / dt;
}

namespace {
// How far the centre of sphere i lies in front of wall w, and whether that is an offence.
real_t wall_distance(const Wall& w, const Particles& p, std::size_t i) { return (p.x[i] - w.point).dot(w.normal); }
bool offends(const Scene& sc, const Wall& w, const Particles& p, std::size_t i) {
  const real_t d = wall_distance(w, p, i), R = p.radius[i];
  return d <= 0 || R - d > sc.max_initial_overlap * R;
}
}  // namespace

WallOffence first_wall_offence(const Scene& sc, const std::vector<Wall>& walls, const Particles& p) {
  for (std::size_t k = 0; k < walls.size(); ++k) {
    std::size_t first = p.n_owned();
    for (std::size_t i = 0; i < p.n_owned(); ++i)
      if (offends(sc, walls[k], p, i) && (first == p.n_owned() || p.id[i] < p.id[first])) first = i;
    if (first < p.n_owned()) return {k, first};
  }
  return {walls.size(), p.n_owned()};
}

void refuse_wall_offence(const Scene& sc, const std::vector<Wall>& walls, const Particles& p, WallOffence o) {
  const std::string from = sc.source == ParticleSource::File ? sc.data_file : std::string("the generated specimen");
  const Wall& w = walls[o.wall];
  const std::size_t i = o.particle;
  const real_t d = wall_distance(w, p, i), R = p.radius[i];
  if (d <= 0)
    throw InputError(where(sc, o.wall) + "point = " + vec(w.point) + ", normal = " + vec(w.normal) + ": particle " +
                     std::to_string(p.id[i]) + " of " + from + " starts beyond the wall (its centre " +
                     number_text(-d) + " m behind the plane)");
  throw InputError(where(sc, o.wall) + "point = " + vec(w.point) + ": particle " + std::to_string(p.id[i]) + " of " +
                   from + " overlaps the wall by " + number_text((R - d) / R) + " of its radius, above " + sc.path +
                   ": [run] max_initial_overlap = " + number_text(sc.max_initial_overlap));
}

real_t walls_critical_time_step(const Scene& sc, const Particles& p, real_t rmin, real_t rmax,
                                const Materials* materials) {
  real_t dt = std::numeric_limits<real_t>::infinity();
  if (sc.walls.empty() || p.n_owned() == 0) return dt;
  dt = critical_time_step(p, sc.law, true, rmin, rmax, materials);
  for (const WallSpec& w : sc.walls)
    if (w.own_law) dt = std::min(dt, critical_time_step(p, w.law, true, rmin, rmax));
  return dt;
}

std::vector<std::int64_t> driven_counts(const Scene& sc, const Particles& p) {
  std::vector<std::int64_t> n(sc.driven.size(), 0);
  for (std::size_t k = 0; k < sc.driven.size(); ++k)
    for (std::size_t i = 0; i < p.n_owned(); ++i) n[k] += sc.driven[k].contains(p.id[i]);
  return n;
}

void check_driven_counts(const Scene& sc, const std::vector<std::int64_t>& counts) {
  for (std::size_t k = 0; k < sc.driven.size(); ++k) {
    const DrivenSet& d = sc.driven[k];
    if (counts[k] == d.size()) continue;
    const std::string what =
        d.ids.empty() ? "id_range = [" + std::to_string(d.first) + ", " + std::to_string(d.last) + "]" : "ids";
    throw InputError(sc.path + ": [driven #" + std::to_string(k + 1) + "] " + what + ": names " +
                     std::to_string(d.size()) + " particle(s), of which " + std::to_string(counts[k]) +
                     " are in the specimen (" +
                     (sc.source == ParticleSource::File ? sc.data_file : std::string("generated, ids 0 to count - 1")) +
                     "); every id must be a particle's");
  }
}

}  // namespace fabrica
