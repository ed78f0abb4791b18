// The Verlet list: every pair of spheres closer than R_i + R_j + skin, plus every sphere-wall
// pair closer than R_i + skin, each with its contact history. Rebuilt only when particles have
// moved far enough (see neighbor.hpp); between rebuilds only the springs change.
#pragma once
#include "core/cell.hpp"
#include "core/contact_law.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

// Periodic image offsets s in {-1,0,1}^3 are stored as one byte: code = (s0+1) + 3 (s1+1) + 9 (s2+1).
inline int image_code(int s0, int s1, int s2) { return (s0 + 1) + 3 * (s1 + 1) + 9 * (s2 + 1); }
inline Vec3 image_offset(int code, const Vec3& L) {
  return Vec3((code % 3 - 1) * L[0], (code / 3 % 3 - 1) * L[1], (code / 9 - 1) * L[2]);
}
// The shift of image 'code' in a cell of any shape (orthorhombic: the same bits as above).
inline Vec3 image_offset(int code, const PeriodicCell& cell) {
  return cell.image_shift(code % 3 - 1, code / 3 % 3 - 1, code / 9 - 1);
}
inline constexpr int kNoImage = 13;  // image_code(0, 0, 0)

struct PairList {
  // Pair p joins body i[p] (lower global id) to body j[p] shifted by image[p]:
  // branch vector d = x[j] + image_offset(image[p], L) - x[i].
  std::vector<Index> i, j;
  std::vector<std::uint8_t> image;
  std::vector<std::uint8_t> touching;  // 1 while the spheres overlap (the pair has springs)

  // The springs of the touching pairs only (memory at large N: a list pair is 14 bytes, and
  // only the ~45 % of pairs that touch carry the 48 bytes of springs). Touching pair q keeps
  // its springs at slot[q] of the pools (slot[q] means nothing while q does not touch); a
  // contact that closes takes a free slot (zeroed), one that opens gives its slot back. At a
  // rebuild the slots are handed out afresh in list order, so the force loop reads the pools
  // nearly in order. Which slot a contact has changes no result.
  std::vector<Index> slot;
  std::vector<Vec3> spring_fs;    // shear springs (N), by slot
  std::vector<Vec3> spring_mr;    // rolling springs (N m), by slot; used only with rolling
  std::vector<real_t> spring_mt;  // twisting springs (N m), by slot; used only with twisting
  std::vector<Index> free_slots;
  bool rolling = false;   // whether spring_mr is kept (mu_r > 0)
  bool twisting = false;  // whether spring_mt is kept (mu_t > 0)

  // The springs of pair q (zero while it does not touch).
  Vec3 shear_spring(std::size_t q) const { return touching[q] ? spring_fs[slot[q]] : Vec3(Vec3::Zero()); }
  Vec3 rolling_spring(std::size_t q) const { return touching[q] && rolling ? spring_mr[slot[q]] : Vec3(Vec3::Zero()); }
  real_t twisting_spring(std::size_t q) const { return touching[q] && twisting ? spring_mt[slot[q]] : 0.0; }
  // Gives pair q (not touching) a slot with zero springs; the caller sets touching[q].
  void take_slot(std::size_t q) {
    Index s;
    if (!free_slots.empty()) {
      s = free_slots.back();
      free_slots.pop_back();
      spring_fs[s].setZero();
      if (rolling) spring_mr[s].setZero();
      if (twisting) spring_mt[s] = 0;
    } else {
      s = Index(spring_fs.size());
      if (spring_fs.size() == spring_fs.capacity()) {  // an eighth more, not double (memory)
        const std::size_t room = spring_fs.size() + spring_fs.size() / 8 + 64;
        spring_fs.reserve(room);
        if (rolling) spring_mr.reserve(room);
        if (twisting) spring_mt.reserve(room);
      }
      spring_fs.push_back(Vec3::Zero());
      if (rolling) spring_mr.push_back(Vec3::Zero());
      if (twisting) spring_mt.push_back(0);
    }
    slot[q] = s;
  }
  // Pair q stops touching: its slot becomes free (the caller clears touching[q]).
  void give_slot(std::size_t q) { free_slots.push_back(slot[q]); }
  // Rolling springs kept or not from now on (a stage may switch mu_r on or off): switched on,
  // every rolling spring starts at zero.
  void set_rolling(bool on) {
    rolling = on;
    if (on) spring_mr.assign(spring_fs.size(), Vec3::Zero());
    else std::vector<Vec3>().swap(spring_mr);
  }
  // Twisting springs likewise (a stage may switch mu_t on or off).
  void set_twisting(bool on) {
    twisting = on;
    if (on) spring_mt.assign(spring_fs.size(), 0.0);
    else std::vector<real_t>().swap(spring_mt);
  }
  // After a rebuild: no pair touches yet, room for 'expected' touching pairs.
  void reset_springs(std::size_t expected) {
    touching.assign(size(), 0);
    slot.assign(size(), 0);
    spring_fs.clear();
    spring_mr.clear();
    spring_mt.clear();
    free_slots.clear();
    spring_fs.reserve(expected);
    if (rolling) spring_mr.reserve(expected);
    if (twisting) spring_mt.reserve(expected);
  }

  // Work arrays of the force loop (core/forces.cpp), refilled by every call and meaningless
  // between calls: the touching pairs of the step in list order (spring slot, bodies, branch
  // vector and its squared length), and the contacts that opened, each with the number of
  // touching pairs before it and the spring energy it lost [J].
  struct Work {
    std::vector<Index> s;
    std::vector<Index> i, j;
    std::vector<real_t> dx, dy, dz, r2;
    struct Opening {
      std::size_t before;
      real_t e_friction, e_rolling;  // e_rolling: the rolling and twisting springs'
    };
    std::vector<Opening> openings;
    void resize(std::size_t n) {
      if (s.size() >= n) return;
      s.resize(n);
      for (auto* v : {&i, &j}) v->resize(n);
      for (auto* v : {&dx, &dy, &dz, &r2}) v->resize(n);
    }
  } work;

  std::size_t size() const { return i.size(); }
  void clear() {
    i.clear();
    j.clear();
    image.clear();
    touching.clear();
    slot.clear();
    spring_fs.clear();
    spring_mr.clear();
    spring_mt.clear();
    free_slots.clear();
  }
};

// A plane, moving at a constant velocity (zero: fixed) or servo-controlled along its normal
// (core/wall_servo.hpp). Its contacts use the scene's contact law, or its own when own_law is
// set (Rbar = R of the sphere, k_n = pi R E for the deformability form, m_eff = m of the sphere).
struct Wall {
  Vec3 point = Vec3::Zero();     // a point of the plane (m), advanced by velocity * dt each step
  Vec3 normal = Vec3::UnitZ();   // unit normal pointing into the granular domain
  Vec3 velocity = Vec3::Zero();  // m/s (a servo wall: its normal part is the servo's)
  bool own_law = false;
  ContactLawParams law;  // used when own_law
  // Its material (core/contact/materials.hpp; -1: none): a sphere of material m meets it with
  // the law Materials::pair(m, material), in a scene of several materials.
  std::int32_t material = -1;
  // Servo control, when servo_pressure > 0: after every step the normal part of the velocity is
  // set so that the spheres' push on the wall approaches servo_pressure times the cell's
  // cross-section across the wall's axis (core/wall_servo.hpp).
  real_t servo_pressure = 0;      // Pa
  real_t servo_relaxation = 0.5;  // fraction of the force error one step corrects, (0, 1)
  real_t servo_max_speed = 0;     // m/s, the cap on the servo's speed (> 0 with a servo)

  bool servo() const { return servo_pressure > 0; }
  bool moving() const { return servo() || !velocity.isZero(); }
};

struct WallContactList {
  std::vector<Index> i;            // particle
  std::vector<std::int32_t> wall;  // wall index
  std::vector<std::uint8_t> touching;
  std::vector<Vec3> fs, mr;  // mr with rolling only
  std::vector<real_t> mt;    // with twisting only

  std::size_t size() const { return i.size(); }
  void clear() {
    i.clear();
    wall.clear();
    touching.clear();
    fs.clear();
    mr.clear();
    mt.clear();
  }
};

}  // namespace fabrica
