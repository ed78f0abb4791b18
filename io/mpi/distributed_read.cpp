#include "io/mpi/distributed_read.hpp"

#include "core/errors.hpp"
#include "io/serial/memory_check.hpp"
#include "parallel/byte_buffer.hpp"
#include "parallel/exchange.hpp"
#include "parallel/guard.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

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

// The header (every rank reads it) and this rank's lines of the body, numbered as in the file.
struct MyLines {
  DataHeader h;
  Piece piece;
  std::int64_t first_line = 0;  // of piece's first line
};
MyLines read_my_lines(const std::string& path, MPI_Comm comm, int rank, int ranks) {
  MyLines m;
  agree(comm, [&] { m.h = read_data_header(path); });
  std::uint64_t size = 0;
  agree(comm, [&] {
    std::error_code ec;
    size = std::uint64_t(std::filesystem::file_size(path, ec));
    if (ec) throw InputError(path + ": cannot read the particle data file's size (" + ec.message() + ")");
  });
  const int node = ranks_on_this_node(comm);
  agree(comm, [&] {
    check_specimen_memory(path + ":" + std::to_string(m.h.natoms_line) + ": '" + std::to_string(m.h.natoms) + " atoms'",
                          m.h.natoms, ranks, node);
  });
  agree(comm, [&] { m.piece = read_piece(path, m.h.body_offset, size, rank, ranks); });
  // Line numbers: the lines of the ranks before this one.
  std::int64_t mine = std::int64_t(m.piece.starts.size()), before = 0;
  MPI_Exscan(&mine, &before, 1, MPI_INT64_T, MPI_SUM, comm);
  if (rank == 0) before = 0;
  m.first_line = m.h.body_line + before;
  return m;
}

// The section keywords of the whole file (a handful), in line order: every rank learns all of
// them and checks them (each section once).
struct Keyword {
  std::int64_t line;
  std::string word;
  DataSection section = DataSection::Atoms;
};
std::vector<Keyword> section_keywords(const std::string& path, MPI_Comm comm, const MyLines& m, int ranks) {
  std::vector<char> keys;
  for (std::size_t k = 0; k < m.piece.starts.size(); ++k) {
    std::istringstream ls(data_line_body(line_of(m.piece, k)));
    std::string w;
    if (ls >> w && std::isalpha(static_cast<unsigned char>(w[0]))) {
      put(keys, std::int64_t(m.first_line + std::int64_t(k)));
      put(keys, std::int64_t(w.size()));
      keys.insert(keys.end(), w.begin(), w.end());
    }
  }
  std::vector<std::vector<char>> out(std::size_t(ranks), keys);
  const std::vector<std::vector<char>> in = exchange_all(comm, out);
  std::vector<Keyword> keywords;  // in line order (ranks hold consecutive lines)
  for (const auto& b : in)
    for (const char *c = b.data(), *e = c + b.size(); c < e;) {
      const auto line = get<std::int64_t>(c);
      const auto n = std::size_t(get<std::int64_t>(c));
      keywords.push_back({line, std::string(c, n)});
      c += n;
    }
  agree(comm, [&] {  // the same on every rank: every rank checks, rank 0's message is kept
    bool seen[2] = {false, false};
    for (Keyword& k : keywords) {
      k.section = data_section_keyword(k.word, path, int(k.line));
      bool& was = seen[k.section == DataSection::Atoms ? 0 : 1];
      if (was) throw InputError(path + ":" + std::to_string(k.line) + ": section '" + k.word + "' appears twice");
      was = true;
    }
  });
  return keywords;
}

// This rank's lines, parsed and checked, in one buffer for each directory rank of their ids.
std::vector<std::vector<char>> parse_for_directory(const std::string& path, MPI_Comm comm, const MyLines& m,
                                                   const std::vector<Keyword>& keywords, int ranks,
                                                   const std::vector<std::int64_t>* types) {
  std::vector<std::vector<char>> to_dir(static_cast<std::size_t>(ranks));
  agree(comm, [&] {
    std::size_t key = 0;
    std::optional<DataSection> section;
    while (key < keywords.size() && keywords[key].line < m.first_line) section = keywords[key++].section;
    for (std::size_t k = 0; k < m.piece.starts.size(); ++k) {
      const std::int64_t lineno = m.first_line + std::int64_t(k);
      if (key < keywords.size() && keywords[key].line == lineno) {
        section = keywords[key++].section;
        continue;
      }
      const std::string line = line_of(m.piece, k);
      std::istringstream ls(data_line_body(line));
      std::string w;
      if (!(ls >> w)) continue;
      if (*section == DataSection::Atoms) {
        const AtomLine a{parse_atom_line(line, m.h, path, int(lineno), types), lineno};
        std::vector<char>& b = to_dir[std::size_t(std::uint64_t(a.s.id) % std::uint64_t(ranks))];
        put(b, std::int8_t(0));
        put(b, a);
      } else {
        const MotionLine ml{parse_velocity_line(line, path, int(lineno)), lineno};
        std::vector<char>& b = to_dir[std::size_t(std::uint64_t(ml.m.id) % std::uint64_t(ranks))];
        put(b, std::int8_t(1));
        put(b, ml);
      }
    }
  });
  return to_dir;
}

// The directory rank's part: every id once, every velocity for an atom, the counts over all
// ranks; its atoms, with their velocities, are its share.
DataFile directory_share(const std::string& path, MPI_Comm comm, std::vector<std::vector<char>>& in,
                         const DataHeader& h, bool has_velocities) {
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
  if (!has_velocities) return df;
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
  return df;
}

}  // namespace

int ranks_on_this_node(MPI_Comm comm) {
  MPI_Comm node;
  MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int n = 1;
  MPI_Comm_size(node, &n);
  MPI_Comm_free(&node);
  return n;
}

DataFile read_data_share(const std::string& path, MPI_Comm comm, const std::vector<std::int64_t>* types) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);
  MyLines m = read_my_lines(path, comm, rank, ranks);
  const std::vector<Keyword> keywords = section_keywords(path, comm, m, ranks);
  bool has_velocities = false;
  for (const Keyword& k : keywords) has_velocities |= k.section == DataSection::Velocities;
  std::vector<std::vector<char>> to_dir = parse_for_directory(path, comm, m, keywords, ranks, types);
  // Freed, not only emptied (a moved-from or cleared std::string may keep its buffer).
  std::string().swap(m.piece.text);
  std::vector<std::size_t>().swap(m.piece.starts);
  std::vector<std::vector<char>> in = exchange_all(comm, to_dir);
  std::vector<std::vector<char>>().swap(to_dir);
  return directory_share(path, comm, in, m.h, has_velocities);
}

}  // namespace fabrica
