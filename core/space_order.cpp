#include "core/space_order.hpp"

#include <algorithm>

namespace fabrica {

namespace {
// Spreads the low 21 bits of v so that bit k lands at bit 3k.
std::uint64_t spread3(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}
}  // namespace

namespace {
// The key of fractional coordinates f (each in [0, 1), clamped).
std::uint64_t fractional_key(const Vec3& f) {
  constexpr real_t cells = real_t(1u << kMortonBits);
  std::uint64_t key = 0;
  for (int k = 0; k < 3; ++k) {
    const real_t s = f[k] * cells;
    const std::uint64_t c = s <= 0 ? 0 : (s >= cells ? (1u << kMortonBits) - 1 : std::uint64_t(s));
    key |= spread3(c) << k;
  }
  return key;
}
}  // namespace

std::uint64_t morton_key(const Vec3& x, const Vec3& L) { return fractional_key(x.cwiseQuotient(L)); }

std::uint64_t morton_key(const Vec3& x, const PeriodicCell& cell) { return fractional_key(cell.fractional(x)); }

void space_ranks(const Particles& p, std::size_t n, const PeriodicCell& L, std::vector<std::uint32_t>& rank,
                 std::vector<Index>* order) {
  struct Item {
    std::uint64_t key;
    GlobalId id;
    Index a;
  };
  auto before = [](const Item& u, const Item& v) { return u.key != v.key ? u.key < v.key : u.id < v.id; };
  rank.resize(n);
  // The owned particles already in the order (a rebuild's neighbour search, right after the
  // spatial sort): only the others (the ghosts) are sorted, and merged with them; no item per
  // owned particle (24 bytes each at the rebuild's peak) and no sort of them.
  const std::size_t m = std::min(n, p.n_owned());
  bool sorted = !order && m > 0;
  for (std::size_t a = 1; sorted && a < m; ++a)
    sorted = before({morton_key(p.x[a - 1], L), p.id[a - 1], 0}, {morton_key(p.x[a], L), p.id[a], 0});
  if (sorted) {
    std::vector<Item> rest(n - m);
    for (std::size_t a = m; a < n; ++a) rest[a - m] = {morton_key(p.x[a], L), p.id[a], Index(a)};
    std::sort(rest.begin(), rest.end(), before);
    std::size_t k = 0, g = 0;
    for (std::size_t a = 0; a < m; ++a) {
      const Item own{morton_key(p.x[a], L), p.id[a], Index(a)};
      for (; g < rest.size() && before(rest[g], own); ++g) rank[rest[g].a] = std::uint32_t(k++);
      rank[a] = std::uint32_t(k++);
    }
    for (; g < rest.size(); ++g) rank[rest[g].a] = std::uint32_t(k++);
    return;
  }
  std::vector<Item> items(n);
  for (std::size_t a = 0; a < n; ++a) items[a] = {morton_key(p.x[a], L), p.id[a], Index(a)};
  std::sort(items.begin(), items.end(), before);
  for (std::size_t k = 0; k < n; ++k) rank[items[k].a] = std::uint32_t(k);
  if (order) {
    order->resize(n);
    for (std::size_t k = 0; k < n; ++k) (*order)[k] = items[k].a;
  }
}

}  // namespace fabrica
