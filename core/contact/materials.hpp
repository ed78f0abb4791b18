// Materials: each sphere (and a wall that names one) is of a material, and the contact of two
// materials a, b has the law mix(a, b) (docs/scene.md, "Materials"). The scene's model and
// rolling model are shared by every material; the numbers mix as follows (a number equal in
// both materials is taken as it is, so that a pair of one material has exactly its law):
//   linear:  E (deformability mode) and k_n (direct mode): the harmonic mean 2 x y / (x + y),
//            two halves of the contact as springs in series (PFC's and Yade's rule for equal
//            radii); k_s likewise from each material's k_n / kappa, so kappa = k_n / k_s;
//   Hertz-Mindlin: 1/E* = (1 - nu_a^2)/E_a + (1 - nu_b^2)/E_b,
//            1/G* = 2 (2 - nu_a)(1 + nu_a)/E_a + 2 (2 - nu_b)(1 + nu_b)/E_b (Johnson 1985;
//            LAMMPS hertz/material, LIGGGHTS);
//   friction, rolling and twisting friction: the smaller of the two (PFC, Yade);
//   dashpots (damping ratios and rates): the mean of the two;
// and a [[material_pair]] table may give a pair's friction coefficients and restitution
// instead (LIGGGHTS' peratomtypepair). A [[stage]] that sets a number sets it for every pair.
#pragma once
#include "core/contact/params.hpp"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace fabrica {

// The most materials a scene may have (a particle's material is one byte).
inline constexpr std::size_t kMaxMaterials = 255;

namespace mixing {
inline real_t harmonic(real_t x, real_t y) { return x == y ? x : 2.0 * x * y / (x + y); }
inline real_t mean(real_t x, real_t y) { return x == y ? x : 0.5 * (x + y); }
}  // namespace mixing

// The law of a contact between materials a and b (the scene's model and rolling model, which
// both share).
inline ContactLawParams mix(const ContactLawParams& a, const ContactLawParams& b) {
  using mixing::harmonic, mixing::mean;
  ContactLawParams m = a;
  if (a.model == ContactModel::HertzMindlin) {
    if (a.youngs_modulus != b.youngs_modulus || a.poisson_ratio != b.poisson_ratio) {
      const real_t na = a.poisson_ratio, nb = b.poisson_ratio;
      m.pair_estar = 1.0 / ((1.0 - na * na) / a.youngs_modulus + (1.0 - nb * nb) / b.youngs_modulus);
      m.pair_gstar =
          1.0 / (2.0 * (2.0 - na) * (1.0 + na) / a.youngs_modulus + 2.0 * (2.0 - nb) * (1.0 + nb) / b.youngs_modulus);
    }
  } else if (a.stiffness_mode == NormalStiffnessMode::Direct) {
    m.normal_stiffness = harmonic(a.normal_stiffness, b.normal_stiffness);
    if (a.normal_stiffness != b.normal_stiffness || a.stiffness_ratio != b.stiffness_ratio)
      m.stiffness_ratio =
          m.normal_stiffness / harmonic(a.normal_stiffness / a.stiffness_ratio, b.normal_stiffness / b.stiffness_ratio);
  } else {
    m.youngs_modulus = harmonic(a.youngs_modulus, b.youngs_modulus);
    if (a.youngs_modulus != b.youngs_modulus || a.stiffness_ratio != b.stiffness_ratio)
      m.stiffness_ratio =
          m.youngs_modulus / harmonic(a.youngs_modulus / a.stiffness_ratio, b.youngs_modulus / b.stiffness_ratio);
  }
  m.friction = std::min(a.friction, b.friction);
  m.rolling_friction = std::min(a.rolling_friction, b.rolling_friction);
  m.twisting_friction = std::min(a.twisting_friction, b.twisting_friction);
  m.damping_ratio_n = mean(a.damping_ratio_n, b.damping_ratio_n);
  m.damping_ratio_s = mean(a.damping_ratio_s, b.damping_ratio_s);
  m.damping_rate_n = mean(a.damping_rate_n, b.damping_rate_n);
  m.damping_rate_s = mean(a.damping_rate_s, b.damping_rate_s);
  return m;
}

// The materials of a scene with more than one (empty: one material, the scene's law). Material
// k is Particles::material == k; a wall names one by its index (Wall::material).
struct Materials {
  std::vector<std::string> names;
  std::vector<ContactLawParams> laws;   // each material's own law
  std::vector<ContactLawParams> pairs;  // the law of a contact of a and b at a * size() + b

  std::size_t size() const { return laws.size(); }
  bool empty() const { return laws.empty(); }
  const ContactLawParams& pair(std::size_t a, std::size_t b) const { return pairs[a * laws.size() + b]; }

  // The pairs' laws by the mixing rule, then the numbers 'given' for some pairs (each entry:
  // a, b and the numbers of their [[material_pair]]).
  struct Given {
    std::size_t a, b;
    LawChanges numbers;
  };
  void mix_pairs(const std::vector<Given>& given = {}) {
    const std::size_t n = laws.size();
    pairs.assign(n * n, ContactLawParams{});
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = 0; b < n; ++b) pairs[a * n + b] = a == b ? laws[a] : mix(laws[a], laws[b]);
    for (const Given& g : given) {
      pairs[g.a * n + g.b] = g.numbers.applied_to(pairs[g.a * n + g.b]);
      pairs[g.b * n + g.a] = g.numbers.applied_to(pairs[g.b * n + g.a]);
    }
  }
  // Numbers set for every material and pair (a [[stage]]'s, the triaxial test's switches).
  void apply(const LawChanges& c) {
    for (auto& l : laws) l = c.applied_to(l);
    for (auto& l : pairs) l = c.applied_to(l);
  }
  // Whether some pair needs the kernel's switch (ContactLawParams::rolling, twisting, viscous).
  template <class Pred>
  bool any(Pred pred) const {
    return std::any_of(pairs.begin(), pairs.end(), pred);
  }
};

}  // namespace fabrica
