#include "io/serial/setup.hpp"

#include "io/serial/memory_check.hpp"

#include "core/exact_sum.hpp"
#include "core/generate.hpp"
#include "core/neighbor.hpp"
#include "core/timestep.hpp"
#include "core/errors.hpp"
#include "io/serial/lammps_data.hpp"
#include "io/serial/wall_setup.hpp"

#include <algorithm>
#include <cmath>
#include <new>
#include <numeric>
#include <numbers>
#include <sstream>

namespace fabrica {

real_t scene_time_step(const Scene& sc, real_t critical_dt) {
  const std::string where = sc.path + ": [run] ";
  if (sc.time_step) {
    if (*sc.time_step > critical_dt && !sc.force_time_step)
      throw InputError(where + "time_step = " + number_text(*sc.time_step) + " s exceeds the critical estimate " +
                       number_text(critical_dt) + " s; lower it or set force_time_step = true");
    return *sc.time_step;
  }
  if (sc.time_step_fraction > 1.0 && !sc.force_time_step)
    throw InputError(where + "time_step_fraction = " + number_text(sc.time_step_fraction) +
                     " is above 1 (critical estimate " + number_text(critical_dt) +
                     " s); lower it or set force_time_step = true");
  return sc.time_step_fraction * critical_dt;
}

OverlapReport largest_overlap(const Particles& p, const PeriodicCell& cell) {
  // The search needs positions in [0, L): a wrapped copy only if some are not (memory at
  // large N; make_setup passes wrapped positions).
  bool wrapped = p.n_ghost() == 0;
  for (std::size_t a = 0; wrapped && a < p.n_owned(); ++a) wrapped = cell.wrap(p.x[a]) == p.x[a];
  Particles copy;
  if (!wrapped) {
    copy = p;
    copy.clear_ghosts();
    for (std::size_t a = 0; a < copy.n_owned(); ++a) copy.x[a] = cell.wrap(copy.x[a]);
  }
  const Particles& w = wrapped ? p : copy;
  NeighborSearch search;
  PairList pairs;
  search.build(w, cell, 0.0, pairs);
  OverlapReport r;
  const Vec3& L = cell.lengths();
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const Index i = pairs.i[q], j = pairs.j[q];
    const real_t un = w.radius[i] + w.radius[j] - (w.x[j] + image_offset(pairs.image[q], L) - w.x[i]).norm();
    const real_t ratio = un / std::min(w.radius[i], w.radius[j]);
    if (un > 0 && ratio > r.ratio) r = {ratio, un, w.id[i], w.id[j]};
  }
  return r;
}

RegionCut region_cut(const Scene& sc) {
  const GenerateSpec& g = sc.generate;
  RegionCut c{{g.count, g.fractal_dimension, g.d_min, g.d_max, g.seed, sc.density},
              Vec3::Zero(),
              RegionGrid({}, Vec3::Ones(), Vec3::Ones())};
  c.expected = sc.cell_size
      ? *sc.cell_size
      : Vec3(g.aspect * std::cbrt(expected_solid_volume(c.spec) / g.solid_fraction / g.aspect.prod()));
  c.grid = RegionGrid(c.spec, c.expected, c.expected);
  return c;
}

PeriodicCell region_cell(const Scene& sc, RegionCut& cut, real_t solid_volume) {
  const GenerateSpec& g = sc.generate;
  const Vec3 L =
      sc.cell_size ? *sc.cell_size : Vec3(g.aspect * std::cbrt(solid_volume / g.solid_fraction / g.aspect.prod()));
  check_neighbour_grid(sc.path + ": [particles] d_min = " + number_text(g.d_min), L, 0.5 * g.d_min, sc.skin);
  PeriodicCell cell(L);
  check_cell_size(cell, 0.5 * g.d_max, sc.skin);
  cut.grid = RegionGrid(cut.spec, cut.expected, L);  // the same cut, the real cell's sides
  return cell;
}

std::string overlap_message(const Scene& sc, const OverlapReport& ov) {
  const std::string from = sc.source == ParticleSource::File
      ? sc.data_file
      : sc.path + ": [particles] (generated, seed " + std::to_string(sc.generate.seed) + ")";
  return from + ": particles " + std::to_string(ov.a) + " and " + std::to_string(ov.b) + " overlap by " +
      number_text(ov.ratio) + " of the smaller radius (" + number_text(ov.overlap) + " m), above " + sc.path +
      ": [run] max_initial_overlap = " + number_text(sc.max_initial_overlap) +
      "; fix the specimen (a bad generation or data file) or raise the limit";
}

namespace {
bool inside_cell(const Vec3& x, const Vec3& L) {
  for (int k = 0; k < 3; ++k)
    if (x[k] < 0 || x[k] > L[k]) return false;
  return true;
}
}  // namespace

std::size_t outside_cell(const Particles& p, const Vec3& L) {
  std::size_t first = p.n_owned();
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    if (!inside_cell(p.x[a], L) && (first == p.n_owned() || p.id[a] < p.id[first])) first = a;
  return first;
}

void refuse_outside_cell(const Scene& sc, const Particles& p, std::size_t a, const Vec3& L, const Vec3& lo) {
  int k = 0;
  while (k < 2 && p.x[a][k] >= 0 && p.x[a][k] <= L[k]) ++k;
  throw InputError(sc.path + ": [cell] size = [" + number_text(L[0]) + ", " + number_text(L[1]) + ", " +
                   number_text(L[2]) + "]: particle " + std::to_string(p.id[a]) + " of " + sc.data_file +
                   " lies outside the cell (coordinate " + std::to_string(k + 1) + " = " +
                   number_text(p.x[a][k] + lo[k]) + ")");
}

std::vector<std::int64_t> material_types(const Scene& sc) {
  std::vector<std::int64_t> t;
  if (sc.source == ParticleSource::File)
    for (const MaterialSpec& m : sc.materials) t.push_back(m.type);
  return t;
}

void apply_scene_run(const Scene& sc, Setup& s) {
  Particles& p = s.particles;
  if (sc.source == ParticleSource::Generate && sc.materials.size() > 1)  // (a data file's: by type when read)
    for (std::size_t a = 0; a < p.n_owned(); ++a) {
      const std::uint8_t m = generated_material(sc, p.id[a]);
      const real_t R = p.radius[a];
      p.material[a] = m;
      p.mass[a] = sc.materials[m].density * 4.0 / 3.0 * std::numbers::pi * R * R * R;  // as Particles::add
    }
  s.params.materials = scene_materials(sc);
  if (sc.density_scaling != 1.0) s.particles.scale_density(sc.density_scaling);
  s.params.law = sc.law;
  s.params.skin = sc.skin;
  s.params.gravity = sc.gravity;
  s.params.local_damping = sc.local_damping;
}

Setup make_setup(const Scene& sc) {
  Setup s;
  if (sc.source == ParticleSource::File) {
    const std::vector<std::int64_t> types = material_types(sc);
    DataFile df = read_lammps_data(sc.data_file, types.empty() ? nullptr : &types);
    s.particles = std::move(df.particles);
    const Vec3 box = df.hi - df.lo;
    const Vec3 L = sc.cell_size.value_or(box);
    if (const std::size_t a = outside_cell(s.particles, L); a < s.particles.n_owned())
      refuse_outside_cell(sc, s.particles, a, L, df.lo);
    check_neighbour_grid(sc.data_file, L, s.particles.min_radius(), sc.skin);
    s.cell = PeriodicCell(L);
  } else {
    const GenerateSpec& g = sc.generate;
    check_memory(sc.path + ": [particles] count = " + std::to_string(g.count), double(g.count) * kBytesPerSphere,
                 "200 B per sphere at least");
    if (g.placement == GenerateSpec::Placement::Regions) {
      try {
        RegionCut cut = region_cut(sc);
        ExactSums V(1);
        for (int r = 0; r < cut.grid.regions(); ++r)
          for (real_t x : region_diameters(cut.spec, cut.grid, r)) V.add(0, std::numbers::pi / 6 * x * x * x);
        V.normalize();
        s.cell = region_cell(sc, cut, V.value(0));
        std::vector<int> all(std::size_t(cut.grid.regions()));
        std::iota(all.begin(), all.end(), 0);
        s.particles = region_packing(cut.spec, cut.grid, s.cell, all,
                                     [](const Particles&, const std::vector<int>&) { return Particles(); });
      } catch (const InputError&) { throw; } catch (const std::bad_alloc&) {
        throw;
      } catch (const std::exception& e) {
        throw InputError(sc.path + ": [particles] count = " + std::to_string(g.count) + ": " + e.what());
      }
    } else {
      Random rng(g.seed);
      const auto d = fractal_diameters(std::size_t(g.count), g.fractal_dimension, g.d_min, g.d_max, rng);
      real_t vs = 0;
      for (real_t x : d) vs += std::numbers::pi / 6 * x * x * x;
      Vec3 L;
      if (sc.cell_size) {
        L = *sc.cell_size;
      } else {
        const real_t V = vs / g.solid_fraction;
        L = g.aspect * std::cbrt(V / g.aspect.prod());
      }
      check_neighbour_grid(sc.path + ": [particles] d_min = " + number_text(g.d_min), L, 0.5 * g.d_min, sc.skin);
      s.cell = PeriodicCell(L);
      try {
        check_cell_size(s.cell, 0.5 * g.d_max, sc.skin);
        s.particles = random_packing(d, sc.density, s.cell, rng);
      } catch (const std::bad_alloc&) {
        throw;  // not the input's fault as such: reported as what it is
      } catch (const std::exception& e) {
        throw InputError(sc.path + ": [particles] count = " + std::to_string(g.count) + ": " + e.what());
      }
    }
  }
  try {
    check_cell_size(s.cell, s.particles.max_radius(), sc.skin);
  } catch (const std::exception& e) { throw InputError(sc.path + ": [cell] " + e.what()); }
  // Wrapped now as the simulation would (the same positions; the overlap check needs them).
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) s.particles.x[a] = s.cell.wrap(s.particles.x[a]);
  const OverlapReport ov = largest_overlap(s.particles, s.cell);
  if (ov.ratio > sc.max_initial_overlap) throw InputError(overlap_message(sc, ov));
  apply_scene_run(sc, s);
  s.critical_dt = critical_time_step(s.particles, sc.law, false, &s.params.materials);
  if (!sc.walls.empty()) {  // [[wall]] (io/serial/wall_setup.hpp)
    s.params.walls = scene_walls(sc, s.cell);
    if (const WallOffence o = first_wall_offence(sc, s.params.walls, s.particles); o.wall < s.params.walls.size())
      refuse_wall_offence(sc, s.params.walls, s.particles, o);
    s.critical_dt = std::min(s.critical_dt,
                             walls_critical_time_step(sc, s.particles, s.particles.min_radius(),
                                                      s.particles.max_radius(), &s.params.materials));
  }
  if (!sc.driven.empty()) {  // [[driven]] (io/serial/wall_setup.hpp)
    check_driven_counts(sc, driven_counts(sc, s.particles));
    s.params.driven = sc.driven;
  }
  s.params.dt = scene_time_step(sc, s.critical_dt);
  set_servo_speed_caps(s.params.walls, s.particles.min_radius(), s.params.dt);
  return s;
}

}  // namespace fabrica
