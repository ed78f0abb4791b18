#include "io/serial/setup.hpp"
#include "io/serial/setup_ranks.hpp"

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
#include <functional>
#include <limits>
#include <new>
#include <numbers>
#include <optional>

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
  return largest_overlap(w, pairs, cell);
}

OverlapReport largest_overlap(const Particles& p, const PairList& pairs, const PeriodicCell& cell) {
  OverlapReport r;
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const Index i = pairs.i[q], j = pairs.j[q];
    const real_t un = p.radius[i] + p.radius[j] - (p.x[j] + image_offset(pairs.image[q], cell) - p.x[i]).norm();
    const real_t ratio = un / std::min(p.radius[i], p.radius[j]);
    if (un > 0 && ratio > r.ratio) r = {ratio, un, p.id[i], p.id[j]};
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

namespace {

// A generation that failed for the input's sake (no room for a sphere, a cell too small for
// the largest one): an InputError naming the count. A failed allocation stays what it is.
void as_count_error(const Scene& sc, const std::function<void()>& step) {
  try {
    step();
  } catch (const InputError&) { throw; } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(sc.path + ": [particles] count = " + std::to_string(sc.generate.count) + ": " + e.what());
  }
}

// The smallest radius over every rank; 0 if no rank holds any (as Particles::min_radius).
real_t smallest_radius(SetupRanks& ranks, const Particles& p) {
  const double r = ranks.min(p.n_owned() ? p.min_radius() : std::numeric_limits<double>::infinity());
  return std::isinf(r) ? 0.0 : r;
}

// [particles] source = "file": the particles each rank reads, the cell (the scene's or the
// file's box), every particle inside it.
void particles_from_file(const Scene& sc, SetupRanks& ranks, Setup& s) {
  const std::vector<std::int64_t> types = material_types(sc);
  DataFile df = ranks.read_data(sc.data_file, types.empty() ? nullptr : &types);
  s.particles = std::move(df.particles);
  const Vec3 L = sc.cell_size.value_or(df.hi - df.lo);
  // The offender with the smallest id over all ranks, as one rank names it.
  const Particles& p = s.particles;
  const std::size_t out = outside_cell(p, L);
  const GlobalId first = ranks.min(out < p.n_owned() ? p.id[out] : std::numeric_limits<GlobalId>::max());
  ranks.agree([&] {
    if (out < p.n_owned() && p.id[out] == first) refuse_outside_cell(sc, p, out, L, df.lo);
  });
  const real_t rmin = smallest_radius(ranks, p);
  ranks.agree([&] { check_neighbour_grid(sc.data_file, L, rmin, sc.skin); });
  s.cell = PeriodicCell(L);
}

// placement = "regions": the cell from the solid volume of every region's diameters (each rank
// draws those of a contiguous block of regions), then each rank places its regions, handing
// the spheres near a region of another rank over after each colour (core/region_packing.hpp).
void particles_by_regions(const Scene& sc, SetupRanks& ranks, Setup& s) {
  const GenerateSpec& g = sc.generate;
  const int node = ranks.ranks_on_node();
  ranks.agree([&] {
    check_specimen_memory(sc.path + ": [particles] count = " + std::to_string(g.count), g.count, ranks.ranks(), node);
  });
  std::optional<RegionCut> cut;
  ranks.agree([&] { as_count_error(sc, [&] { cut = region_cut(sc); }); });
  const int G = cut->grid.regions();
  ExactSums V(1);
  ranks.agree([&] {
    as_count_error(sc, [&] {
      for (int q = 0; q < G; ++q)
        if (std::int64_t(q) * ranks.ranks() / G == ranks.rank())
          for (real_t x : region_diameters(cut->spec, cut->grid, q)) V.add(0, std::numbers::pi / 6 * x * x * x);
      V.normalize();
    });
  });
  ranks.sum(V);
  ranks.agree([&] { as_count_error(sc, [&] { s.cell = region_cell(sc, *cut, V.value(0)); }); });
  const std::vector<int> owners = ranks.region_owners(*cut, s.cell, g.d_max + sc.skin);
  std::vector<int> mine;
  for (int q = 0; q < G; ++q)
    if (owners[std::size_t(q)] == ranks.rank()) mine.push_back(q);
  const RegionExchange exchange = ranks.region_exchange(sc, *cut, s.cell, owners);
  // A sphere with no room is reported after the last round (every rank goes through every
  // round's exchange), and agreed.
  ranks.agree(
      [&] { as_count_error(sc, [&] { s.particles = region_packing(cut->spec, cut->grid, s.cell, mine, exchange); }); });
}

// The sequential generator: the whole specimen (on every rank alike; each keeps its share when
// the shares are taken).
void particles_random(const Scene& sc, Setup& s) {
  const GenerateSpec& g = sc.generate;
  check_specimen_memory(sc.path + ": [particles] count = " + std::to_string(g.count), g.count, 1, 1);  // whole
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
  as_count_error(sc, [&] {
    check_cell_size(s.cell, 0.5 * g.d_max, sc.skin);
    s.particles = random_packing(d, sc.density, s.cell, rng);
  });
}

// [[wall]] (io/serial/wall_setup.hpp): the walls, no sphere beyond or into one (the first wall
// with an offending sphere on any rank, and on it the smallest id, as one rank names it), and
// the walls' critical estimate folded into dt.
void check_walls(const Scene& sc, SetupRanks& ranks, Setup& s, real_t rmin, real_t rmax, real_t& dt) {
  ranks.agree([&] { s.params.walls = scene_walls(sc, s.cell); });
  const Particles& p = s.particles;
  const WallOffence o = first_wall_offence(sc, s.params.walls, p);
  const std::int64_t wall = ranks.min(std::int64_t(o.wall));
  const bool first_wall = o.wall < s.params.walls.size() && std::int64_t(o.wall) == wall;
  const GlobalId id = ranks.min(first_wall ? p.id[o.particle] : std::numeric_limits<GlobalId>::max());
  ranks.agree([&] {
    if (first_wall && p.id[o.particle] == id) refuse_wall_offence(sc, s.params.walls, p, o);
  });
  dt = std::min(dt, walls_critical_time_step(sc, p, rmin, rmax, &s.params.materials));
}

// The scene's run parameters, the walls and driven sets, and the time step against the
// critical estimate of every rank's spheres (rmin, rmax: of every rank).
void run_parameters(const Scene& sc, SetupRanks& ranks, Setup& s, real_t rmin, real_t rmax) {
  apply_scene_run(sc, s);
  real_t dt = critical_time_step(s.particles, sc.law, false, rmin, rmax, &s.params.materials);
  if (!sc.walls.empty()) check_walls(sc, ranks, s, rmin, rmax, dt);
  if (!sc.driven.empty()) {  // [[driven]] (io/serial/wall_setup.hpp): every id a particle of some rank
    std::vector<std::int64_t> n = driven_counts(sc, s.particles);
    ranks.sum(n);
    ranks.agree([&] { check_driven_counts(sc, n); });
    s.params.driven = sc.driven;
  }
  s.critical_dt = ranks.min(dt);
  ranks.agree([&] { s.params.dt = scene_time_step(sc, s.critical_dt); });
  set_servo_speed_caps(s.params.walls, rmin, s.params.dt);
}

}  // namespace

Setup make_setup(const Scene& sc, SetupRanks& ranks) {
  Setup s;
  Holding held = ranks.holding();
  if (sc.source == ParticleSource::File) {
    particles_from_file(sc, ranks, s);
  } else if (sc.generate.placement == GenerateSpec::Placement::Regions) {
    particles_by_regions(sc, ranks, s);
  } else {
    ranks.agree([&] { particles_random(sc, s); });
    held = Holding::Whole;
  }
  const real_t rmax = ranks.max(s.particles.max_radius()), rmin = smallest_radius(ranks, s.particles);
  ranks.agree([&] {
    try {
      check_cell_size(s.cell, rmax, sc.skin);
    } catch (const std::exception& e) { throw InputError(sc.path + ": [cell] " + e.what()); }
  });
  // Wrapped now as the simulation would (the same positions; the overlap check needs them).
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) s.particles.x[a] = s.cell.wrap(s.particles.x[a]);
  // Each rank takes its share; the largest overlap of all ranks' pairs (ties: the lowest rank's).
  const OverlapReport ov = ranks.largest(ranks.take_share(s.particles, s.cell, 2 * rmax + sc.skin, held));
  ranks.agree([&] {
    if (ov.ratio > sc.max_initial_overlap) throw InputError(overlap_message(sc, ov));
  });
  run_parameters(sc, ranks, s, rmin, rmax);
  s.holding = ranks.holding();
  return s;
}

Setup make_setup(const Scene& sc) {
  SetupRanks one;
  return make_setup(sc, one);
}

}  // namespace fabrica
