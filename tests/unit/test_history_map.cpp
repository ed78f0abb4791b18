// HistoryMap (core/history_map.hpp): springs keyed by the two ids, in pools taken over from a
// contact list or filled by insert; checked against a std::map of the same contacts.
#include "core/history_map.hpp"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <utility>

namespace fabrica {
namespace {

ContactHistory history_of(int k) { return {Vec3(k, -k, 0.5 * k), Vec3(1e-3 * k, 2e-3 * k, -3e-3 * k), -4e-3 * k}; }

TEST(HistoryMap, InsertFindAndOverwrite) {
  HistoryMap h;
  h.reset(4, true);  // fewer than inserted: the table grows; twisting springs kept
  std::map<std::pair<GlobalId, GlobalId>, int> ref;
  std::mt19937_64 rng(7);
  for (int k = 0; k < 5000; ++k) {
    const GlobalId a = GlobalId(rng() % 3000), b = GlobalId(rng() % 3000) - 100;  // b < 0: walls
    h.insert(a, b, history_of(k));
    ref[{a, b}] = k;  // a key inserted again is overwritten
  }
  ASSERT_EQ(h.size(), ref.size());
  EXPECT_EQ(h.pool_size(), ref.size());  // an overwrite takes no new slot
  for (const auto& [key, k] : ref) {
    const std::uint32_t s = h.find_slot(key.first, key.second);
    ASSERT_NE(s, HistoryMap::kNone);
    const ContactHistory got = h.at(s), want = history_of(k);
    EXPECT_EQ(got.fs, want.fs);
    EXPECT_EQ(got.mr, want.mr);
    EXPECT_EQ(got.mt, want.mt);
  }
  EXPECT_EQ(h.find_slot(5000, 5000), HistoryMap::kNone);
  std::size_t seen = 0;
  h.for_each([&](GlobalId a, GlobalId b, const ContactHistory& c) {
    ++seen;
    EXPECT_EQ(c.fs, history_of(ref.at({a, b})).fs);
  });
  EXPECT_EQ(seen, ref.size());
}

TEST(HistoryMap, AdoptedPoolsAreKeyedNotCopied) {
  // A contact list's pools: slots 0..5, of which 1 and 4 are free (their contents stale).
  std::vector<Vec3> fs, mr;
  std::vector<real_t> mt;
  for (int s = 0; s < 6; ++s)
    fs.push_back(history_of(s).fs), mr.push_back(history_of(s).mr), mt.push_back(history_of(s).mt);
  const Vec3* data = fs.data();
  for (bool rolling : {true, false}) {
    const bool twisting = !rolling;
    std::vector<Vec3> f = fs, m = mr;
    std::vector<real_t> t = mt;
    f.reserve(8);  // room for the wall's slot: no reallocation below
    m.reserve(8);
    t.reserve(8);
    const Vec3* fdata = f.data();
    HistoryMap h;
    h.adopt_pools(std::move(f), std::move(m), rolling, std::move(t), twisting);
    for (GlobalId s : {0, 2, 3, 5}) h.insert_slot(10 + s, 20 + s, std::uint32_t(s));
    h.insert(7, -1, history_of(9));  // a wall contact: a new slot after the adopted ones
    EXPECT_EQ(h.size(), 5u);
    ASSERT_EQ(h.pool_size(), 7u);
    EXPECT_EQ(h.find_slot(13, 23), 3u);
    EXPECT_EQ(h.find_slot(11, 21), HistoryMap::kNone);  // a free slot is not a contact
    EXPECT_EQ(h.find_slot(7, -1), 6u);
    EXPECT_EQ(h.at(5).fs, history_of(5).fs);
    EXPECT_EQ(h.at(6).fs, history_of(9).fs);
    // Without rolling the rolling springs read zero.
    EXPECT_EQ(h.at(5).mr, rolling ? history_of(5).mr : Vec3(Vec3::Zero()));
    EXPECT_EQ(h.at(6).mr, rolling ? history_of(9).mr : Vec3(Vec3::Zero()));
    // Without twisting the twisting springs read zero.
    EXPECT_EQ(h.at(5).mt, twisting ? history_of(5).mt : 0.0);
    EXPECT_EQ(h.at(6).mt, twisting ? history_of(9).mt : 0.0);
    std::vector<Vec3> out_fs, out_mr;
    std::vector<real_t> out_mt;
    h.take_pools(out_fs, out_mr, out_mt);
    ASSERT_EQ(out_fs.size(), 7u);
    EXPECT_EQ(out_fs.data(), fdata);  // the same buffer: moved, never copied
    EXPECT_EQ(out_mr.size(), rolling ? 7u : 0u);
    EXPECT_EQ(out_mt.size(), twisting ? 7u : 0u);
    EXPECT_EQ(h.find_slot(13, 23), 3u);  // the keys stay
  }
  EXPECT_EQ(fs.data(), data);
}

TEST(HistoryMap, KeysAreIndexedOnlyWhenAsked) {
  // After adopt_pools the keys are recorded without a table (the caller frees its list first):
  // lookups before index() are refused, not answered wrongly; after it every key is found.
  std::vector<Vec3> fs(1000, Vec3::Zero()), mr;
  HistoryMap h;
  h.adopt_pools(std::move(fs), std::move(mr), false, {}, false);
  for (GlobalId k = 0; k < 500; ++k) h.insert_slot(k, 7 * k + 1, std::uint32_t(2 * k));
  EXPECT_THROW(h.find_slot(3, 22), std::logic_error);
  h.index();
  for (GlobalId k = 0; k < 500; ++k) {
    EXPECT_EQ(h.find_slot(k, 7 * k + 1), std::uint32_t(2 * k));
    EXPECT_EQ(h.find_slot(k, 7 * k + 2), HistoryMap::kNone);
  }
  h.index();  // a second call changes nothing
  EXPECT_EQ(h.find_slot(499, 3494), 998u);
  // An empty map answers without a table.
  HistoryMap e;
  e.adopt_pools({}, {}, false, {}, false);
  EXPECT_EQ(e.find_slot(1, 2), HistoryMap::kNone);
}

}  // namespace
}  // namespace fabrica
