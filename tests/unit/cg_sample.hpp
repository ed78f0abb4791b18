// A random gas of spheres in a periodic cell for the coarse-grained fields' tests
// (test_coarse_grain, test_coarse_grain_sheared), with "contacts" between near pairs (branch to
// the nearest image, so many cross the faces; about 3 a sphere at the default reach) carrying
// random forces and flags, and the volume integral of a field.
#pragma once
#include "core/cell.hpp"
#include "core/coarse_grain.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace fabrica {

struct CgSample {
  Vec3 L;  // the diagonal of the cell's matrix (an orthorhombic cell's lengths)
  std::vector<CgParticle> p;
  std::vector<CgContact> c;
};

// n spheres uniform in the cell of edge vectors the columns of H; pairs closer than 'reach' (to
// the nearest image) are the contacts. With 'any_image' body 1's centre is given at a random
// image along the first edge (the fields must wrap it), else in the cell.
inline CgSample cg_sample(const Mat3& H, std::size_t n, std::uint64_t seed, double reach, bool any_image) {
  CgSample s;
  s.L = H.diagonal();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g;
  for (std::size_t i = 0; i < n; ++i) {
    CgParticle q;
    q.x = H * Vec3(u(rng), u(rng), u(rng));
    q.radius = 0.001 + 0.002 * u(rng);
    q.mass = 2650 * 4.0 / 3.0 * std::numbers::pi * std::pow(q.radius, 3);
    q.v = Vec3(g(rng), g(rng), g(rng)) * 0.01;
    q.w = Vec3(g(rng), g(rng), g(rng));
    s.p.push_back(q);
  }
  const PeriodicCell cell = PeriodicCell::from_matrix(H);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      CgContact c;
      c.rec.id1 = GlobalId(i), c.rec.id2 = GlobalId(j);
      c.rec.branch = cell.minimum_image(s.p[j].x - s.p[i].x);
      if (c.rec.branch.norm() > reach) continue;
      c.rec.normal = c.rec.branch.normalized();
      c.rec.overlap = 1e-5;
      c.rec.fn = 10 * u(rng);
      Vec3 tt(g(rng), g(rng), g(rng));
      tt -= tt.dot(c.rec.normal) * c.rec.normal;
      c.rec.ft = 0.4 * c.rec.fn * u(rng) * tt.normalized();
      c.rec.sliding = u(rng) < 0.3, c.rec.rolling = u(rng) < 0.5;
      c.x1 = s.p[i].x;
      if (any_image) c.x1 += H * Vec3(std::floor(3 * u(rng)) - 1, 0, 0);
      c.r1 = s.p[i].radius;
      s.c.push_back(c);
    }
  return s;
}

// The volume integral of component 'comp' of a field: the sum over the nodes times the node volume.
inline double volume_integral(const FieldsResult& r, const std::string& name, int comp) {
  const Field& f = r.field(name);
  double s = 0;
  for (std::size_t g = 0; g < r.grid.nodes(); ++g) s += f.values[g * std::size_t(f.components) + std::size_t(comp)];
  return s * r.grid.cell_volume();
}

}  // namespace fabrica
