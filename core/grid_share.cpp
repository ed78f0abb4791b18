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

}  // namespace

void sum_into_slabs(const FieldGrid& grid, const NodeBox& box, const WideSum* box_sums, std::size_t slots, Layers mine,
                    WideSum* slab, GridExchange& ex) {
  const int P = ex.size(), nz = grid.n[2];
  const std::size_t layer = std::size_t(box.len[0]) * std::size_t(box.len[1]);
  const std::size_t n0 = std::size_t(grid.n[0]), n1 = std::size_t(grid.n[1]);
  // One ring a layer of the slabs (the t-th layer of every slab), so that a message is at most
  // one z-layer of a box: [first0, len0, first1, len1] of the sender's box, then its nodes'
  // integers, each as two words (low and high 64 bits: the sums wrap as 128-bit integers do).
  const int rounds = (nz + P - 1) / P;  // the most layers a slab has, the same on every rank
  for (int t = 0; t < rounds; ++t) {
    const GridExchange::Pack pack = [&](int to, std::vector<std::uint64_t>& w) {
      const Layers L = slab_of(nz, to, P);
      const int k = L.first + t;
      if (k >= L.end || layer == 0) return;
      const int b2 = box.local(2, k);
      if (b2 >= box.len[2]) return;  // not in this rank's box
      w.reserve(4 + layer * slots * 2);
      for (int a = 0; a < 2; ++a) w.push_back(std::uint64_t(box.first[a])), w.push_back(std::uint64_t(box.len[a]));
      const WideSum* src = box_sums + std::size_t(b2) * layer * slots;
      for (std::size_t q = 0; q < layer * slots; ++q) {
        const UWide u = UWide(src[q]);
        w.push_back(std::uint64_t(u));
        w.push_back(std::uint64_t(u >> 64));
      }
    };
    const GridExchange::Take take = [&](int, std::span<const std::uint64_t> w) {
      if (w.empty()) return;
      const int first0 = int(w[0]), len0 = int(w[1]), first1 = int(w[2]), len1 = int(w[3]);
      if (w.size() != 4 + std::size_t(len0) * std::size_t(len1) * slots * 2 || mine.first + t >= mine.end)
        throw std::logic_error("sum_into_slabs: a message of the wrong size");
      const std::size_t k = std::size_t(t);  // the layer in this rank's slab
      const std::uint64_t* p = w.data() + 4;
      for (int b1 = 0; b1 < len1; ++b1) {
        const std::size_t j = std::size_t((first1 + b1) % grid.n[1]);
        for (int b0 = 0; b0 < len0; ++b0) {
          const std::size_t i = std::size_t((first0 + b0) % grid.n[0]);
          WideSum* dst = slab + (i + n0 * (j + n1 * k)) * slots;
          for (std::size_t s = 0; s < slots; ++s, p += 2) dst[s] += WideSum(UWide(p[0]) | (UWide(p[1]) << 64));
        }
      }
    };
    ex.ring(pack, take);
  }
}

}  // namespace fabrica
