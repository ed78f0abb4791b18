// Specimen generation: the fractal gradation of the reference study and simple packings.
//
// Gradation by mass M(<d)/M_T = (d/d_max)^(3-D) on [d_min, d_max], truncated below d_min: the
// mass below d_min is not generated and the remaining distribution is renormalised to
// [d_min, d_max]. The number density that realises it is n(d) ~ d^-(D+1); each diameter is
// drawn by inverting N(>d) ~ d^-D - d_max^-D.
#pragma once
#include "core/cell.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

// Deterministic uniform numbers in [0,1) (SplitMix64), identical on every platform.
class Random {
 public:
  explicit Random(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  real_t uniform() { return real_t(next() >> 11) * 0x1.0p-53; }
  std::uint64_t state() const { return s_; }

 private:
  std::uint64_t s_;
};

std::vector<real_t> fractal_diameters(std::size_t n, real_t D, real_t d_min, real_t d_max, Random& rng);

// Places spheres of the given diameters (largest first) at random without overlap in the
// periodic cell; throws std::runtime_error if a sphere finds no room after many attempts.
// Ids are 0..n-1 in the order of 'diameters'.
Particles random_packing(const std::vector<real_t>& diameters, real_t density, const PeriodicCell& cell, Random& rng);

// n^3 equal spheres of radius R on a simple cubic lattice of spacing a (cell n a per side).
Particles simple_cubic(int n, real_t R, real_t a, real_t density);

}  // namespace fabrica
