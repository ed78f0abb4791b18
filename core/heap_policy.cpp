#include "core/heap_policy.hpp"

#include <cstdlib>
#include <cstring>

#include <malloc.h>

namespace fabrica {

bool map_large_blocks() {
  if (std::getenv("MALLOC_MMAP_THRESHOLD_")) return false;
  if (const char* t = std::getenv("GLIBC_TUNABLES"); t && std::strstr(t, "mmap_threshold")) return false;
  return mallopt(M_MMAP_THRESHOLD, kMapThreshold) == 1;
}

}  // namespace fabrica
