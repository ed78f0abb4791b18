// Memory requests checked against the machine before anything is allocated (a huge [particles]
// count, a data-file box far larger than its spheres): an InputError naming the input and the
// estimate, instead of std::bad_alloc or a length error from deep inside the set-up.
#pragma once
#include "core/types.hpp"

#include <cstdint>
#include <string>

namespace fabrica {

// Bytes of memory the machine has (physical pages x page size); 0 if unknown.
double machine_memory_bytes();

// A lower bound of what a run of 'spheres' spheres needs: 200 B per sphere (the particle record
// is 144 B and the rebuild reference 24 B; a dense packing needs more, with its neighbour pairs
// and contact history: docs/large.md gives the measured peak per sphere).
constexpr double kBytesPerSphere = 200;

// Throws InputError("<what>: needs at least B of memory (<why>), the machine has M") if 'bytes'
// exceeds the machine's memory.
void check_memory(const std::string& what, double bytes, const std::string& why);
// The check of a specimen of 'spheres' spheres shared by 'ranks' ranks, 'node' of them on this
// machine ('ranks' 1: held whole, "200 B per sphere at least"; else per rank, naming the share).
void check_specimen_memory(const std::string& what, std::int64_t spheres, int ranks, int node);

// The neighbour search's cells for a cell of lengths L and the smallest sphere radius rmin
// (cell edge 2 rmin + skin); refused (InputError naming 'what') above 2^31 cells or the memory.
void check_neighbour_grid(const std::string& what, const Vec3& L, real_t rmin, real_t skin);

}  // namespace fabrica
