#include "core/contact_snapshot.hpp"

#include <array>
#include <cmath>
#include <limits>

namespace fabrica {

namespace {

template <class Model>
void contact_records_of(Model, const Particles& p, const PeriodicCell& cell, const ContactLawParams& scene_law,
                        const Materials* materials, const PairList& pairs,
                        const std::function<void(const ContactRecord&)>& fn) {
  std::array<Vec3, 27> shift;
  for (int c = 0; c < 27; ++c) shift[c] = image_offset(c, cell);
  const bool mixed = materials && !materials->empty();
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const Index i = pairs.i[q], j = pairs.j[q];
    if (!pairs.touching[q] || std::size_t(i) >= p.n_owned()) continue;
    const ContactLawParams& law = mixed ? materials->pair(p.material[i], p.material[j]) : scene_law;
    const bool rolling = law.rolling() && pairs.rolling;
    const Vec3 d = p.x[j] + shift[pairs.image[q]] - p.x[i];
    const real_t sum_r = p.radius[i] + p.radius[j];
    const real_t r2 = d.squaredNorm();
    if (r2 >= sum_r * sum_r) continue;
    const real_t dist = std::sqrt(r2);
    ContactRecord c;
    c.id1 = p.id[i];
    c.id2 = p.id[j];
    c.branch = d;
    c.normal = d / dist;
    c.overlap = sum_r - dist;
    const auto k = Model::template constants<true, false>(law, p.radius[i], p.radius[j], p.mass[i], p.mass[j]);
    c.fn = Model::normal_force(k, c.overlap);
    c.ft = Model::shear_force(k, c.overlap, pairs.shear_spring(q));
    const real_t cap = law.friction * c.fn;
    c.sliding = at_limit(c.ft.squaredNorm(), cap);  // the force loop's classification
    if (rolling) {
      c.mr = pairs.rolling_spring(q);
      c.rolling = at_limit(c.mr.squaredNorm(), Model::rolling_limit(law, k, c.overlap));
    } else {
      c.rolling = true;  // no rolling resistance: every contact rolls freely (spec section 5)
    }
    if (pairs.twisting) c.mr += pairs.twisting_spring(q) * c.normal;  // its twisting moment
    fn(c);
  }
}

template <class Model>
std::vector<ContactRecord> wall_records_of(Model, const Particles& p, const ContactLawParams& law,
                                           const Materials* materials, const std::vector<Wall>& walls,
                                           const WallContactList& wl) {
  const bool mixed = materials && !materials->empty();
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  std::vector<ContactRecord> out;
  for (std::size_t q = 0; q < wl.size(); ++q) {
    if (!wl.touching[q]) continue;
    const Index i = wl.i[q];
    const Wall& W = walls[std::size_t(wl.wall[q])];
    // As the force loop takes it (core/forces.cpp, wall_forces).
    const ContactLawParams& l = W.material >= 0 ? materials->pair(p.material[i], std::size_t(W.material))
        : W.own_law                             ? W.law
        : mixed                                 ? materials->pair(p.material[i], p.material[i])
                                                : law;
    const real_t R = p.radius[i], dist = (p.x[i] - W.point).dot(W.normal);
    if (dist >= R) continue;
    ContactRecord c;
    c.id1 = p.id[i];
    c.id2 = -1 - GlobalId(wl.wall[q]);
    c.normal = -W.normal;
    c.overlap = R - dist;
    c.branch = (R - 0.5 * c.overlap) * c.normal;
    const auto k = Model::template constants<true, false>(l, R, inf, p.mass[i], inf);
    c.fn = Model::normal_force(k, c.overlap);
    c.ft = Model::shear_force(k, c.overlap, wl.fs[q]);
    c.sliding = at_limit(c.ft.squaredNorm(), l.friction * c.fn);
    if (l.rolling() && wl.mr.size() == wl.size()) {
      c.mr = wl.mr[q];
      c.rolling = at_limit(c.mr.squaredNorm(), Model::rolling_limit(l, k, c.overlap));
    } else {
      c.rolling = true;
    }
    if (wl.mt.size() == wl.size()) c.mr += wl.mt[q] * c.normal;
    out.push_back(c);
  }
  return out;
}
}  // namespace

void for_each_contact_record(const Particles& p, const PeriodicCell& cell, const ContactLawParams& law,
                             const PairList& pairs, const std::function<void(const ContactRecord&)>& fn,
                             const Materials* materials) {
  with_model(law.model, [&](auto m) { contact_records_of(m, p, cell, law, materials, pairs, fn); });
}

std::vector<ContactRecord> contact_records(const Particles& p, const PeriodicCell& cell, const ContactLawParams& law,
                                           const PairList& pairs, const Materials* materials) {
  // Room for the touching pairs of owned bodies at once: grown by doubling, the records took up
  // to three times their size at the moment of a copy (53 MB for 17 MB of records at 108,672
  // spheres, the peak of a triaxial run).
  std::size_t n = 0;
  for (std::size_t q = 0; q < pairs.size(); ++q) n += pairs.touching[q] && std::size_t(pairs.i[q]) < p.n_owned();
  std::vector<ContactRecord> out;
  out.reserve(n);
  for_each_contact_record(
      p, cell, law, pairs, [&](const ContactRecord& c) { out.push_back(c); }, materials);
  return out;
}

std::vector<ContactRecord> wall_contact_records(const Particles& p, const ContactLawParams& law,
                                                const std::vector<Wall>& walls, const WallContactList& wl,
                                                const Materials* materials) {
  return with_model(law.model, [&](auto m) { return wall_records_of(m, p, law, materials, walls, wl); });
}

}  // namespace fabrica
