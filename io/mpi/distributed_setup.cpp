#include "io/mpi/distributed_setup.hpp"

#include "core/exact_sum.hpp"
#include "core/generate.hpp"
#include "core/neighbor.hpp"
#include "core/timestep.hpp"
#include "core/errors.hpp"
#include "io/serial/lammps_data.hpp"
#include "io/serial/wall_setup.hpp"
#include "io/serial/memory_check.hpp"
#include "parallel/byte_buffer.hpp"
#include "parallel/exchange.hpp"
#include "parallel/guard.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <unordered_map>

namespace fabrica {

namespace {

// What a rank read of the body, travelling to the directory rank of its id.
struct AtomLine {
  SphereInit s;
  std::int64_t line;
};
struct MotionLine {
  DataMotion m;
  std::int64_t line;
};

// Squared periodic distance from x to the box [lo, lo + side).
double box_distance2(const Vec3& x, const Vec3& lo, const Vec3& side, const Vec3& L) {
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double t = std::fmod(x[k] - lo[k], L[k]);
    if (t < 0) t += L[k];
    const double d = t <= side[k] ? 0.0 : std::min(t - side[k], L[k] - t);
    d2 += d * d;
  }
  return d2;
}

int ranks_on_this_node(MPI_Comm comm) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}

// This rank's lines of the data file's body: those that start in its byte range
// [body + (size - body) r / P, body + (size - body) (r + 1) / P), the last one read to its end.
struct Piece {
  std::string text;
  std::vector<std::size_t> starts;  // of the lines in 'text'
};
Piece read_piece(const std::string& path, std::uint64_t body, std::uint64_t size, int rank, int ranks) {
  const std::uint64_t span = size - body;
  const std::uint64_t b0 = body + span * std::uint64_t(rank) / std::uint64_t(ranks);
  const std::uint64_t b1 = body + span * std::uint64_t(rank + 1) / std::uint64_t(ranks);
  Piece p;
  if (b0 == b1) return p;
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(path + ": cannot open the particle data file (" +
                     std::string(errno ? std::strerror(errno) : "unreadable") + ")");
  // A line starting before b0 is the previous rank's: start after its end.
  std::uint64_t from = b0;
  if (b0 > body) {
    in.seekg(std::streamoff(b0 - 1));
    std::string rest;
    std::getline(in, rest);  // from b0 - 1 to the end of that line
    from = b0 - 1 + rest.size() + 1;
    if (from >= b1) return p;
  }
  in.clear();
  in.seekg(std::streamoff(from));
  std::string line;
  std::uint64_t at = from;
  while (at < b1 && std::getline(in, line)) {
    p.starts.push_back(p.text.size());
    p.text += line;
    p.text += '\n';
    at += line.size() + 1;
  }
  return p;
}

std::string line_of(const Piece& p, std::size_t k) {
  const std::size_t b = p.starts[k];
  const std::size_t e = p.text.find('\n', b);
  return p.text.substr(b, e - b);
}

// The distributed read of a data file: this rank's share (from the directory), its box.
DataFile read_data_share(const std::string& path, MPI_Comm comm, int rank, int ranks, std::int64_t& natoms_out,
                         const std::vector<std::int64_t>* types) {
  DataHeader h;
  agree(comm, [&] { h = read_data_header(path); });
  natoms_out = h.natoms;
  std::uint64_t size = 0;
  agree(comm, [&] {
    std::error_code ec;
    size = std::uint64_t(std::filesystem::file_size(path, ec));
    if (ec) throw InputError(path + ": cannot read the particle data file's size (" + ec.message() + ")");
  });
  const int node = ranks_on_this_node(comm);
  agree(comm, [&] {
    check_memory(path + ":" + std::to_string(h.natoms_line) + ": '" + std::to_string(h.natoms) + " atoms'",
                 double(h.natoms) * kBytesPerSphere / ranks * node,
                 "200 B per sphere at least, " + std::to_string(h.natoms / ranks) + " spheres on each of " +
                     std::to_string(node) + " rank(s) of this node");
  });
  Piece piece;
  agree(comm, [&] { piece = read_piece(path, h.body_offset, size, rank, ranks); });
  // Line numbers: the lines of the ranks before this one.
  std::int64_t mine = std::int64_t(piece.starts.size()), before = 0;
  MPI_Exscan(&mine, &before, 1, MPI_INT64_T, MPI_SUM, comm);
  if (rank == 0) before = 0;
  const std::int64_t first_line = h.body_line + before;
  // Section keywords: every rank learns all of them (a handful) and their lines.
  std::vector<char> keys;
  for (std::size_t k = 0; k < piece.starts.size(); ++k) {
    std::istringstream ls(data_line_body(line_of(piece, k)));
    std::string w;
    if (ls >> w && std::isalpha(static_cast<unsigned char>(w[0]))) {
      put(keys, std::int64_t(first_line + std::int64_t(k)));
      put(keys, std::int64_t(w.size()));
      keys.insert(keys.end(), w.begin(), w.end());
    }
  }
  std::vector<std::vector<char>> out(std::size_t(ranks), keys), in = exchange_all(comm, out);
  struct Keyword {
    std::int64_t line;
    std::string word;
  };
  std::vector<Keyword> keywords;  // in line order (ranks hold consecutive lines)
  for (const auto& b : in)
    for (const char *c = b.data(), *e = c + b.size(); c < e;) {
      const auto line = get<std::int64_t>(c);
      const auto n = std::size_t(get<std::int64_t>(c));
      keywords.push_back({line, std::string(c, n)});
      c += n;
    }
  std::vector<DataSection> section_of;  // of each keyword
  agree(comm, [&] {                     // the same on every rank: every rank checks, rank 0's message is kept
    bool seen[2] = {false, false};
    for (const Keyword& k : keywords) {
      const DataSection s = data_section_keyword(k.word, path, int(k.line));
      bool& was = seen[s == DataSection::Atoms ? 0 : 1];
      if (was) throw InputError(path + ":" + std::to_string(k.line) + ": section '" + k.word + "' appears twice");
      was = true;
      section_of.push_back(s);
    }
  });
  // This rank's lines, parsed and checked; sent to the directory rank of their id.
  std::vector<std::vector<char>> to_dir(static_cast<std::size_t>(ranks));
  bool has_velocities = false;
  for (DataSection s : section_of) has_velocities |= s == DataSection::Velocities;
  agree(comm, [&] {
    std::size_t key = 0;
    std::optional<DataSection> section;
    while (key < keywords.size() && keywords[key].line < first_line) section = section_of[key++];
    for (std::size_t k = 0; k < piece.starts.size(); ++k) {
      const std::int64_t lineno = first_line + std::int64_t(k);
      if (key < keywords.size() && keywords[key].line == lineno) {
        section = section_of[key++];
        continue;
      }
      const std::string line = line_of(piece, k);
      std::istringstream ls(data_line_body(line));
      std::string w;
      if (!(ls >> w)) continue;
      if (*section == DataSection::Atoms) {
        const AtomLine a{parse_atom_line(line, h, path, int(lineno), types), lineno};
        std::vector<char>& b = to_dir[std::size_t(std::uint64_t(a.s.id) % std::uint64_t(ranks))];
        put(b, std::int8_t(0));
        put(b, a);
      } else {
        const MotionLine m{parse_velocity_line(line, path, int(lineno)), lineno};
        std::vector<char>& b = to_dir[std::size_t(std::uint64_t(m.m.id) % std::uint64_t(ranks))];
        put(b, std::int8_t(1));
        put(b, m);
      }
    }
  });
  // Freed, not only emptied (a moved-from or cleared std::string may keep its buffer).
  std::string().swap(piece.text);
  std::vector<std::size_t>().swap(piece.starts);
  in = exchange_all(comm, to_dir);
  std::vector<std::vector<char>>().swap(to_dir);
  // The directory: every id once, every velocity for an atom; the counts over all ranks.
  std::vector<AtomLine> atoms;
  std::vector<MotionLine> motions;
  for (auto& b : in) {
    for (const char *c = b.data(), *e = c + b.size(); c < e;) {
      if (get<std::int8_t>(c) == 0) atoms.push_back(get<AtomLine>(c));
      else motions.push_back(get<MotionLine>(c));
    }
    std::vector<char>().swap(b);
  }
  auto by_id_line = [](const auto& x, const auto& y, auto id) {
    return id(x) != id(y) ? id(x) < id(y) : x.line < y.line;
  };
  std::sort(atoms.begin(), atoms.end(), [&](const AtomLine& x, const AtomLine& y) {
    return by_id_line(x, y, [](const AtomLine& a) { return a.s.id; });
  });
  std::sort(motions.begin(), motions.end(), [&](const MotionLine& x, const MotionLine& y) {
    return by_id_line(x, y, [](const MotionLine& m) { return m.m.id; });
  });
  agree(comm, [&] {
    for (std::size_t k = 1; k < atoms.size(); ++k)
      if (atoms[k].s.id == atoms[k - 1].s.id)
        throw InputError(data_duplicate_id(path, int(atoms[k].line), atoms[k].s.id, false));
    for (std::size_t k = 1; k < motions.size(); ++k)
      if (motions[k].m.id == motions[k - 1].m.id)
        throw InputError(data_duplicate_id(path, int(motions[k].line), motions[k].m.id, true));
  });
  std::int64_t counts[2] = {std::int64_t(atoms.size()), std::int64_t(motions.size())};
  MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_INT64_T, MPI_SUM, comm);
  agree(comm, [&] {
    if (counts[0] != h.natoms) throw InputError(data_count_error(path, h.natoms, counts[0], false));
  });
  DataFile df;
  df.lo = h.lo;
  df.hi = h.hi;
  df.has_velocities = has_velocities;
  df.particles.reserve(atoms.size());
  for (const AtomLine& a : atoms) df.particles.add(a.s);
  if (has_velocities) {
    agree(comm, [&] {
      std::size_t k = 0;  // both sorted by id
      for (const MotionLine& m : motions) {
        while (k < atoms.size() && atoms[k].s.id < m.m.id) ++k;
        if (k == atoms.size() || atoms[k].s.id != m.m.id)
          throw InputError(data_orphan_velocity(path, int(m.line), m.m.id));
        df.particles.v[k] = m.m.v;
        df.particles.w[k] = m.m.w;
      }
    });
    agree(comm, [&] {
      if (counts[1] != h.natoms) throw InputError(data_count_error(path, h.natoms, counts[1], true));
    });
  }
  return df;
}

}  // namespace

Setup make_distributed_setup(const Scene& sc, MPI_Comm comm, const MpiDomainOptions& options) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);
  Setup s;
  Holding holding = Holding::Share;
  if (sc.source == ParticleSource::File) {
    std::int64_t natoms = 0;
    const std::vector<std::int64_t> types = material_types(sc);
    DataFile df = read_data_share(sc.data_file, comm, rank, ranks, natoms, types.empty() ? nullptr : &types);
    s.particles = std::move(df.particles);
    const Vec3 L = sc.cell_size.value_or(df.hi - df.lo);
    // The offender with the smallest id over all ranks, as the serial check names it.
    const std::size_t out = outside_cell(s.particles, L);
    GlobalId first = out < s.particles.n_owned() ? s.particles.id[out] : std::numeric_limits<GlobalId>::max();
    MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT64_T, MPI_MIN, comm);
    agree(comm, [&] {
      if (out < s.particles.n_owned() && s.particles.id[out] == first)
        refuse_outside_cell(sc, s.particles, out, L, df.lo);
    });
    double rmin = s.particles.n_owned() ? s.particles.min_radius() : 1e300;
    MPI_Allreduce(MPI_IN_PLACE, &rmin, 1, MPI_DOUBLE, MPI_MIN, comm);
    agree(comm, [&] { check_neighbour_grid(sc.data_file, L, rmin, sc.skin); });
    s.cell = PeriodicCell(L);
  } else if (sc.generate.placement == GenerateSpec::Placement::Regions) {
    // Region by region: each rank its block of regions; after each colour, the spheres placed
    // go to the ranks of the adjacent regions (core/region_packing.hpp).
    const GenerateSpec& g = sc.generate;
    const int node = ranks_on_this_node(comm);
    agree(comm, [&] {
      check_memory(sc.path + ": [particles] count = " + std::to_string(g.count),
                   double(g.count) * kBytesPerSphere / ranks * node,
                   "200 B per sphere at least, " + std::to_string(g.count / ranks) + " spheres on each of " +
                       std::to_string(node) + " rank(s) of this node");
    });
    std::optional<RegionCut> cut;
    agree(comm, [&] { cut = region_cut(sc); });
    const int G = cut->grid.regions();
    // The solid volume (for the cell) over contiguous blocks of regions, then the regions each
    // rank places: those whose centre its subdomain will hold (a Cartesian decomposition made
    // as the simulation will make it, with the largest possible cutoff), so that few spheres
    // move afterwards; blocks of regions for METIS.
    std::vector<int> mine;
    for (int q = 0; q < G; ++q)
      if (std::int64_t(q) * ranks / G == rank) mine.push_back(q);
    ExactSums V(1);
    for (int q : mine)
      for (real_t x : region_diameters(cut->spec, cut->grid, q)) V.add(0, std::numbers::pi / 6 * x * x * x);
    V.normalize();
    MPI_Allreduce(MPI_IN_PLACE, V.words().data(), int(V.words().size()), MPI_INT64_T, MPI_SUM, comm);
    V.normalize();
    agree(comm, [&] { s.cell = region_cell(sc, *cut, V.value(0)); });
    std::vector<int> owner_of(static_cast<std::size_t>(G));
    for (int q = 0; q < G; ++q) owner_of[std::size_t(q)] = int(std::int64_t(q) * ranks / G);
    if (options.kind == DecompositionKind::Cartesian) {
      const Decomposition dec = Decomposition::cartesian(ranks, s.cell.lengths(), g.d_max + sc.skin);
      for (int q = 0; q < G; ++q)
        owner_of[std::size_t(q)] = dec.owner(dec.bin_of(cut->grid.lower(q) + 0.5 * cut->grid.side(), s.cell.lengths()));
    }
    auto owner = [&](int region) { return owner_of[std::size_t(region)]; };
    mine.clear();
    for (int q = 0; q < G; ++q)
      if (owner(q) == rank) mine.push_back(q);
    const RegionExchange exchange = [&](const Particles& placed, const std::vector<int>& region_of) {
      std::vector<std::vector<char>> out(static_cast<std::size_t>(ranks));
      for (std::size_t a = 0; a < placed.n_owned(); ++a) {
        // Only to the ranks of adjacent boxes it can reach: a later sphere of box h overlaps it
        // only if it lies within d_max of h (the boxes are 4 d_max wide or more: a thin layer).
        std::vector<int> to;
        for (int h : cut->grid.neighbours(region_of[a])) {
          const int r = owner(h);
          if (r == rank || std::find(to.begin(), to.end(), r) != to.end()) continue;
          if (box_distance2(placed.x[a], cut->grid.lower(h), cut->grid.side(), s.cell.lengths()) < g.d_max * g.d_max)
            to.push_back(r);
        }
        for (int r : to) {
          put(out[std::size_t(r)], placed.id[a]);
          put(out[std::size_t(r)], placed.radius[a]);
          put(out[std::size_t(r)], placed.x[a]);
        }
      }
      const auto in = exchange_all(comm, out);
      Particles got;
      for (const auto& b : in)
        for (const char *c = b.data(), *e = c + b.size(); c < e;) {
          const auto id = get<GlobalId>(c);
          const auto rad = get<real_t>(c);
          got.add({id, rad, sc.density, get<Vec3>(c)});  // its material and mass: apply_scene_run
        }
      return got;
    };
    // A sphere with no room is reported after the last round (every rank goes through every
    // round's exchange), and agreed.
    agree(comm, [&] {
      try {
        s.particles = region_packing(cut->spec, cut->grid, s.cell, mine, exchange);
      } catch (const std::runtime_error& e) {
        throw InputError(sc.path + ": [particles] count = " + std::to_string(g.count) + ": " + e.what());
      }
    });
  } else {
    // The generator is sequential: every rank makes the whole specimen (identical), and keeps
    // its share in the adoption below.
    agree(comm, [&] {
      Scene one = sc;
      one.max_initial_overlap = std::numeric_limits<double>::infinity();  // checked below
      one.density_scaling = 1.0;                                          // applied below
      Setup whole = make_setup(one);
      s.particles = std::move(whole.particles);
      s.cell = whole.cell;
    });
    holding = Holding::Whole;
  }
  double r[2] = {s.particles.n_owned() ? s.particles.max_radius() : 0.0,
                 s.particles.n_owned() ? -s.particles.min_radius() : -1e300};
  MPI_Allreduce(MPI_IN_PLACE, r, 2, MPI_DOUBLE, MPI_MAX, comm);
  const real_t rmax = r[0], rmin = -r[1];
  agree(comm, [&] {
    try {
      check_cell_size(s.cell, rmax, sc.skin);
    } catch (const std::exception& e) { throw InputError(sc.path + ": [cell] " + e.what()); }
  });
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) s.particles.x[a] = s.cell.wrap(s.particles.x[a]);

  // Each rank takes the particles of its subdomain, and with the ghosts of the decomposition
  // finds the largest overlap of its pairs; the largest of all ranks (ties: the lowest ids).
  {
    MpiDomain domain(comm, options);
    const real_t cutoff = 2 * rmax + sc.skin;
    domain.adopt(s.particles, s.cell, cutoff, nullptr, holding);
    domain.build_ghosts(s.particles, s.cell, cutoff);
    NeighborSearch search;
    PairList pairs;
    search.build(s.particles, s.cell, 0.0, pairs);
    OverlapReport ov;
    const Vec3& L = s.cell.lengths();
    const Particles& p = s.particles;
    for (std::size_t q = 0; q < pairs.size(); ++q) {
      const Index i = pairs.i[q], j = pairs.j[q];
      const real_t un = p.radius[i] + p.radius[j] - (p.x[j] + image_offset(pairs.image[q], L) - p.x[i]).norm();
      const real_t ratio = un / std::min(p.radius[i], p.radius[j]);
      if (un > 0 && ratio > ov.ratio) ov = {ratio, un, p.id[i], p.id[j]};
    }
    s.particles.clear_ghosts();
    std::vector<double> all(std::size_t(4 * ranks));
    const double mine[4] = {ov.ratio, ov.overlap, double(ov.a), double(ov.b)};
    MPI_Allgather(mine, 4, MPI_DOUBLE, all.data(), 4, MPI_DOUBLE, comm);
    OverlapReport worst;
    for (int k = 0; k < ranks; ++k) {
      const double* o = &all[std::size_t(4 * k)];
      if (o[0] > worst.ratio) worst = {o[0], o[1], GlobalId(o[2]), GlobalId(o[3])};
    }
    agree(comm, [&] {
      if (worst.ratio > sc.max_initial_overlap) throw InputError(overlap_message(sc, worst));
    });
  }
  apply_scene_run(sc, s);
  double dt =
      s.particles.n_owned() ? critical_time_step(s.particles, sc.law, false, rmin, rmax, &s.params.materials) : 1e300;
  if (!sc.walls.empty()) {  // [[wall]] (io/serial/wall_setup.hpp); each rank checks its spheres
    agree(comm, [&] { s.params.walls = scene_walls(sc, s.cell); });
    // The first wall with an offending sphere on any rank, and on it the smallest id, as the
    // serial check names it.
    const WallOffence o = first_wall_offence(sc, s.params.walls, s.particles);
    std::int64_t first[2] = {std::int64_t(o.wall), std::numeric_limits<std::int64_t>::max()};
    MPI_Allreduce(MPI_IN_PLACE, &first[0], 1, MPI_INT64_T, MPI_MIN, comm);
    if (o.wall == std::size_t(first[0]) && o.wall < s.params.walls.size()) first[1] = s.particles.id[o.particle];
    MPI_Allreduce(MPI_IN_PLACE, &first[1], 1, MPI_INT64_T, MPI_MIN, comm);
    agree(comm, [&] {
      if (o.wall == std::size_t(first[0]) && o.wall < s.params.walls.size() && s.particles.id[o.particle] == first[1])
        refuse_wall_offence(sc, s.params.walls, s.particles, o);
    });
    dt = std::min(dt, walls_critical_time_step(sc, s.particles, rmin, rmax, &s.params.materials));
  }
  if (!sc.driven.empty()) {  // [[driven]]: every id a particle of some rank
    std::vector<std::int64_t> n = driven_counts(sc, s.particles);
    MPI_Allreduce(MPI_IN_PLACE, n.data(), int(n.size()), MPI_INT64_T, MPI_SUM, comm);
    agree(comm, [&] { check_driven_counts(sc, n); });
    s.params.driven = sc.driven;
  }
  MPI_Allreduce(MPI_IN_PLACE, &dt, 1, MPI_DOUBLE, MPI_MIN, comm);
  s.critical_dt = dt;
  agree(comm, [&] { s.params.dt = scene_time_step(sc, s.critical_dt); });
  set_servo_speed_caps(s.params.walls, rmin, s.params.dt);
  s.holding = Holding::Share;
  return s;
}

Setup make_run_setup(const Scene& scene, MPI_Comm comm, const MpiDomainOptions& options) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  if (ranks > 1) return make_distributed_setup(scene, comm, options);
  Setup s;
  agree(comm, [&] { s = make_setup(scene); });
  return s;
}

SpecimenTotals specimen_totals(const Particles& p, MPI_Comm comm) {
  ExactSums sums(3);
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const real_t R = p.radius[a];
    sums.add(0, 2 * R);
    sums.add(1, p.mass[a]);
    sums.add(2, 4.0 / 3.0 * std::numbers::pi * R * R * R);
  }
  sums.normalize();
  std::int64_t n = std::int64_t(p.n_owned());
  MPI_Allreduce(MPI_IN_PLACE, sums.words().data(), int(sums.words().size()), MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, &n, 1, MPI_INT64_T, MPI_SUM, comm);
  sums.normalize();
  return {n, sums.value(0), sums.value(1), sums.value(2)};
}

}  // namespace fabrica
