// The contacts of one instant as plain records: what the fabric analysis (core/fabric.hpp) and
// the HDF5 snapshots (io/) read. Each rank lists the touching particle-particle contacts whose
// body 1 (the lower global id) it owns, so that over all ranks every contact appears exactly
// once; within a rank the records are in (id1, id2) order, like the pair list.
//
// The forces are those of the contact springs at the current positions: f_n = k_n u_n (the
// elastic normal force) and f_t = the shear spring; with viscous dashpots their velocity terms
// are not included. Wall contacts are listed apart (wall_contact_records).
#pragma once
#include "core/cell.hpp"
#include "core/contact_law.hpp"
#include "core/contact_list.hpp"
#include "core/particles.hpp"

#include <functional>
#include <vector>

namespace fabrica {

struct ContactRecord {
  GlobalId id1 = -1, id2 = -1;  // id1 < id2
  Vec3 normal = Vec3::Zero();   // unit normal from body 1 to body 2
  Vec3 branch = Vec3::Zero();   // x2 (periodic image) - x1 [m]
  real_t overlap = 0;           // u_n [m]
  real_t fn = 0;                // normal force on body 2 along +normal (>= 0) [N]
  Vec3 ft = Vec3::Zero();       // tangential force on body 2 [N]
  Vec3 mr = Vec3::Zero();       // spring moment on body 2 [N m]: rolling (zero when mu_r = 0)
                                // plus twisting along the normal (mu_t > 0)
  bool sliding = false;         // |f_t| at the Coulomb limit mu_s f_n (at_limit, contact_law.hpp;
                                // always true if mu_s = 0)
  bool rolling = false;         // |m_r| at the rolling limit mu_r Rbar f_n (always true if mu_r = 0)

  // The total contact force on body 2 (compression pushes it away from body 1, along +normal);
  // the Love-Weber stress is (1/V) sum force() (x) branch.
  Vec3 force() const { return fn * normal + ft; }
};

// This rank's records (see above). 'law' (and, in a scene of several materials, 'materials')
// must be the law of the step that produced the springs.
std::vector<ContactRecord> contact_records(const Particles& p, const PeriodicCell& cell, const ContactLawParams& law,
                                           const PairList& pairs, const Materials* materials = nullptr);
// The same records, one at a time and in the same order, without holding them all (snapshots
// of large specimens).
void for_each_contact_record(const Particles& p, const PeriodicCell& cell, const ContactLawParams& law,
                             const PairList& pairs, const std::function<void(const ContactRecord&)>& fn,
                             const Materials* materials = nullptr);

// This rank's touching sphere-wall contacts (the rank owning the sphere), in list order: id1 the
// sphere, id2 = -1 - wall index (the convention of the contact history), normal from the
// sphere's centre towards the wall, branch = (R - u_n/2) normal the arm from the centre to the
// contact point; fn, ft and mr with the wall's law (its own, or 'law'), on the wall (body 2).
std::vector<ContactRecord> wall_contact_records(const Particles& p, const ContactLawParams& law,
                                                const std::vector<Wall>& walls, const WallContactList& contacts,
                                                const Materials* materials = nullptr);

}  // namespace fabrica
