#include "core/specimen_response.hpp"

#include "core/contact/models.hpp"

#include <algorithm>
#include <cmath>

namespace fabrica {

namespace {

// Visits every touching contact with an owned body i: f(d2, n, kn, ks, cn, cs), the squared
// branch length, the unit normal, the tangent stiffnesses and (Viscous) the dashpots of its law.
template <class Model, bool Viscous, class F>
void for_each_contact_response(const Particles& P, const PairList& pl, const PeriodicCell& cell,
                               const ContactLawParams& scene_law, const Materials* materials, F&& f) {
  const bool mixed = materials && !materials->empty();
  for (std::size_t q = 0; q < pl.size(); ++q) {
    if (!pl.touching[q] || std::size_t(pl.i[q]) >= P.n_owned()) continue;
    const Index i = pl.i[q], j = pl.j[q];
    const Vec3 d = P.x[j] + image_offset(pl.image[q], cell) - P.x[i];
    const real_t d2 = d.squaredNorm();
    if (d2 == 0) continue;
    const real_t dist = std::sqrt(d2);
    const Vec3 n = d / dist;
    const real_t un = std::max(0.0, P.radius[i] + P.radius[j] - dist);
    const ContactLawParams& law = mixed ? materials->pair(P.material[i], P.material[j]) : scene_law;
    const auto c = Model::template constants<false, Viscous>(law, P.radius[i], P.radius[j], P.mass[i], P.mass[j]);
    const real_t kn = Model::normal_stiffness(c, un), ks = Model::shear_stiffness(c, un);
    real_t cn = 0, cs = 0;
    if constexpr (Viscous) cn = Model::normal_dashpot(c, un), cs = Model::shear_dashpot(c, un);
    f(d2, n, kn, ks, cn, cs);
  }
}

template <class Model, bool Viscous>
void add_response(const Particles& P, const PairList& pl, const PeriodicCell& cell, const ContactLawParams& scene_law,
                  const Materials* materials, double* m) {
  for_each_contact_response<Model, Viscous>(
      P, pl, cell, scene_law, materials, [&](real_t d2, const Vec3& n, real_t kn, real_t ks, real_t cn, real_t cs) {
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l) {
            const real_t w = d2 * n[k] * n[l];
            m[3 * k + l] += w * ((kn - ks) * n[k] * n[l] + (k == l ? ks : 0.0));
            if constexpr (Viscous) m[9 + 3 * k + l] += w * ((cn - cs) * n[k] * n[l] + (k == l ? cs : 0.0));
          }
      });
}

template <class Model, bool Viscous>
void add_shear(const Particles& P, const PairList& pl, const PeriodicCell& cell, const ContactLawParams& scene_law,
               const Materials* materials, double* m) {
  constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};  // 12, 13, 23
  for_each_contact_response<Model, Viscous>(
      P, pl, cell, scene_law, materials, [&](real_t d2, const Vec3& n, real_t kn, real_t ks, real_t cn, real_t cs) {
        for (int k = 0; k < 3; ++k) {
          const real_t a2 = n[kPairs[k][0]] * n[kPairs[k][0]], b2 = n[kPairs[k][1]] * n[kPairs[k][1]];
          m[k] += d2 * ((kn - ks) * a2 * b2 + 0.25 * ks * (a2 + b2));
          if constexpr (Viscous) m[3 + k] += d2 * ((cn - cs) * a2 * b2 + 0.25 * cs * (a2 + b2));
        }
      });
}

// Whether any law of the scene has dashpots.
bool any_viscous(const ContactLawParams& law, const Materials* materials) {
  return law.viscous() || (materials && materials->any([](const ContactLawParams& l) { return l.viscous(); }));
}
}  // namespace

void add_specimen_response(const Particles& p, const PairList& pairs, const PeriodicCell& cell,
                           const ContactLawParams& law, double m[18], const Materials* materials) {
  with_model(law.model, [&](auto model) {
    using Model = decltype(model);
    if (any_viscous(law, materials)) add_response<Model, true>(p, pairs, cell, law, materials, m);
    else add_response<Model, false>(p, pairs, cell, law, materials, m);
  });
}

void add_shear_response(const Particles& p, const PairList& pairs, const PeriodicCell& cell,
                        const ContactLawParams& law, double m[6], const Materials* materials) {
  with_model(law.model, [&](auto model) {
    using Model = decltype(model);
    if (any_viscous(law, materials)) add_shear<Model, true>(p, pairs, cell, law, materials, m);
    else add_shear<Model, false>(p, pairs, cell, law, materials, m);
  });
}

}  // namespace fabrica
