// How the process's heap returns memory: blocks of 128 KiB and more straight to the operating
// system.
//
// glibc serves a block above its mmap threshold with a mapping of its own, returned to the
// system when freed, and smaller ones from the heap, which keeps freed memory for reuse. The
// threshold starts at 128 KiB but rises to the size of every mapped block freed (up to 32 MiB):
// after the first rebuild of a large specimen every particle-sized array comes from the heap,
// and the arrays a rebuild frees and makes again leave tens of MB resident beyond what is in
// use (at 869,376 spheres on one rank: peak RSS 318 MiB for a 269 MB heap peak). A fixed
// threshold keeps blocks of 128 KiB and more in mappings of their own, so that the resident
// memory follows what is in use. It was 1 MiB at first: a rank's arrays of 0.1 to 1 MiB (a
// share of 5,000 to 40,000 particles, common on a cluster) then came from the heap, where the
// holes a rebuild left between live blocks stayed resident and added up over the rebuilds
// (108,672 spheres on 2 ranks: 31.3 MiB a rank after 100 steps and 32.6 after 3,000, against
// 29.1 and 29.2 now). The cost is the page faults of fresh mappings at every rebuild, and the
// mapped arrays all starting at the same place in a page, which slows the first pass of a
// specimen that sits in the cache: 13,584 spheres on 1 rank 1.5-3.5 % slower, larger ones
// within the noise (benchmarks/README.md, "The mmap threshold at 128 KiB").
#pragma once

namespace fabrica {

inline constexpr int kMapThreshold = 128 << 10;

// Sets glibc's mmap threshold to kMapThreshold, unless the user set one
// (MALLOC_MMAP_THRESHOLD_, or glibc.malloc.mmap_threshold in GLIBC_TUNABLES). Call once, early
// in main. Returns whether it was set.
bool map_large_blocks();

}  // namespace fabrica
