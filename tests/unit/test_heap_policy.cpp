// core/heap_policy.hpp: with the policy, blocks of 1 MiB and more that are freed leave the
// resident memory (glibc alone keeps them once its dynamic threshold has risen).
#include "core/heap_policy.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace {

long resident_kib() {
  std::ifstream f("/proc/self/status");
  std::string key;
  long value = -1;
  while (f >> key) {
    if (key == "VmRSS:") {
      f >> value;
      break;
    }
    std::getline(f, key);
  }
  return value;
}

TEST(HeapPolicy, FreedLargeBlocksLeaveResidentMemory) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "the sanitizers' allocator does not follow glibc's settings";
#endif
  if (std::getenv("MALLOC_MMAP_THRESHOLD_") || std::getenv("GLIBC_TUNABLES"))
    GTEST_SKIP() << "the user's allocator settings are kept";
  ASSERT_TRUE(fabrica::map_large_blocks());
  // Three rounds of a 24 MiB block written and freed, as a rebuild makes and frees its arrays.
  // Without the policy the first block's mapping raises glibc's threshold to 24 MiB, the next
  // ones come from the heap, and 24 MiB stay resident after they are freed.
  const std::size_t bytes = std::size_t(24) << 20;
  const long before = resident_kib();
  ASSERT_GT(before, 0);
  for (int round = 0; round < 3; ++round) {
    std::vector<char> block(bytes);
    std::memset(block.data(), round + 1, bytes);
    EXPECT_GT(resident_kib(), before + 20 * 1024);  // the block is resident while it is held
  }
  EXPECT_LT(resident_kib(), before + 4 * 1024) << "resident KiB before " << before;
}

}  // namespace
