#include "core/localisation.hpp"

#include "core/exact_sum.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

namespace fabrica {

double shear_intensity(const double* e) {
  // As apps/localisation.py: the symmetric part, its trace, the deviator, sqrt(2 e':e').
  double s[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s[3 * i + j] = 0.5 * (e[3 * i + j] + e[3 * j + i]);
  const double third = (s[0] + s[4] + s[8]) / 3.0;
  double dd = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double d = s[3 * i + j] - (i == j ? third : 0.0);
      dd += d * d;
    }
  return std::sqrt(2.0 * dd);
}

std::vector<double> finite_shear_intensities(std::span<const double> strain_increment) {
  std::vector<double> gamma;
  gamma.reserve(strain_increment.size() / 9);
  for (std::size_t g = 0; g + 9 <= strain_increment.size(); g += 9) {
    const double v = shear_intensity(strain_increment.data() + g);
    if (std::isfinite(v)) gamma.push_back(v);
  }
  return gamma;
}

double localisation_index(std::span<const double> strain_increment) {
  return localisation_index_of(finite_shear_intensities(strain_increment));
}

double localisation_index_of(std::vector<double> gamma) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = gamma.size();
  if (n == 0) return kNaN;
  const std::size_t top = (n + 9) / 10;  // ceil(n / 10), at least 1
  // The top values first (their order among themselves does not matter: the sums are exact).
  std::nth_element(gamma.begin(), gamma.begin() + std::ptrdiff_t(top - 1), gamma.end(), std::greater<double>());
  ExactSums sums(2);
  for (std::size_t k = 0; k < n; ++k) {
    sums.add(1, gamma[k]);
    if (k < top) sums.add(0, gamma[k]);
  }
  sums.normalize();
  const double all = sums.value(1);
  if (!(all > 0)) return kNaN;
  return sums.value(0) / all;
}

}  // namespace fabrica
