#include "core/particles.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

namespace fabrica {

void Particles::reserve(std::size_t n) {
  for (auto* a : {&x, &v, &w}) a->reserve(n);
  if (!forces_released_)
    for (auto* a : {&f, &t}) a->reserve(n);
  for (auto* a : {&radius, &mass}) a->reserve(n);
  id.reserve(n);
  material.reserve(n);
}

void Particles::reserve_more(std::size_t n) {
  if (size() + n > capacity()) reserve(size() + n + n / 8);
}

void Particles::release_forces() {
  std::vector<Vec3>().swap(f);
  std::vector<Vec3>().swap(t);
  forces_released_ = true;
}

void Particles::zero_forces() {
  for (auto* a : {&f, &t}) {
    a->reserve(capacity());  // the other arrays' room, so that appending does not double them
    a->assign(size(), Vec3::Zero());
  }
  forces_released_ = false;
}

void Particles::resize(std::size_t n) {
  for (auto* a : {&x, &v, &w}) a->resize(n, Vec3::Zero());
  if (!forces_released_)
    for (auto* a : {&f, &t}) a->resize(n, Vec3::Zero());
  for (auto* a : {&radius, &mass}) a->resize(n, 0.0);
  id.resize(n, -1);
  material.resize(n, 0);
}

void Particles::add(const SphereInit& s) {
  if (n_ghost() != 0) throw std::logic_error("Particles::add called while ghosts are present");
  const real_t m = s.density * 4.0 / 3.0 * std::numbers::pi * s.radius * s.radius * s.radius;
  x.push_back(s.x);
  v.push_back(s.v);
  w.push_back(s.w);
  f.push_back(Vec3::Zero());
  t.push_back(Vec3::Zero());
  radius.push_back(s.radius);
  mass.push_back(m);
  id.push_back(s.id);
  material.push_back(s.material);
  ++n_owned_;
}

template <class T>
static void apply_order(std::vector<T>& a, std::span<const Index> order, bool in_place, std::vector<T>& tmp) {
  if (in_place) {  // order[k] >= k
    for (std::size_t k = 0; k < order.size(); ++k) a[k] = a[std::size_t(order[k])];
    a.resize(order.size());
    return;
  }
  // 'tmp' is the array ordered before this one, or empty. For an order much shorter than the
  // arrays (a set-up's hand-over keeps about 1/P of what a rank read), a fresh buffer: reused,
  // the long one would pass on from array to array as spare room (at 869,376 spheres on 8
  // ranks 12 MB per rank at the set-up's peak). Not for the room of ghosts (up to about twice
  // the owned particles on many ranks), which the next ghost build would otherwise allocate
  // again: then the first array's room, of which only the kept particles' pages are touched.
  if (tmp.capacity() > 3 * order.size()) std::vector<T>().swap(tmp);
  else if (a.capacity() <= 3 * order.size()) tmp.reserve(a.capacity());  // the first array's room too
  tmp.resize(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) tmp[k] = a[order[k]];
  a.swap(tmp);
}

std::size_t Particles::append_owned(std::size_t n) {
  if (n_ghost() != 0) throw std::logic_error("Particles::append_owned called while ghosts are present");
  const std::size_t first = size();
  resize(first + n);
  n_owned_ += n;
  return first;
}

std::size_t Particles::append_ghosts(std::size_t n) {
  const std::size_t first = size();
  resize(first + n);
  return first;
}

void Particles::permute_owned(std::span<const Index> order) {
  if (order.size() > n_owned_) throw std::logic_error("permute_owned: order too long");
  resize(n_owned_);
  // A migration keeps nearly all its particles, in their order: compacted in place, with no
  // spare array (at 869,376 spheres on 2 ranks the spare vectors, scalars and ids together
  // were the rank's peak: 19 MB above the migration's start, 6.6 MB above the steady state
  // between rebuilds). Any other order, or one that drops many (a set-up's hand-over, whose
  // dropped particles' pages must go), goes through one spare array at a time, each freed
  // before the next type's is made.
  const bool in_place = 8 * (n_owned_ - order.size()) <= n_owned_ &&
      std::adjacent_find(order.begin(), order.end(), std::greater_equal<Index>()) == order.end();
  {
    std::vector<Vec3> tv;
    for (auto* a : {&x, &v, &w}) apply_order(*a, order, in_place, tv);
    if (!forces_released_)
      for (auto* a : {&f, &t}) apply_order(*a, order, in_place, tv);
  }
  {
    std::vector<real_t> tr;
    for (auto* a : {&radius, &mass}) apply_order(*a, order, in_place, tr);
  }
  std::vector<GlobalId> ti;
  apply_order(id, order, in_place, ti);
  std::vector<std::uint8_t> tm;
  apply_order(material, order, in_place, tm);
  n_owned_ = order.size();
}

real_t Particles::max_radius() const { return radius.empty() ? 0.0 : *std::max_element(radius.begin(), radius.end()); }
real_t Particles::min_radius() const { return radius.empty() ? 0.0 : *std::min_element(radius.begin(), radius.end()); }
real_t Particles::solid_volume() const {
  real_t s = 0;
  for (std::size_t i = 0; i < n_owned_; ++i) s += radius[i] * radius[i] * radius[i];
  return 4.0 / 3.0 * std::numbers::pi * s;
}

void Particles::scale_density(real_t f) {
  for (std::size_t a = 0; a < size(); ++a) mass[a] *= f;
}

}  // namespace fabrica
