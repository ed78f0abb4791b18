// How each particle property travels between ranks, declared once; packing and unpacking of
// ghosts and migrants follow from this list (after waLBerla mesa_pd's syncMode and LAMMPS'
// fields_comm / fields_border).
//   EveryStep  - sent to ghosts every step (forward update) and with ghosts and migrants
//   Drifted    - sent when a ghost is created, with migrants and in a refreshing update; an
//                ordinary forward update leaves it out, since the receiver advances its ghosts'
//                copies itself with the velocities it receives, as their owners advance them
//                (the position: x + dt v, with the same arithmetic, core/domain.hpp GhostDrift)
//   AtCreation - sent when a ghost is created and with migrants, never in between
//   Never      - not sent (accumulators, rebuilt every step)
// Contact history is not a particle property: it travels with migrants, keyed by the two ids
// (parallel/mpi_domain.cpp).
#pragma once
#include "core/particles.hpp"
#include "parallel/byte_buffer.hpp"

#include <cstring>
#include <vector>

namespace fabrica {

enum class Travel { EveryStep, Drifted, AtCreation, Never };

// Calls f(name, vector, travel) for every property of Particles.
template <class P, class F>
void for_each_property(P& p, F&& f) {
  f("x", p.x, Travel::Drifted);
  f("v", p.v, Travel::EveryStep);
  f("w", p.w, Travel::EveryStep);
  f("radius", p.radius, Travel::AtCreation);
  f("mass", p.mass, Travel::AtCreation);
  f("id", p.id, Travel::AtCreation);
  f("material", p.material, Travel::AtCreation);
  f("f", p.f, Travel::Never);
  f("t", p.t, Travel::Never);
}

// Which properties a message carries.
// Forward: EveryStep only (v, w); Refresh: EveryStep + Drifted (x, v, w); Full: EveryStep +
// Drifted + AtCreation; All: every property, the accumulators too (a particle handed to its
// owner at start-up, whose forces the next half-kick uses).
enum class Message { Forward, Refresh, Full, All };

inline bool carries(Message m, Travel t) {
  switch (t) {
    case Travel::EveryStep:
      return true;
    case Travel::Drifted:
      return m != Message::Forward;
    case Travel::AtCreation:
      return m == Message::Full || m == Message::All;
    case Travel::Never:
      return m == Message::All;
  }
  return false;
}

// Bytes per particle of a message.
inline std::size_t bytes_per_particle(Message m) {
  std::size_t b = 0;
  Particles probe;
  for_each_property(probe, [&](const char*, auto& vec, Travel t) {
    if (carries(m, t)) b += sizeof(typename std::decay_t<decltype(vec)>::value_type);
  });
  return b;
}

// Appends the properties of particles idx to buf, particle by particle.
inline void pack(const Particles& p, const std::vector<Index>& idx, Message m, std::vector<char>& buf) {
  const std::size_t start = buf.size();
  buf.resize(start + idx.size() * bytes_per_particle(m));
  char* out = buf.data() + start;
  for (Index a : idx)
    for_each_property(p, [&](const char*, const auto& vec, Travel t) {
      if (!carries(m, t)) return;
      std::memcpy(out, &vec[a], sizeof(vec[a]));
      out += sizeof(vec[a]);
    });
}

// Writes n packed particles from 'in' into p at indices first .. first+n-1; returns the end.
inline const char* unpack(Particles& p, std::size_t first, std::size_t n, Message m, const char* in) {
  for (std::size_t a = first; a < first + n; ++a)
    for_each_property(p, [&](const char*, auto& vec, Travel t) {
      if (!carries(m, t)) return;
      std::memcpy(static_cast<void*>(&vec[a]), in, sizeof(vec[a]));
      in += sizeof(vec[a]);
    });
  return in;
}

// The same messages field by field: every particle's first property, then every particle's
// second, ... (the forward update: each field of a contiguous range of ghosts is one copy).
inline void pack_fields(const Particles& p, const std::vector<Index>& idx, Message m, std::vector<char>& buf) {
  const std::size_t start = buf.size();
  buf.resize(start + idx.size() * bytes_per_particle(m));
  char* out = buf.data() + start;
  for_each_property(p, [&](const char*, const auto& vec, Travel t) {
    if (!carries(m, t)) return;
    constexpr std::size_t size = sizeof(typename std::decay_t<decltype(vec)>::value_type);
    for (Index a : idx) {
      std::memcpy(out, &vec[a], size);
      out += size;
    }
  });
}

// The places in p of a field-by-field message for the contiguous range [first, first + n):
// one piece per carried field, in the message's order (a receive can go straight there).
// Written into 'out' (cleared first; its room is kept, so the per-step update allocates nothing).
inline void field_pieces(Particles& p, std::size_t first, std::size_t n, Message m, std::vector<BytePiece>& out) {
  out.clear();
  for_each_property(p, [&](const char*, auto& vec, Travel t) {
    if (!carries(m, t) || n == 0) return;
    out.push_back({static_cast<void*>(vec.data() + first), n * sizeof(vec[0])});
  });
}
inline std::vector<BytePiece> field_pieces(Particles& p, std::size_t first, std::size_t n, Message m) {
  std::vector<BytePiece> out;
  field_pieces(p, first, n, m, out);
  return out;
}

// The sizes of those pieces for n particles (what a sender of such a message cuts it into),
// written into 'out' (cleared first, its room kept).
inline void field_piece_bytes(std::size_t n, Message m, std::vector<std::size_t>& out) {
  out.clear();
  Particles probe;
  for_each_property(probe, [&](const char*, auto& vec, Travel t) {
    if (carries(m, t) && n != 0) out.push_back(n * sizeof(typename std::decay_t<decltype(vec)>::value_type));
  });
}
inline std::vector<std::size_t> field_piece_bytes(std::size_t n, Message m) {
  std::vector<std::size_t> out;
  field_piece_bytes(n, m, out);
  return out;
}

inline const char* unpack_fields(Particles& p, std::size_t first, std::size_t n, Message m, const char* in) {
  for (const BytePiece& piece : field_pieces(p, first, n, m)) {
    std::memcpy(piece.at, in, piece.bytes);
    in += piece.bytes;
  }
  return in;
}

}  // namespace fabrica
