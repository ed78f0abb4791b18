// One DEM run on this rank: particles, periodic cell, contact lists and the time step.
// The whole step is Simulation::step(); read it first. Simulation composes the parts of one job
// each: the contacts and the carry of their springs (core/contact_store.hpp), the energy account
// (core/energy_account.hpp), the guards (core/guards.hpp), the servo walls' loads
// (core/wall_servo.hpp), the driven particles (core/driven.hpp) and the phase timers
// (core/phase_timer.hpp).
#pragma once
#include "core/cell.hpp"
#include "core/contact_list.hpp"
#include "core/contact_store.hpp"
#include "core/domain.hpp"
#include "core/driven.hpp"
#include "core/energy_account.hpp"
#include "core/forces.hpp"
#include "core/guards.hpp"
#include "core/history_map.hpp"
#include "core/integrator.hpp"
#include "core/measures.hpp"
#include "core/neighbor.hpp"
#include "core/particles.hpp"
#include "core/phase_timer.hpp"
#include "core/serial_domain.hpp"
#include "core/wall_servo.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace fabrica {

struct SimulationParams {
  ContactLawParams law;
  // A scene of several materials: each pair's law (core/contact/materials.hpp); empty: 'law'
  // for every contact.
  Materials materials;
  real_t dt = 0;                  // s (see critical_time_step)
  real_t skin = 0;                // m, Verlet skin
  Vec3 gravity = Vec3::Zero();    // m/s^2
  real_t local_damping = 0;       // alpha [-], 0 <= alpha < 1
  std::vector<Wall> walls;        // planes (core/contact_list.hpp)
  std::vector<DrivenSet> driven;  // particles of prescribed motion (core/driven.hpp)
  bool spatial_sort = true;       // reorder particles in space at rebuilds (cache locality)
  int kernel_lanes = 4;           // contacts the force loop evaluates at once (4 or 1: the
                                  // same bits, core/forces.cpp)
  int fetch_ahead = -1;           // what the force loop fetches ahead: -1 by the particle
                                  // count, 0 the first lines, 1 everything (the same bits)

  // The kernel's switches: the scene's law or a wall's own law needs them.
  bool rolling() const {
    bool r = law.rolling() || materials.any([](const ContactLawParams& l) { return l.rolling(); });
    for (const Wall& w : walls) r = r || (w.own_law && w.law.rolling());
    return r;
  }
  bool twisting() const {
    bool t = law.twisting() || materials.any([](const ContactLawParams& l) { return l.twisting(); });
    for (const Wall& w : walls) t = t || (w.own_law && w.law.twisting());
    return t;
  }
  bool viscous() const {
    bool v = law.viscous() || materials.any([](const ContactLawParams& l) { return l.viscous(); });
    for (const Wall& w : walls) v = v || (w.own_law && w.law.viscous());
    return v;
  }
  bool moving_walls() const {
    for (const Wall& w : walls)
      if (w.moving()) return true;
    return false;
  }
};

// The state a checkpoint holds (io/mpi/checkpoint.hpp): enough to rebuild a Simulation that
// continues bit for bit, provided it was taken right after a neighbour-list rebuild
// (Simulation::rebuilt_last_step()): the lists are then a function of the positions and of the
// springs of the touching contacts.
struct SimulationSnapshot {
  Particles particles;      // every particle (or a part, below), forces and torques included
  HistoryMap history;       // springs of every touching contact (or a part), keyed by the ids
  PeriodicCell cell;        // lengths and strain rates
  SimulationParams params;  // contact law, time step, skin, damping, walls
  MacroState macro;         // the last measured state
  Dissipation dissipation;  // this rank's accumulators
  std::int64_t step = 0, rebuilds = 0;
  real_t time = 0;
  DecompositionRecord decomposition;  // see Domain::decomposition_record()
  EnergyAccount energy;               // the global part, and this rank's gravity work
  Holding holding = Holding::Whole;   // particles and history: all of them, or this rank's part
};

class Simulation {
 public:
  // Builds the contact lists and the initial forces. Throws std::invalid_argument if the cell
  // is too small for the largest sphere and the skin. With a domain (MPI), every rank passes
  // the same complete set of particles (Holding::Whole) or a part of them (Holding::Share, see
  // Domain::adopt) and keeps its own; the domain must outlive the simulation. Without one, the
  // run is serial (serial_domain()).
  Simulation(Particles particles, PeriodicCell cell, SimulationParams params, Domain* domain = nullptr,
             Holding holding = Holding::Whole);

  // A copy of 'other' that communicates through 'domain' (a clone of other's domain, or null
  // for a serial run): to branch several runs from one prepared state. The only copy: a plain
  // copy would share other's domain (its decomposition and ghost plan), so it is not public.
  Simulation(const Simulation& other, Domain* domain);
  // The same without the copy: 'other' is taken over (left empty), e.g. by the last branch.
  Simulation(Simulation&& other, Domain* domain);
  Simulation& operator=(const Simulation&) = delete;
  // A move keeps the domain (the serial one is shared and stateless).
  Simulation(Simulation&&) = default;
  Simulation& operator=(Simulation&&) = default;

  // A run restored from a snapshot (every rank passes the same particles and history, or with
  // snapshot.holding = Share a part of each, as io/mpi/checkpoint reads them; the dissipation is
  // this rank's). Forces are not recomputed: the next step() is the one the
  // saved run would have taken.
  Simulation(SimulationSnapshot snapshot, Domain* domain);

  // Advances one time step. With measure = true (the same on every rank) the contact sums of
  // this step are reduced over all ranks and macro() returns the state at the end of the step.
  // A step that does not measure leaves its closing half kick to the start of the next one,
  // whose loop over the particles applies it just before its own (the same arithmetic, one pass
  // less over memory); particles() and anything that reads or changes the particles' state
  // between steps apply it first (settle()). Not with driven particles.
  void step(bool measure = false);

  const MacroState& macro() const { return macro_; }  // after a measuring step or construction

  // The particles at the end of the last step (this applies a closing half kick the last step
  // left to the next one, see step()).
  Particles& particles() {
    settle();
    positions_exposed_ = true;  // the next ghost update sends positions (step())
    return p_;
  }
  const Particles& particles() const {
    settle();
    return p_;
  }
  PeriodicCell& cell() { return cell_; }
  const PeriodicCell& cell() const { return cell_; }
  const SimulationParams& params() const { return par_; }
  void set_law(const ContactLawParams& law);  // e.g. switching mu_s / mu_r between stages
  // Some numbers of the law set anew (a [[stage]]'s): in the scene's law, every material's and
  // every pair's.
  void change_law(const LawChanges& changes);
  // The law and the materials' laws (a [compress] stage put back).
  void set_laws(const ContactLawParams& law, const Materials& materials);
  void set_local_damping(real_t alpha) { par_.local_damping = alpha; }
  // A new time step (s) from the next step on (e.g. a branch run at another step size).
  void set_time_step(real_t dt) {
    settle();
    par_.dt = dt;
  }
  // A new Verlet skin (m); rebuilds the lists. Throws std::invalid_argument if the cell is too
  // small, or on several ranks if the cutoff grows beyond the one the domain was built for.
  void set_skin(real_t skin);

  // Energy put into the system since construction [J]: the kinetic and elastic energy at
  // construction, plus the boundary work of the deforming cell, plus the work of gravity.
  // The boundary work is integrated over every step in which the cell strains, with the stress
  // at both ends of the step (trapezoid in the strain):
  //   W += -sum_k (V sigma_kk(start) + V sigma_kk(end)) / 2 * edot_k dt
  // where edot_k dt is the step's exact logarithmic strain increment (PeriodicCell::deform).
  // For an affine elastic lattice it equals the change of the stored elastic energy to
  // O((edot dt)^2) per step, at any measuring interval (tests/unit/test_energy_account.cpp). A
  // straining step therefore sums the contact virial (when it does not measure, the pair loop's
  // variant that sums nothing else) and reduces its diagonal over the ranks (3 numbers), whether
  // it measures or not; a step with
  // the cell at rest costs nothing more. When the stress at the start of a straining step is
  // unknown (the step before neither strained nor measured), the end stress stands for it.
  // macro().energy_input is e0 + W + gravity work at measuring steps.
  // Driven particles (core/driven.hpp): the drive's work, that of the force holding them to
  // their prescribed motion against the contacts and gravity (one reduction of one number per
  // step, only with driven particles), is part of macro().energy_input as macro().drive_work.
  // Moving walls: their work on the spheres, sum over steps of -F . v_wall dt (F the force on
  // the wall at the end of the step), reduced over the ranks at every step (one number), is
  // part of macro().energy_input as macro().wall_work.
  real_t boundary_work() const { return energy_.boundary_work(); }
  EnergyAccount energy_account() const { return energy_.record(); }
  Domain& domain() { return *domain_; }
  const Domain& domain() const { return *domain_; }
  const PairList& pairs() const { return contacts_.pairs(); }
  const WallContactList& wall_contacts() const { return contacts_.walls(); }
  const Dissipation& dissipation() const { return diss_; }

  std::int64_t step_count() const { return step_; }
  real_t time() const { return time_; }
  std::int64_t rebuild_count() const { return rebuilds_; }
  real_t cutoff() const { return cutoff_max_; }  // 2 Rmax + skin, Rmax over every rank
  // True if the last step() (or the construction) rebuilt the lists: the moments at which a
  // checkpoint can be taken (and restored bit for bit).
  bool rebuilt_last_step() const { return lists_step_ == step_; }

  // The guard of every step (in the displacement check every step makes anyway, in its one
  // reduction): empty, or - when the force loop of the previous step found an overlap beyond
  // kMaxOverlapRatio of the smaller radius (core/forces.hpp) - "numerical blow-up at step N:
  // overlap of particles A and B is ..." with the step of that force computation (0: the
  // initial forces), the ratio, the overlap and the radius; or - when a particle's position or
  // velocity is not finite, or a particle moves more than half the smallest radius in one step
  // (an overlap could then jump past any bound between two steps) - "numerical blow-up at step
  // N: particle ID ..." with its speed and velocity; or - when a rebuild finds a cell length
  // no longer above 2 (2 Rmax + skin), a shrinking cell - "the run cannot go on at step N: the
  // periodic cell has shrunk to ...". The same on every rank; the executables
  // stop the run with it (and save the state, OUT/blowup.ckpt).
  const std::string& step_guard() const { return guards_.message(); }

  // Calls fn(id_a, id_b, history) once per touching contact over all ranks: here, those whose
  // lower-id body is owned by this rank (walls: b = -1 - wall index).
  template <class F>
  void for_each_contact(F&& fn) const {
    contacts_.for_each(p_, fn);
  }
  // Contacts [first, first + n) of for_each_contact's order. 'at' carries the place in the
  // lists from one call to the next (start with {}): ranges taken in order, as a checkpoint
  // writes its blocks, cost one pass over the lists in all, not one pass per range.
  using ContactCursor = ContactStore::Cursor;
  template <class F>
  void for_each_contact_in(std::uint64_t first, std::uint64_t n, ContactCursor& at, F&& fn) const {
    contacts_.for_each_in(p_, first, n, at, fn);
  }

  // New lists: the springs carried by global ids, the particles migrated and sorted in space,
  // the ghosts, the neighbour search, the springs attached. 'forces_spent': the force and
  // torque accumulators hold nothing the run needs (step(): the first pass has zeroed them, or
  // the force computation that follows resets them all); they are then freed during the
  // search (48 bytes per particle off the rebuild's peak) and come back zero.
  void rebuild(bool forces_spent = false);

  // Optional phase timers for step(): off by default (then each phase costs one predictable
  // branch). Enabling resets the sums.
  void enable_phase_timers(bool on) { timer_.enable(on); }
  const PhaseTimes& phase_times() const { return timer_.times(); }

 private:
  Simulation(const Simulation&) = default;  // member-wise, for the branching constructor only

  // True once particles (on any rank) have moved, or the cell has strained, enough that a pair
  // outside the list could be touching; the guards of the motion on the way. Collective.
  // 'motion': this rank's largest displacement^2 since the last rebuild and speed^2
  // (kick_drift_check, or local_motion()).
  bool needs_rebuild(const StepStart& motion);
  StepStart local_motion() const;  // the maxima of StepStart by a loop of their own

  // Forces at the current positions; the contact springs advance by the relative motion over
  // dt (0 for the initial forces, which must not change the contact history).
  // 'virial_only': with 'measure', only the contact virial is summed; 'owned_ready': the owned
  // f and t hold their starting values (ForceContext).
  void compute(bool measure, real_t dt, bool virial_only = false, bool owned_ready = false);

  // Of the step just done, of length dt (orthorhombic: its strain increment edot dt).
  void measure_and_reduce(const Vec3& strain_increment, real_t dt);
  Mat3 rate_of_deformation() const;  // D = (G + G^T) / 2 of the cell
  // Steps 2-4 of rebuild(): new lists from the positions, with the springs held in the carry.
  // 'work': per owned particle, the work over the last list by which the domain may balance its
  // decomposition (none at the first list, and on one rank).
  void rebuild_lists(bool forces_spent = false, std::vector<std::int32_t>* work = nullptr);

  Domain* domain_;       // never null: the caller's domain, or serial_domain()
  mutable Particles p_;  // mutable: settle() from particles() const
  // The owned positions were handed out for change (particles() not const) since the last
  // ghost update: the next one sends them rather than letting the ghosts drift.
  bool positions_exposed_ = true;
  // The last step's closing half kick is still to apply (step() leaves it to the next step's
  // first pass); settle() applies it.
  mutable bool kick_pending_ = false;
  void settle() const;
  PeriodicCell cell_;
  SimulationParams par_;
  NeighborSearch search_;
  ContactStore contacts_;
  Dissipation diss_;
  ContactSums sums_;
  MacroState macro_;
  // The rebuild criterion's reference, made at each rebuild.
  std::vector<Vec3> s_ref_;     // reduced positions x / L
  Vec3 L_ref_;                  // cell lengths
  Mat3 H_ref_;                  // cell matrix (sheared cells)
  std::vector<Vec3> wall_ref_;  // wall points
  real_t cutoff_max_ = 0;       // 2 Rmax + skin
  std::int64_t step_ = 0, rebuilds_ = 0;
  std::int64_t lists_step_ = 0;  // the step at whose end positions the lists were built
  real_t time_ = 0;
  EnergyBook energy_;     // see boundary_work above
  ServoWallLoads servo_;  // the servo walls' push and stiffness (the last step)
  DrivenMembers driven_;  // the owned driven particles (found with the lists)
  StepGuards guards_;     // step_guard()
  PhaseTimer timer_;      // enable_phase_timers()
};

}  // namespace fabrica
