// The Verlet list: every pair of spheres closer than R_i + R_j + skin, plus every sphere-wall
// pair closer than R_i + skin, each with its contact history. Rebuilt only when particles have
// moved far enough (see neighbor.hpp); between rebuilds only the springs change.
#pragma once
#include "core/contact_law.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

// Periodic image offsets s in {-1,0,1}^3 are stored as one byte: code = (s0+1) + 3 (s1+1) + 9 (s2+1).
inline int image_code(int s0, int s1, int s2) { return (s0 + 1) + 3 * (s1 + 1) + 9 * (s2 + 1); }
inline Vec3 image_offset(int code, const Vec3& L) {
  return Vec3((code % 3 - 1) * L[0], (code / 3 % 3 - 1) * L[1], (code / 9 - 1) * L[2]);
}
inline constexpr int kNoImage = 13;  // image_code(0, 0, 0)

struct PairList {
  // Pair p joins body i[p] (lower global id) to body j[p] shifted by image[p]:
  // branch vector d = x[j] + image_offset(image[p], L) - x[i].
  std::vector<Index> i, j;
  std::vector<std::uint8_t> image;
  std::vector<std::uint8_t> touching;  // 1 while the spheres overlap (history may be non-zero)
  std::vector<Vec3> fs;                // shear springs (N)
  std::vector<Vec3> mr;                // rolling springs (N m); empty when mu_r = 0

  // Work arrays of the force loop (core/forces.cpp), refilled by every call and meaningless
  // between calls: the touching pairs of the step in list order (list index, bodies, branch
  // vector and its squared length), and the contacts that opened, each with the number of
  // touching pairs before it and the spring energy it lost [J].
  struct Work {
    std::vector<Index> q, i, j;
    std::vector<real_t> dx, dy, dz, r2;
    struct Opening {
      std::size_t before;
      real_t e_friction, e_rolling;
    };
    std::vector<Opening> openings;
    void resize(std::size_t n) {
      if (q.size() >= n) return;
      for (auto* v : {&q, &i, &j}) v->resize(n);
      for (auto* v : {&dx, &dy, &dz, &r2}) v->resize(n);
    }
  } work;

  std::size_t size() const { return i.size(); }
  void clear() {
    i.clear(); j.clear(); image.clear(); touching.clear(); fs.clear(); mr.clear();
  }
};

// A plane, moving at a constant velocity (zero: fixed). Its contacts use the scene's contact
// law, or its own when own_law is set (Rbar = R of the sphere, k_n = pi R E for the
// deformability form, m_eff = m of the sphere).
struct Wall {
  Vec3 point = Vec3::Zero();        // a point of the plane (m), advanced by velocity * dt each step
  Vec3 normal = Vec3::UnitZ();      // unit normal pointing into the granular domain
  Vec3 velocity = Vec3::Zero();     // m/s
  bool own_law = false;
  ContactLawParams law;             // used when own_law

  bool moving() const { return !velocity.isZero(); }
};

struct WallContactList {
  std::vector<Index> i;              // particle
  std::vector<std::int32_t> wall;    // wall index
  std::vector<std::uint8_t> touching;
  std::vector<Vec3> fs, mr;

  std::size_t size() const { return i.size(); }
  void clear() { i.clear(); wall.clear(); touching.clear(); fs.clear(); mr.clear(); }
};

}  // namespace fabrica
