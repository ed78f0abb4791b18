// How the process's heap returns memory: large blocks straight to the operating system.
//
// glibc serves a block above its mmap threshold with a mapping of its own, returned to the
// system when freed, and smaller ones from the heap, which keeps freed memory for reuse. The
// threshold starts at 128 KiB but rises to the size of every mapped block freed (up to 32 MiB):
// after the first rebuild of a large specimen every particle-sized array comes from the heap,
// and the arrays a rebuild frees and makes again leave tens of MB resident beyond what is in
// use (at 869,376 spheres on one rank: peak RSS 318 MiB for a 269 MB heap peak). A fixed
// threshold keeps blocks of 1 MiB and more in mappings of their own, so that the resident
// memory follows what is in use, at the cost of the page faults of fresh mappings (at that
// size the neighbour build about 4 % longer, the step within the noise; docs/large.md).
#pragma once

namespace fabrica {

// Sets glibc's mmap threshold to 1 MiB, unless the user set one (MALLOC_MMAP_THRESHOLD_, or
// glibc.malloc.mmap_threshold in GLIBC_TUNABLES). Call once, early in main. Returns whether
// it was set.
bool map_large_blocks();

}  // namespace fabrica
