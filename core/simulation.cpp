#include "core/simulation.hpp"

#include "core/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>

namespace fabrica {

Simulation::Simulation(Particles particles, PeriodicCell cell, SimulationParams params, Domain* domain, Holding holding)
    : domain_(domain ? domain : &serial_domain()), p_(std::move(particles)), cell_(cell), par_(std::move(params)) {
  const real_t rmax = domain_->max_all(p_.max_radius());  // of every rank's particles
  cutoff_max_ = 2 * rmax + par_.skin;
  check_cell_size(cell_, rmax, par_.skin);
  for (std::size_t a = 0; a < p_.n_owned(); ++a) p_.x[a] = cell_.wrap(p_.x[a]);
  domain_->adopt(p_, cell_, cutoff_max_, nullptr, holding);
  rebuild();
  if (!par_.driven.empty()) {  // their prescribed motion from the start (in the initial energy)
    driven_.impose(p_, par_.driven, 0.0);
    domain_->update_ghosts(p_);  // the ghosts' copies too (collective: every rank has the sets)
  }
  compute(true, 0.0);  // initial forces: no time passes, so the springs must not advance
  measure_and_reduce(Vec3::Zero(), 0.0);
  energy_.open(macro_.kinetic + macro_.e_normal + macro_.e_shear + macro_.e_rolling);
  macro_.energy_input = energy_.e0() + macro_.gravity_work;
}

Simulation::Simulation(const Simulation& other, Domain* domain) : Simulation(other) {
  domain_ = domain ? domain : &serial_domain();
  positions_exposed_ = true;  // the new domain's ghosts: sent in full at the first update
}

Simulation::Simulation(Simulation&& other, Domain* domain) : Simulation(std::move(other)) {
  domain_ = domain ? domain : &serial_domain();
  positions_exposed_ = true;  // the new domain's ghosts: sent in full at the first update
}

Simulation::Simulation(SimulationSnapshot s, Domain* domain)
    : domain_(domain ? domain : &serial_domain()), p_(std::move(s.particles)), cell_(s.cell), par_(std::move(s.params)),
      diss_(s.dissipation), macro_(s.macro), step_(s.step), time_(s.time), energy_(s.energy) {
  const real_t rmax = domain_->max_all(p_.max_radius());
  cutoff_max_ = 2 * rmax + par_.skin;
  check_cell_size(cell_, rmax, par_.skin);
  contacts_.restore(std::move(s.history));
  domain_->adopt(p_, cell_, cutoff_max_, s.decomposition.empty() ? nullptr : &s.decomposition, s.holding,
                 &contacts_.carry());
  rebuild_lists();  // the saved run rebuilt at the saved positions: the same lists
  rebuilds_ = s.rebuilds;
}

void Simulation::step(bool measure) {
  const real_t dt = par_.dt;
  timer_.start();
  const Vec3 rate = cell_.strain_rate();
  StepStart motion;
  double drive = 0;
  CellStep deformation;
  if (driven_.empty()) {  // one pass: [the last step's closing kick,] kick, gravity's power,
                          // drift, the check's maxima, f and t
    motion = kick_drift_check(p_, cell_, dt, s_ref_, par_.gravity, kick_pending_);
    deformation = motion.deformation;
    kick_pending_ = false;
    if (!par_.gravity.isZero()) energy_.add_gravity_work(motion.gravity_power * dt);
  } else {
    settle();
    half_kick(p_, dt);
    drive = driven_.impose(p_, par_.driven, 0.5 * dt);
    if (!par_.gravity.isZero()) {  // work of gravity over the drift, with the drift's velocity
      real_t gv = 0;
      for (std::size_t a = 0; a < p_.n_owned(); ++a) gv += p_.mass[a] * par_.gravity.dot(p_.v[a]);
      energy_.add_gravity_work(gv * dt);
    }
    deformation = drift_and_deform(p_, cell_, dt);
  }
  for (Wall& w : par_.walls) w.point += w.velocity * dt;
  timer_.lap(&PhaseTimes::integrate);
  // The ghosts' update travels while the rebuild check, which reads owned particles only, runs
  // (the messages can progress during its reduction). It carries v and w, and the ghosts'
  // positions take the step's drift on arrival, unless the owned positions were open to
  // change since the ghosts last had them (particles() not const): then they travel too.
  const GhostDrift drift{dt, deformation, cell_.deforming()};
  domain_->begin_ghost_update(p_, positions_exposed_ ? nullptr : &drift);
  positions_exposed_ = false;
  timer_.lap(&PhaseTimes::ghost);
  if (!driven_.empty()) motion = local_motion();
  const bool rebuild_now = needs_rebuild(motion);
  // The owned f and t hold m g and 0 from the first pass, unless driven particles took the
  // separate loops, or under gravity a migration brings arrivals with f = 0 (the force
  // computation then sets them all).
  const bool owned_ready = driven_.empty() && (par_.gravity.isZero() || !rebuild_now);
  timer_.lap(&PhaseTimes::check);
  domain_->end_ghost_update(p_);
  timer_.lap(&PhaseTimes::ghost);
  if (rebuild_now) {
    rebuild(true);  // f and t: zero (owned_ready) or reset by compute() below
    timer_.lap_rebuild();
  }
  const bool strains = cell_.deforming();
  const bool timed = domain_->wants_force_seconds();  // a decomposition balanced by time
  const auto f0 = timed ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
  compute(measure || strains, dt, !measure, owned_ready);  // a straining step needs the contact virial (boundary work)
  if (timed) domain_->note_force_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - f0).count());
  timer_.lap(&PhaseTimes::force);
  if (!measure && driven_.empty()) kick_pending_ = true;  // to the next step's first pass (or settle())
  else half_kick(p_, dt);
  if (!par_.driven.empty()) {  // the same on every rank (the sets, not this rank's members)
    drive += driven_.impose(p_, par_.driven, 0.5 * dt);
    domain_->sum_all(std::span<double>(&drive, 1));
    energy_.add_drive_work(drive);
  }
  timer_.lap(&PhaseTimes::integrate);
  if (measure) {
    measure_and_reduce(rate * dt, dt);
  } else if (strains && cell_.sheared()) {
    Mat3 fb = sums_.fb;  // the contact virial's stress on every component (sigma : D)
    domain_->sum_all(std::span<double>(fb.data(), 9));
    const real_t V = cell_.volume();
    energy_.close_step(V, rate_of_deformation() * dt, Mat3(fb / V));
  } else if (strains) {
    double d[3] = {sums_.fb(0, 0), sums_.fb(1, 1), sums_.fb(2, 2)};
    domain_->sum_all(std::span<double>(d, 3));
    const real_t V = cell_.volume();
    energy_.close_step(V, rate * dt, Vec3(d[0] / V, d[1] / V, d[2] / V));
  } else {
    energy_.close_step_unknown();
  }
  if (measure || strains) timer_.lap(&PhaseTimes::reduce);
  timer_.end_step();
  ++step_;
  time_ += dt;
  if (rebuild_now) lists_step_ = step_;
}

void Simulation::compute(bool measure, real_t dt, bool virial_only, bool owned_ready) {
  guards_.overlap() = OverlapAlarm{};
  const bool moving = dt > 0 && par_.moving_walls();
  // Servo walls (core/wall_servo.hpp): the push and contact stiffness of each wall, exact sums.
  const bool servo = dt > 0 && servo_wall_count(par_.walls) > 0;
  ForceContext ctx{par_.law, par_.walls, par_.gravity, dt, &guards_.overlap(), par_.kernel_lanes};
  ctx.materials = &par_.materials;
  ctx.wall_load = servo ? servo_.start(par_.walls.size()) : nullptr;
  ctx.owned_ready = owned_ready;
  ctx.virial_only = virial_only;
  ctx.fetch_ahead = par_.fetch_ahead;
  real_t power = 0;
  compute_forces(p_, cell_, ctx, contacts_.pairs(), contacts_.walls(), diss_, measure ? &sums_ : nullptr,
                 moving ? &power : nullptr);
  if (moving) {  // the walls' work over this step, with the forces at its end (every rank)
    double pw = power;
    domain_->sum_all(std::span<double>(&pw, 1));
    energy_.add_wall_work(pw * dt);
  }
  if (servo) servo_.finish(*domain_, par_.walls, cell_, dt);  // the walls' velocities for the next step
  if (par_.local_damping > 0) diss_.local += apply_local_damping(p_, par_.local_damping, dt);
}

Mat3 Simulation::rate_of_deformation() const {
  const Mat3 g = cell_.velocity_gradient();
  return 0.5 * (g + g.transpose());
}

void Simulation::measure_and_reduce(const Vec3& strain_increment, real_t dt) {
  sums_.work_gravity = energy_.gravity_work_local();
  macro_ = reduce_macro_state(p_, cell_, sums_, diss_, *domain_);
  if (cell_.sheared()) energy_.close_step(cell_.volume(), Mat3(rate_of_deformation() * dt), macro_.stress);
  else energy_.close_step(cell_.volume(), strain_increment, macro_.stress.diagonal());
  macro_.wall_work = energy_.wall_work();
  macro_.drive_work = energy_.drive_work();
  macro_.energy_input = energy_.input(macro_.gravity_work);
}

void Simulation::settle() const {
  if (!kick_pending_) return;
  half_kick(p_, par_.dt);
  kick_pending_ = false;
}

void Simulation::set_skin(real_t skin) {
  settle();
  const real_t two_rmax = cutoff_max_ - par_.skin;  // global (a rank may not hold the largest)
  const real_t cutoff = two_rmax + skin;
  if (domain_->size() > 1 && cutoff > cutoff_max_)
    throw std::invalid_argument(
        "Simulation::set_skin: on several ranks the cutoff 2 Rmax + skin "
        "cannot grow beyond the one the domain was built with");
  check_cell_size(cell_, 0.5 * two_rmax, skin);
  par_.skin = skin;
  cutoff_max_ = cutoff;
  rebuild();
}

void Simulation::change_law(const LawChanges& changes) {
  Materials m = par_.materials;
  m.apply(changes);
  set_laws(changes.applied_to(par_.law), m);
}

void Simulation::set_law(const ContactLawParams& law) { set_laws(law, par_.materials); }

void Simulation::set_laws(const ContactLawParams& law, const Materials& materials) {
  const bool had_rolling = par_.rolling(), had_twisting = par_.twisting();
  par_.law = law;
  par_.materials = materials;
  contacts_.set_springs(par_.rolling(), had_rolling, par_.twisting(), had_twisting);
}

StepStart Simulation::local_motion() const {
  StepStart r;
  for (std::size_t a = 0; a < p_.n_owned(); ++a) {
    raise_max(r.max_d2, (p_.x[a] - cell_.cartesian(s_ref_[a])).squaredNorm());
    raise_max(r.max_v2, p_.v[a].squaredNorm());
  }
  return r;
}

bool Simulation::needs_rebuild(const StepStart& motion) {
  const Vec3& L = cell_.lengths();
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  // m[0]: the largest displacement^2 since the last rebuild; m[1]: the largest speed^2 (the
  // step guard). A non-finite value counts as infinite (an exact maximum on every rank).
  // m[2]: the largest overlap ratio beyond the limit found by the last force computation.
  double m[3] = {motion.max_d2, motion.max_v2, guards_.overlap().ratio};
  domain_->max_all(std::span<double>(m, 3));
  guards_.check_motion(m[1], m[2], m[0] != inf, p_, *domain_, step_, par_.dt);
  // The largest stretch of a branch vector by the cell's deformation since the rebuild (sheared:
  // the Frobenius norm of H H_ref^-1 - I, a bound on it).
  const real_t strain = cell_.sheared() ? (cell_.matrix() * H_ref_.inverse() - Mat3::Identity()).norm()
                                        : (L.cwiseQuotient(L_ref_) - Vec3::Ones()).cwiseAbs().maxCoeff();
  // A moving wall and a sphere approach by at most the wall's travel plus the sphere's.
  real_t wall_travel = 0;
  for (std::size_t w = 0; w < par_.walls.size() && w < wall_ref_.size(); ++w)
    wall_travel = std::max(wall_travel, (par_.walls[w].point - wall_ref_[w]).norm());
  return 2.0 * std::sqrt(m[0]) + strain * cutoff_max_ > par_.skin || std::sqrt(m[0]) + wall_travel > par_.skin;
}

void Simulation::rebuild(bool forces_spent) {
  guards_.check_cell(cell_, cutoff_max_, par_.skin, step_);  // unless a guard has tripped
  // The displacement reference is made anew at the end: free it for the rebuild's peak.
  std::vector<Vec3>().swap(s_ref_);
  // The work of each owned particle over the last list (1 + its pairs), by which the MPI
  // domain may balance its decomposition.
  std::optional<std::vector<std::int32_t>> work;
  if (domain_->size() > 1) {  // on every rank, so that the balancing decision is collective
    const PairList& pairs = contacts_.pairs();
    std::vector<std::int32_t>& w = work.emplace(p_.n_owned(), 1);
    for (std::size_t q = 0; q < pairs.size(); ++q) {
      if (std::size_t(pairs.i[q]) < p_.n_owned()) ++w[pairs.i[q]];
      if (std::size_t(pairs.j[q]) < p_.n_owned()) ++w[pairs.j[q]];
    }
  }
  // 1. Keep the springs of touching contacts, keyed by global ids (local indices change).
  contacts_.keep_springs(p_, par_.rolling(), par_.twisting());
  rebuild_lists(forces_spent, work ? &*work : nullptr);
}

void Simulation::rebuild_lists(bool forces_spent, std::vector<std::int32_t>* work) {
  // 2. Wrap into the cell, move particles that left this subdomain (with their springs), sort
  //    the owned ones in space, and bring in the ghosts.
  p_.clear_ghosts();
  // A sheared cell leaning past its flip ratio is flipped here, where the particles are wrapped
  // and the lists and the decomposition remade anyway (the same on every rank: the cell is).
  cell_.reduce();
  for (std::size_t a = 0; a < p_.n_owned(); ++a) p_.x[a] = cell_.wrap(p_.x[a]);
  const auto t0 = timer_.now();
  domain_->migrate(p_, cell_, contacts_.carry(), work);
  // f and t are zero, or set anew by the force computation of this step (step(): rebuild(true)):
  // freed before the spatial sort, which then does not reorder them, and made again, zero,
  // once the springs are attached (the rebuild's peak memory at large N).
  if (forces_spent) p_.release_forces();
  const auto t1 = timer_.now();
  if (par_.spatial_sort) p_.permute_owned(search_.spatial_order(p_, cell_));
  const auto t2 = timer_.now();
  domain_->build_ghosts(p_, cell_, cutoff_max_);
  timer_.note_communication(t0, t1, t2);

  // 3. New lists, with the kept springs attached; the carry is released: the springs live in
  //    the lists until the next rebuild.
  contacts_.build(p_, cell_, par_.walls, par_.skin, search_, par_.rolling(), par_.twisting());
  if (forces_spent) p_.zero_forces();

  // 4. Reference for the displacement criterion, and the driven particles now owned here.
  s_ref_.resize(p_.n_owned());
  for (std::size_t a = 0; a < p_.n_owned(); ++a) s_ref_[a] = cell_.fractional(p_.x[a]);
  L_ref_ = cell_.lengths();
  H_ref_ = cell_.matrix();
  driven_.find(p_, par_.driven);
  wall_ref_.resize(par_.walls.size());
  for (std::size_t w = 0; w < par_.walls.size(); ++w) wall_ref_[w] = par_.walls[w].point;
  ++rebuilds_;
  lists_step_ = step_;  // step() sets it to the step's number once counted
}

}  // namespace fabrica
