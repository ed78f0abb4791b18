// core/heap_policy.hpp: with the policy, blocks of 128 KiB and more that are freed leave the
// resident memory (glibc alone keeps them once its dynamic threshold has risen, and keeps
// any block below its threshold that was freed between blocks still in use).
#include "core/heap_policy.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
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

// The policy set before each test; skipped where it is not Fabrica's to set.
class HeapPolicy : public ::testing::Test {
 protected:
  void SetUp() override {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "the sanitizers' allocator does not follow glibc's settings";
#endif
    if (std::getenv("MALLOC_MMAP_THRESHOLD_") || std::getenv("GLIBC_TUNABLES"))
      GTEST_SKIP() << "the user's allocator settings are kept";
    ASSERT_TRUE(fabrica::map_large_blocks());
  }
};

TEST_F(HeapPolicy, FreedLargeBlocksLeaveResidentMemory) {
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

TEST_F(HeapPolicy, FreedMidSizeBlocksBetweenLiveOnesLeaveResidentMemory) {
  // The arrays of a rank's share of a few ten thousand particles are 0.1 to 1 MiB, made and
  // freed at every rebuild among smaller blocks that live on. Here 48 blocks of 256 KiB, each
  // followed by a small block that stays: below the threshold (as with 1 MiB) they come from
  // the heap, and once freed they are holes between the small ones, resident still.
  constexpr std::size_t kBlocks = 48, kBytes = std::size_t(256) << 10;
  static_assert(kBytes >= std::size_t(fabrica::kMapThreshold));
  std::vector<std::unique_ptr<char[]>> big(kBlocks), small(kBlocks);
  const long before = resident_kib();
  ASSERT_GT(before, 0);
  for (std::size_t k = 0; k < kBlocks; ++k) {
    big[k] = std::make_unique<char[]>(kBytes);  // value-initialized: written, resident
    small[k] = std::make_unique<char[]>(64);
  }
  EXPECT_GT(resident_kib(), before + 10 * 1024);  // 12 MiB held
  for (auto& b : big) b.reset();
  EXPECT_LT(resident_kib(), before + 2 * 1024) << "resident KiB before " << before;
}

}  // namespace
