// Contact forces over the Verlet list: each pair once, forces and torques added to both bodies
// (Newton's third law). The kernel is chosen once per scene from a table of instantiations of
// (rolling resistance) x (viscous dashpots) x (measure), so a scene that needs neither runs a
// loop without a single instruction of them; walls cost nothing when there are none.
#pragma once
#include "core/cell.hpp"
#include "core/contact/materials.hpp"
#include "core/contact_list.hpp"
#include "core/exact_sum.hpp"
#include "core/particles.hpp"

#include <cstdint>
#include <vector>

namespace fabrica {

// Local sums over this rank's contacts, filled on measuring steps only.
struct ContactSums {
  Mat3 fb = Mat3::Zero();     // sum of f (x) b over particle-particle contacts [N m]
  std::int64_t contacts = 0;  // particle-particle contacts
  std::int64_t sliding = 0;
  std::int64_t rolling = 0;
  std::int64_t wall_contacts = 0;
  real_t e_normal = 0, e_shear = 0, e_rolling = 0;  // elastic energy in the springs [J]
  real_t sum_contact_force = 0;                     // sum of |f| over contacts [N]
  real_t sum_particle_force = 0;                    // sum of |resultant force| over owned particles [N]
  std::vector<std::int32_t> contacts_per_particle;  // for the mechanical coordination number
  real_t sum_overlap = 0;                           // sum of u_n over particle-particle contacts [m]
  real_t max_overlap_ratio = 0;                     // largest u_n / min(R_i, R_j) (walls: u_n / R_i)
  GlobalId max_overlap_a = -1, max_overlap_b = -1;  // its bodies (b = -1 - wall for walls)
  real_t work_gravity = 0;                          // J, cumulative work of gravity on this rank's particles (set
                                                    // by Simulation before the reduction)
  Mat3 fb_walls = Mat3::Zero();                     // sum of F (x) (a1 n) over wall contacts: F the force on the
                                                    // wall, a1 n the arm from the sphere's centre to the contact [N m]
  std::vector<Vec3> wall_force;                     // force of this rank's spheres on each wall [N]
};

// Energy dissipated since the start of the run [J] (local to this rank).
struct Dissipation {
  real_t friction = 0;  // Coulomb slip
  real_t rolling = 0;   // rolling slip
  real_t viscous = 0;   // dashpots
  real_t local = 0;     // local (non-viscous) damping
};

// The overlap guard of every step: an overlap above kMaxOverlapRatio of the smaller radius
// (walls: of the sphere's radius) is beyond the geometric limit - the smaller sphere's centre
// is then inside the other sphere (or behind the wall), the linear law no longer describes the
// contact, and its force can throw the spheres apart. The force loop notes the largest such
// overlap of the contacts whose body 1 this rank owns; finding none costs one comparison per
// contact (benchmarks/README.md, "The overlap guard").
inline constexpr real_t kMaxOverlapRatio = 1.0;
struct OverlapAlarm {
  real_t ratio = 0;         // u_n / smaller radius, 0 when no contact is beyond the limit
  real_t overlap = 0;       // u_n [m]
  real_t radius = 0;        // the smaller radius [m]
  GlobalId a = -1, b = -1;  // the two bodies (b = -1 - wall index for walls)
};

struct ForceContext {
  const ContactLawParams& law;
  const std::vector<Wall>& walls;
  Vec3 gravity;  // m/s^2
  real_t dt;
  OverlapAlarm* alarm = nullptr;  // if set, receives the largest overlap beyond the limit
  int lanes = 4;                  // contacts the pair loop evaluates at once: 4 (SIMD) or 1; the same bits
  // If set (servo walls, core/wall_servo.hpp): per wall k, slot 2k += the elastic part of the
  // spheres' push on it, k_n u_n [N], and slot 2k + 1 += k_n [N/m], over this rank's touching
  // contacts; exact sums, so that the servo moves the wall the same on any number of ranks.
  ExactSums* wall_load = nullptr;
  // The owned particles' f and t already hold m g and 0 (set by kick_drift_check, which
  // passes over them anyway): only the ghosts' are set here.
  bool owned_ready = false;
  // With 'sums': only sums->fb is wanted (and set; the other fields are left as they were),
  // the same bits as the full measurement gives it. A straining step that does not measure
  // needs the diagonal of the contact virial for its boundary work, nothing else.
  bool virial_only = false;
  // What the pair loop fetches ahead of each contact (no result depends on it): -1 decides by
  // the particle count (core/forces.cpp, fetch_all_ahead), 0 the first lines of the partner's
  // fields, 1 every line a contact reads.
  int fetch_ahead = -1;
  // A scene of several materials: the law of each pair of materials (null or empty: 'law' for
  // every contact). The pair loop then takes each lane's law from it (core/forces.cpp, LawLanes).
  const Materials* materials = nullptr;
};

// Sets f = m g and t = 0 (of the ghosts only if ctx.owned_ready), then adds every contact.
// 'sums' may be null (no measurement).
// 'wall_power', if given, receives the power of the moving walls on this rank's spheres [W]
// (sum over wall contacts of -F . v_wall, F the force on the wall).
void compute_forces(Particles& p, const PeriodicCell& cell, const ForceContext& ctx, PairList& pairs,
                    WallContactList& wall_contacts, Dissipation& diss, ContactSums* sums, real_t* wall_power = nullptr);

}  // namespace fabrica
