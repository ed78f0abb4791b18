// The localisation index of a strain-increment field (docs/fields.md "Shear bands"): how much of
// the shear of an increment the most sheared tenth of the grid carries, 0.1 for a homogeneous
// increment, towards 1 as the shear gathers in a band. The same definition as
// apps/localisation.py's `localisation_index(shear_intensity(e))`, to rounding.
#pragma once
#include <cstddef>
#include <span>
#include <vector>

namespace fabrica {

// gamma = sqrt(2 e':e') of one node's strain increment e (9 values, row-major), e' the deviator
// of its symmetric part (e + e^T)/2: the local equivalent shear strain of the increment (NaN if
// e holds a NaN).
double shear_intensity(const double* e);

// The share of sum gamma carried by the ceil(n / 10) nodes where gamma is largest, n the number
// of nodes whose gamma is finite (a NaN node, out of every particle's reach, is left out); the
// count is the integer (n + 9) / 10 (ties do not matter: the top values are the same). Both sums
// are exact (core/exact_sum.hpp) before one division, so the index is the same bits whatever
// the order of the nodes. NaN when no node is finite or sum gamma is not positive.
// 'strain_increment': 9 values a node (the field `strain_increment`, core/coarse_grain.hpp).
double localisation_index(std::span<const double> strain_increment);

// The two halves of localisation_index(), for a field shared over ranks by slabs: the finite gamma
// of some nodes (any subset, in any order), and the index of every node's finite gamma gathered
// (the same bits as localisation_index() of the whole field, whatever the order: exact sums).
std::vector<double> finite_shear_intensities(std::span<const double> strain_increment);
double localisation_index_of(std::vector<double> gamma);

}  // namespace fabrica
