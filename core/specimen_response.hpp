// The local sums of a specimen's response to a homogeneous strain rate, over this rank's
// touching particle-particle contacts (for the stress servo, apps/servo.hpp): with d the branch
// vector, n = d / |d| and k_n, k_s (c_n, c_s) the contact's tangent stiffnesses (dashpots) at
// its overlap, the model's own (core/contact/models.hpp) with the law of the pair's materials,
//   m[3k + l]     += |d|^2 n_k n_l ((k_n - k_s) n_k n_l + delta_kl k_s)
//   m[9 + 3k + l] += |d|^2 n_k n_l ((c_n - c_s) n_k n_l + delta_kl c_s)   (only with dashpots)
// Summed over the ranks and divided by the cell volume, they are the stiffness M [Pa] and the
// viscosity C [Pa s] of the specimen along each axis pair.
#pragma once
#include "core/cell.hpp"
#include "core/contact/materials.hpp"
#include "core/contact_list.hpp"
#include "core/particles.hpp"

namespace fabrica {

void add_specimen_response(const Particles& p, const PairList& pairs, const PeriodicCell& cell,
                           const ContactLawParams& law, double m[18], const Materials* materials = nullptr);

// The same for the shear components c = 12, 13, 23 (the pairs (i, j) of kShearPairs): the
// response of the symmetric shear stress s_ij to a rotation-free engineering shear gamma_ij
// (D_ij = D_ji = gamma_dot / 2), the shear servo's stiffness (apps/servo.hpp):
//   m[c]     += |d|^2 ((k_n - k_s) n_i^2 n_j^2 + k_s (n_i^2 + n_j^2) / 4)
//   m[3 + c] += |d|^2 ((c_n - c_s) n_i^2 n_j^2 + c_s (n_i^2 + n_j^2) / 4)   (only with dashpots)
// (an elastic FCC lattice of cube edge a: m / V = (k_n + k_s) / a, its shear modulus).
void add_shear_response(const Particles& p, const PairList& pairs, const PeriodicCell& cell,
                        const ContactLawParams& law, double m[6], const Materials* materials = nullptr);

}  // namespace fabrica
