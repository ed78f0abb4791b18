#include "core/grid_share.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fabrica {

NodeBox BoxBuilder::box() const {
  NodeBox b;
  b.n = n_;
  if (!any_) return b;  // no items: an empty box
  for (int a = 0; a < 3; ++a) {
    const double span = hi_[a] - lo_[a] + 1;
    if (!(span < double(n_[a]))) {  // the whole axis (or a non-finite position)
      b.first[a] = 0, b.len[a] = n_[a];
      continue;
    }
    const long lo = long(lo_[a]), n = n_[a];
    b.first[a] = int(((lo % n) + n) % n);
    b.len[a] = int(span);
  }
  return b;
}

namespace {

__extension__ typedef unsigned __int128 UWide;

// Which of the box's z-layers lie in 'slab': the box's index b2 of each, in increasing order.
std::vector<int> box_layers_in(const NodeBox& box, Layers slab) {
  std::vector<int> out;
  for (int b2 = 0; b2 < box.len[2]; ++b2) {
    const int k = (box.first[2] + b2) % box.n[2];
    if (k >= slab.first && k < slab.end) out.push_back(b2);
  }
  return out;
}

}  // namespace

void sum_into_slabs(const FieldGrid& grid, const NodeBox& box, const WideSum* box_sums, std::size_t slots, Layers mine,
                    WideSum* slab, GridExchange& ex) {
  const std::size_t layer = std::size_t(box.len[0]) * std::size_t(box.len[1]);
  // A message: the sender's box (first, len), then its layers in the receiver's slab, each
  // integer as two words (low and high 64 bits: the sums wrap as 128-bit integers do).
  const GridExchange::Pack pack = [&](int to, std::vector<std::uint64_t>& w) {
    const std::vector<int> layers = box_layers_in(box, slab_of(grid.n[2], to, ex.size()));
    if (layers.empty() || layer == 0) return;
    w.reserve(6 + layers.size() * layer * slots * 2);
    for (int a = 0; a < 3; ++a) w.push_back(std::uint64_t(box.first[a]));
    for (int a = 0; a < 3; ++a) w.push_back(std::uint64_t(box.len[a]));
    for (int b2 : layers) {
      const WideSum* src = box_sums + std::size_t(b2) * layer * slots;
      for (std::size_t k = 0; k < layer * slots; ++k) {
        const UWide u = UWide(src[k]);
        w.push_back(std::uint64_t(u));
        w.push_back(std::uint64_t(u >> 64));
      }
    }
  };
  const std::size_t n0 = std::size_t(grid.n[0]), n1 = std::size_t(grid.n[1]);
  const GridExchange::Take take = [&](int, std::span<const std::uint64_t> w) {
    if (w.empty()) return;
    NodeBox from;
    from.n = grid.n;
    for (int a = 0; a < 3; ++a) from.first[a] = int(w[std::size_t(a)]), from.len[a] = int(w[std::size_t(3 + a)]);
    const std::vector<int> layers = box_layers_in(from, mine);
    if (w.size() != 6 + layers.size() * std::size_t(from.len[0]) * std::size_t(from.len[1]) * slots * 2)
      throw std::logic_error("sum_into_slabs: a message of the wrong size");
    const std::uint64_t* p = w.data() + 6;
    for (int b2 : layers) {
      const std::size_t k = std::size_t((from.first[2] + b2) % grid.n[2] - mine.first);
      for (int b1 = 0; b1 < from.len[1]; ++b1) {
        const std::size_t j = std::size_t((from.first[1] + b1) % grid.n[1]);
        for (int b0 = 0; b0 < from.len[0]; ++b0) {
          const std::size_t i = std::size_t((from.first[0] + b0) % grid.n[0]);
          WideSum* dst = slab + (i + n0 * (j + n1 * k)) * slots;
          for (std::size_t s = 0; s < slots; ++s, p += 2) dst[s] += WideSum(UWide(p[0]) | (UWide(p[1]) << 64));
        }
      }
    }
  };
  ex.ring(pack, take);
}

}  // namespace fabrica
