#include "core/simulation.hpp"

#include "core/integrator.hpp"
#include "core/wall_servo.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <limits>
#include <span>
#include <chrono>
#include <cmath>
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
    impose_driven(0.0);
    domain_->update_ghosts(p_);  // the ghosts' copies too (collective: every rank has the sets)
  }
  compute(true, 0.0);  // initial forces: no time passes, so the springs must not advance
  measure_and_reduce(Vec3::Zero());
  e0_ = macro_.kinetic + macro_.e_normal + macro_.e_shear + macro_.e_rolling;
  macro_.energy_input = e0_ + macro_.gravity_work;
}

EnergyAccount Simulation::energy_account() const {
  EnergyAccount a;
  a.e0 = e0_;
  a.work = work_;
  a.vol_strain = Vec3(volume_prev_, stress_known_ ? 1.0 : 0.0, 0.0);
  a.stress_prev.diagonal() = stress_prev_;
  a.gravity_work_local = gravity_work_local_;
  a.wall_work = wall_work_;
  a.drive_work = drive_work_;
  return a;
}

namespace {
// Adds the time since the previous lap to one field of PhaseTimes; does nothing when off.
class PhaseClock {
 public:
  using clock = std::chrono::steady_clock;
  explicit PhaseClock(PhaseTimes* t) : t_(t) {
    if (t_) last_ = clock::now();
  }
  void lap(double PhaseTimes::*field) {
    if (!t_) return;
    const clock::time_point now = clock::now();
    t_->*field += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  PhaseTimes* t_;
  clock::time_point last_;
};
}  // namespace

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
      diss_(s.dissipation), macro_(s.macro), step_(s.step), time_(s.time) {
  const real_t rmax = domain_->max_all(p_.max_radius());
  cutoff_max_ = 2 * rmax + par_.skin;
  check_cell_size(cell_, rmax, par_.skin);
  carry_ = std::move(s.history);
  domain_->adopt(p_, cell_, cutoff_max_, s.decomposition.empty() ? nullptr : &s.decomposition, s.holding, &carry_);
  e0_ = s.energy.e0;
  work_ = s.energy.work;
  volume_prev_ = s.energy.vol_strain[0];
  stress_known_ = s.energy.vol_strain[1] != 0;
  stress_prev_ = s.energy.stress_prev.diagonal();
  gravity_work_local_ = s.energy.gravity_work_local;
  wall_work_ = s.energy.wall_work;
  drive_work_ = s.energy.drive_work;
  rebuild_lists();  // the saved run rebuilt at the saved positions: the same lists
  rebuilds_ = s.rebuilds;
}

void Simulation::step(bool measure) {
  const real_t dt = par_.dt;
  PhaseClock clk(timing_ ? &times_ : nullptr);
  const Vec3 rate = cell_.strain_rate();
  StepStart motion;
  double drive = 0;
  Vec3 scale;
  if (driven_.empty()) {  // one pass: [the last step's closing kick,] kick, gravity's power,
                          // drift, the check's maxima, f and t
    motion = kick_drift_check(p_, cell_, dt, s_ref_, par_.gravity, kick_pending_);
    scale = motion.scale;
    kick_pending_ = false;
    if (!par_.gravity.isZero()) gravity_work_local_ += motion.gravity_power * dt;
  } else {
    settle();
    half_kick(p_, dt);
    drive = impose_driven(0.5 * dt);
    if (!par_.gravity.isZero()) {  // work of gravity over the drift, with the drift's velocity
      real_t gv = 0;
      for (std::size_t a = 0; a < p_.n_owned(); ++a) gv += p_.mass[a] * par_.gravity.dot(p_.v[a]);
      gravity_work_local_ += gv * dt;
    }
    scale = drift_and_deform(p_, cell_, dt);
  }
  for (Wall& w : par_.walls) w.point += w.velocity * dt;
  clk.lap(&PhaseTimes::integrate);
  // The ghosts' update travels while the rebuild check, which reads owned particles only, runs
  // (the messages can progress during its reduction). It carries v and w, and the ghosts'
  // positions take the step's drift on arrival, unless the owned positions were open to
  // change since the ghosts last had them (particles() not const): then they travel too.
  const GhostDrift drift{dt, scale, !rate.isZero()};
  domain_->begin_ghost_update(p_, positions_exposed_ ? nullptr : &drift);
  positions_exposed_ = false;
  clk.lap(&PhaseTimes::ghost);
  if (!driven_.empty()) motion = local_motion();
  const bool rebuild_now = needs_rebuild(motion);
  // A migration's arrivals have f = 0: under gravity the force computation sets them all.
  owned_ready_ = driven_.empty() && (par_.gravity.isZero() || !rebuild_now);
  rebuilt_last_ = false;  // set by rebuild_lists()
  clk.lap(&PhaseTimes::check);
  domain_->end_ghost_update(p_);
  clk.lap(&PhaseTimes::ghost);
  if (rebuild_now) {
    rebuild(true);  // f and t: zero (owned_ready_) or reset by compute() below
    clk.lap(&PhaseTimes::rebuild);
    times_.rebuild -= last_migrate_seconds_;
    times_.migrate += last_migrate_seconds_;
  }
  const bool strains = !rate.isZero();
  const bool timed = domain_->wants_force_seconds();  // a decomposition balanced by time
  const auto f0 = timed ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
  compute(measure || strains, dt, !measure);  // a straining step needs the contact virial (boundary work)
  if (timed) domain_->note_force_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - f0).count());
  clk.lap(&PhaseTimes::force);
  if (!measure && driven_.empty()) kick_pending_ = true;  // to the next step's first pass (or settle())
  else half_kick(p_, dt);
  if (!par_.driven.empty()) {  // the same on every rank (the sets, not this rank's members)
    drive += impose_driven(0.5 * dt);
    domain_->sum_all(std::span<double>(&drive, 1));
    drive_work_ += drive;
  }
  clk.lap(&PhaseTimes::integrate);
  if (measure) {
    measure_and_reduce(rate * dt);
  } else if (strains) {
    double d[3] = {sums_.fb(0, 0), sums_.fb(1, 1), sums_.fb(2, 2)};
    domain_->sum_all(std::span<double>(d, 3));
    const real_t V = cell_.volume();
    account_step(rate * dt, Vec3(d[0] / V, d[1] / V, d[2] / V));
  } else {
    stress_known_ = false;
  }
  if (measure || strains) clk.lap(&PhaseTimes::reduce);
  times_.steps += timing_;
  ++step_;
  time_ += dt;
}

void Simulation::compute(bool measure, real_t dt, bool virial_only) {
  overlap_ = OverlapAlarm{};
  const bool moving = dt > 0 && par_.moving_walls();
  // Servo walls (core/wall_servo.hpp): the push and contact stiffness of each wall, exact sums.
  const bool servo = dt > 0 && servo_wall_count(par_.walls) > 0;
  if (servo) {  // kept between steps: no allocation per step
    if (wall_sums_.slots() != 2 * par_.walls.size()) wall_sums_ = ExactSums(2 * par_.walls.size());
    std::fill(wall_sums_.words().begin(), wall_sums_.words().end(), 0);
  }
  ForceContext ctx{par_.law, par_.walls, par_.gravity, dt, &overlap_, par_.kernel_lanes};
  ctx.materials = &par_.materials;
  ctx.wall_load = servo ? &wall_sums_ : nullptr;
  ctx.owned_ready = owned_ready_;
  ctx.virial_only = virial_only;
  ctx.fetch_ahead = par_.fetch_ahead;
  owned_ready_ = false;
  real_t power = 0;
  compute_forces(p_, cell_, ctx, pairs_, walls_, diss_, measure ? &sums_ : nullptr, moving ? &power : nullptr);
  if (moving) {  // the walls' work over this step, with the forces at its end (every rank)
    double pw = power;
    domain_->sum_all(std::span<double>(&pw, 1));
    wall_work_ += pw * dt;
  }
  if (servo) {  // the walls' velocities for the next step, the same on every rank and rank count
    wall_sums_.normalize();
    domain_->sum_all(wall_sums_.words());
    wall_sums_.normalize();
    wall_load_.resize(wall_sums_.slots());
    for (std::size_t k = 0; k < wall_sums_.slots(); ++k) wall_load_[k] = wall_sums_.value(k);
    update_servo_walls(par_.walls, wall_load_, cell_, dt);
  }
  if (par_.local_damping > 0) diss_.local += apply_local_damping(p_, par_.local_damping, dt);
}

void Simulation::measure_and_reduce(const Vec3& strain_increment) {
  sums_.work_gravity = gravity_work_local_;
  macro_ = reduce_macro_state(p_, cell_, sums_, diss_, *domain_);
  account_step(strain_increment, macro_.stress.diagonal());
  macro_.wall_work = wall_work_;
  macro_.drive_work = drive_work_;
  macro_.energy_input = e0_ + work_ + macro_.gravity_work + wall_work_ + drive_work_;
}

void Simulation::account_step(const Vec3& strain_increment, const Vec3& stress_end) {
  const real_t V = cell_.volume();
  const Vec3 end = V * stress_end;
  if (!strain_increment.isZero()) {
    const Vec3 start = stress_known_ ? Vec3(volume_prev_ * stress_prev_) : end;
    work_ -= 0.5 * (start + end).dot(strain_increment);
  }
  stress_prev_ = stress_end;
  volume_prev_ = V;
  stress_known_ = true;
}

real_t Simulation::impose_driven(real_t dt_half) {
  real_t work = 0;
  for (const auto& [a, k] : driven_) {
    const DrivenSet& d = par_.driven[std::size_t(k)];
    work -= (p_.f[a].dot(d.velocity) + p_.t[a].dot(d.spin)) * dt_half;
    p_.v[a] = d.velocity;
    p_.w[a] = d.spin;
  }
  return work;
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
  if (par_.rolling() && !had_rolling) {
    pairs_.set_rolling(true);
    walls_.mr.assign(walls_.size(), Vec3::Zero());
  } else if (!par_.rolling()) {
    pairs_.set_rolling(false);
    walls_.mr.clear();
  }
  if (par_.twisting() && !had_twisting) {
    pairs_.set_twisting(true);
    walls_.mt.assign(walls_.size(), 0.0);
  } else if (!par_.twisting()) {
    pairs_.set_twisting(false);
    walls_.mt.clear();
  }
}

StepStart Simulation::local_motion() const {
  const Vec3& L = cell_.lengths();
  StepStart r;
  for (std::size_t a = 0; a < p_.n_owned(); ++a) {
    raise_max(r.max_d2, (p_.x[a] - s_ref_[a].cwiseProduct(L)).squaredNorm());
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
  double m[3] = {motion.max_d2, motion.max_v2, overlap_.ratio};
  domain_->max_all(std::span<double>(m, 3));
  if (guard_rmin_ == 0) {  // once: the smallest radius over every rank
    real_t r = inf;
    for (std::size_t a = 0; a < p_.n_owned(); ++a) r = std::min(r, p_.radius[a]);
    guard_rmin_ = -domain_->max_all(-r);
  }
  const real_t bound = 0.5 * guard_rmin_ / par_.dt;  // half the smallest radius in one step
  if (m[2] > 0) set_overlap_guard(m[2]);             // the earlier event (the previous force computation)
  else if (m[0] == inf || !(m[1] <= bound * bound)) set_step_guard(m[1], bound);
  const real_t strain = (L.cwiseQuotient(L_ref_) - Vec3::Ones()).cwiseAbs().maxCoeff();
  // A moving wall and a sphere approach by at most the wall's travel plus the sphere's.
  real_t wall_travel = 0;
  for (std::size_t w = 0; w < par_.walls.size() && w < wall_ref_.size(); ++w)
    wall_travel = std::max(wall_travel, (par_.walls[w].point - wall_ref_[w]).norm());
  return 2.0 * std::sqrt(m[0]) + strain * cutoff_max_ > par_.skin || std::sqrt(m[0]) + wall_travel > par_.skin;
}

void Simulation::set_step_guard(real_t max_v2, real_t bound) {
  // Only when the guard trips: the particle (the highest id among equals) and its velocity,
  // from a second reduction; non-holders send -inf.
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  double w[4] = {-inf, -inf, -inf, -inf};
  for (std::size_t a = 0; a < p_.n_owned(); ++a) {
    const real_t v2 = p_.v[a].squaredNorm();
    const bool bad = !std::isfinite(v2) || !p_.x[a].allFinite() || (v2 >= max_v2 && std::isfinite(max_v2));
    if (bad && double(p_.id[a]) > w[0])
      w[0] = double(p_.id[a]), w[1] = p_.v[a][0], w[2] = p_.v[a][1], w[3] = p_.v[a][2];
  }
  domain_->max_all(std::span<double>(w, 4));
  char b[400];
  if (!std::isfinite(max_v2))
    std::snprintf(b, sizeof b,
                  "numerical blow-up at step %lld: particle %.0f has a non-finite position "
                  "or velocity (velocity (%.6g, %.6g, %.6g) m/s)",
                  (long long)(step_ + 1), w[0], w[1], w[2], w[3]);
  else
    std::snprintf(b, sizeof b,
                  "numerical blow-up at step %lld: particle %.0f moves at %.6g m/s, more than "
                  "half the smallest radius (%.6g m) per time step (%.6g s), %.6g m/s: an overlap can "
                  "jump past any bound in one step (velocity (%.6g, %.6g, %.6g) m/s)",
                  (long long)(step_ + 1), w[0], std::sqrt(max_v2), guard_rmin_, par_.dt, bound, w[1], w[2], w[3]);
  guard_ = b;
}

void Simulation::set_overlap_guard(real_t max_ratio) {
  // Only when the guard trips: the contact from a second reduction (the highest ids among
  // equal ratios); non-holders send -inf.
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  const bool mine = overlap_.ratio == max_ratio;
  double w[4] = {mine ? double(overlap_.a) : -inf, mine ? double(overlap_.b) : -inf, mine ? overlap_.overlap : -inf,
                 mine ? overlap_.radius : -inf};
  domain_->max_all(std::span<double>(w, 4));
  char b[400];
  const bool wall = w[1] < 0;
  std::snprintf(b, sizeof b,
                "numerical blow-up at step %lld: overlap of particle%s %.0f and %s%.0f is %.6g of "
                "the smaller radius (%.6g m, radius %.6g m), beyond the geometric limit %.6g (a "
                "centre inside the other body)",
                (long long)step_, wall ? "" : "s", w[0], wall ? "wall " : "", wall ? -1 - w[1] : w[1], max_ratio, w[2],
                w[3], kMaxOverlapRatio);
  guard_ = b;
}

void Simulation::rebuild(bool forces_spent) {
  if (guard_.empty()) check_cell_still_fits();
  const bool rolling = par_.rolling(), twisting = par_.twisting();
  // The displacement reference is made anew at the end: free it for the rebuild's peak.
  std::vector<Vec3>().swap(s_ref_);
  // 1. Keep the springs of touching contacts, keyed by global ids (local indices change): the
  //    carry takes the list's spring pools over and keys the slots of the touching pairs. The
  //    bodies of each slot are noted first (8 bytes a slot), so that the old list is freed
  //    before the keys are made (the rebuild's peak at large N).
  std::vector<std::array<Index, 2>> bodies(pairs_.spring_fs.size(), {Index(-1), Index(-1)});
  for (std::size_t q = 0; q < pairs_.size(); ++q)
    if (pairs_.touching[q]) bodies[pairs_.slot[q]] = {pairs_.i[q], pairs_.j[q]};
  // The work of each owned particle over the last list (1 + its pairs), by which the MPI
  // domain may balance its decomposition.
  if (domain_->size() > 1) {  // on every rank, so that the balancing decision is collective
    std::vector<std::int32_t>& w = particle_work_.emplace(p_.n_owned(), 1);
    for (std::size_t q = 0; q < pairs_.size(); ++q) {
      if (std::size_t(pairs_.i[q]) < p_.n_owned()) ++w[pairs_.i[q]];
      if (std::size_t(pairs_.j[q]) < p_.n_owned()) ++w[pairs_.j[q]];
    }
  }
  std::vector<Vec3> fs = std::move(pairs_.spring_fs), mr = std::move(pairs_.spring_mr);
  std::vector<real_t> mt = std::move(pairs_.spring_mt);
  const bool pairs_rolling = pairs_.rolling, pairs_twisting = pairs_.twisting;
  pairs_ = PairList();  // freed (memory at large N)
  carry_.adopt_pools(std::move(fs), std::move(mr), rolling && pairs_rolling, std::move(mt), twisting && pairs_twisting);
  for (std::size_t s = 0; s < bodies.size(); ++s)
    if (bodies[s][0] != Index(-1)) carry_.insert_slot(p_.id[bodies[s][0]], p_.id[bodies[s][1]], std::uint32_t(s));
  std::vector<std::array<Index, 2>>().swap(bodies);
  for (std::size_t q = 0; q < walls_.size(); ++q)
    if (walls_.touching[q]) carry_.insert(p_.id[walls_.i[q]], -1 - walls_.wall[q], wall_history(q));
  walls_ = WallContactList();
  carry_.index();
  rebuild_lists(forces_spent);
}

// The carried springs go to the new pair list, their slots renumbered in list order so that the
// force loop reads the pools nearly in order: the carry's pools are permuted in place (no second
// copy of the springs at the rebuild's peak) and become the list's; the slots no touching pair
// takes (contacts that opened, the walls', those of particles gone to other ranks) are dropped.
// The carry is released (empty) at the end.
void Simulation::attach_springs() {
  const bool rolling = par_.rolling(), twisting = par_.twisting();
  const std::size_t np = pairs_.size();
  const std::size_t m = carry_.pool_size();
  const bool had_rolling = carry_.rolling(), had_twisting = carry_.twisting();
  pairs_.rolling = rolling;
  pairs_.twisting = twisting;
  pairs_.touching.assign(np, 0);
  pairs_.slot.assign(np, 0);
  pairs_.free_slots.clear();
  std::vector<std::uint32_t> dest(m, HistoryMap::kNone);  // new slot of each carried slot
  std::uint32_t used = 0;
  if (carry_.size() != 0)
    for (std::size_t q = 0; q < np; ++q)
      if (const std::uint32_t s = carry_.find_slot(p_.id[pairs_.i[q]], p_.id[pairs_.j[q]]); s != HistoryMap::kNone) {
        pairs_.touching[q] = 1;
        pairs_.slot[q] = Index(used);
        dest[s] = used++;
      }
  std::vector<Vec3>& fs = pairs_.spring_fs;
  std::vector<Vec3>& mr = pairs_.spring_mr;
  std::vector<real_t>& mt = pairs_.spring_mt;
  carry_.take_pools(fs, mr, mt);
  // The keys are done with: free them before the pools may grow below (the rebuild's peak; at
  // 869,376 spheres 33 MB of keys beside a pool in two copies while it grows).
  carry_.release();
  // The unused slots after the used ones, then the permutation applied by cycles: each swap
  // puts one spring in its final place.
  for (std::uint32_t s = 0, next = used; s < m; ++s)
    if (dest[s] == HistoryMap::kNone) dest[s] = next++;
  const bool move_mr = had_rolling && rolling, move_mt = had_twisting && twisting;
  for (std::size_t s = 0; s < m; ++s)
    while (dest[s] != s) {
      const std::uint32_t d = dest[s];
      std::swap(fs[s], fs[d]);
      if (move_mr) std::swap(mr[s], mr[d]);
      if (move_mt) std::swap(mt[s], mt[d]);
      std::swap(dest[s], dest[d]);
    }
  std::vector<std::uint32_t>().swap(dest);
  fs.resize(used);
  if (rolling) mr.resize(used, Vec3::Zero());  // zero if rolling was off in the old list
  else std::vector<Vec3>().swap(mr);
  if (twisting) mt.resize(used, 0.0);  // zero if twisting was off in the old list
  else std::vector<real_t>().swap(mt);
  // Room for contacts that close before the next rebuild (the pools grow if they are more).
  // Without carried springs (the first list, a restart without history) every contact opens
  // in the next force pass: room for the pairs touching now, counted here, so that the pools
  // are not grown by doubling there (up to twice the room, 11 MB per rank at 869,376 spheres
  // on 4 ranks).
  std::size_t expect = used;
  if (used == 0) {
    std::array<Vec3, 27> shift;
    for (int c = 0; c < 27; ++c) shift[c] = image_offset(c, cell_.lengths());
    for (std::size_t q = 0; q < np; ++q) {
      const Index i = pairs_.i[q], j = pairs_.j[q];
      const real_t sum_r = p_.radius[i] + p_.radius[j];
      expect += (p_.x[j] + shift[pairs_.image[q]] - p_.x[i]).squaredNorm() < sum_r * sum_r;
    }
  }
  const std::size_t room = expect + expect / 16 + 64;
  fs.reserve(room);
  if (rolling) mr.reserve(room);
  if (twisting) mt.reserve(room);
}

void Simulation::check_cell_still_fits() {
  // The list holds one periodic image per pair; that is every image within the cutoff while
  // each cell length exceeds twice the cutoff (check_cell_size at the start). A cell that
  // shrinks (consolidation) can pass that limit: two spheres could then touch through two
  // images, and the second contact would be missed (spheres run into each other unseen and
  // the energy account fills with energy never put in). Checked at every rebuild, which is
  // enough: a pair outside the list cannot come into contact before the next one.
  const Vec3& L = cell_.lengths();
  const real_t need = 2.0 * cutoff_max_;
  for (int k = 0; k < 3; ++k) {
    if (L[k] > need) continue;
    char b[600];
    std::snprintf(b, sizeof b,
                  "the run cannot go on at step %lld: the periodic cell has shrunk to L%d = %.6g m, "
                  "no longer above 2 (2 Rmax + skin) = %.6g m (Rmax %.6g m, skin %.6g m); two "
                  "spheres could now touch through two periodic images, which the contact search "
                  "does not follow. Use a larger specimen (more spheres, or a narrower gradation), "
                  "so that every cell length stays above that limit at the densest state",
                  (long long)(step_ + 1), k + 1, L[k], need, 0.5 * (cutoff_max_ - par_.skin), par_.skin);
    guard_ = b;
    return;
  }
}

void Simulation::rebuild_lists(bool forces_spent) {
  const bool rolling = par_.rolling(), twisting = par_.twisting();
  // 2. Wrap into the cell, move particles that left this subdomain (with their springs), sort
  //    the owned ones in space, and bring in the ghosts.
  p_.clear_ghosts();
  for (std::size_t a = 0; a < p_.n_owned(); ++a) p_.x[a] = cell_.wrap(p_.x[a]);
  using clock = std::chrono::steady_clock;
  const auto t0 = timing_ ? clock::now() : clock::time_point{};
  domain_->migrate(p_, cell_, carry_, particle_work_ ? &*particle_work_ : nullptr);
  particle_work_.reset();
  // f and t are zero, or set anew by the force computation of this step (step(): rebuild(true)):
  // freed before the spatial sort, which then does not reorder them, and made again, zero,
  // once the springs are attached (the rebuild's peak memory at large N).
  if (forces_spent) p_.release_forces();
  const auto t1 = timing_ ? clock::now() : clock::time_point{};
  if (par_.spatial_sort) p_.permute_owned(search_.spatial_order(p_, cell_));
  const auto t2 = timing_ ? clock::now() : clock::time_point{};
  domain_->build_ghosts(p_, cell_, cutoff_max_);
  if (timing_)
    last_migrate_seconds_ =
        std::chrono::duration<double>(t1 - t0).count() + std::chrono::duration<double>(clock::now() - t2).count();

  // 3. New lists, with the kept springs attached. The walls' first: they copy their springs
  //    out of the carry, whose pools then become the pairs'.
  NeighborSearch::build_walls(p_, par_.walls, par_.skin, walls_);
  const std::size_t nw = walls_.size();
  walls_.touching.assign(nw, 0);
  walls_.fs.assign(nw, Vec3::Zero());
  if (rolling) walls_.mr.assign(nw, Vec3::Zero());
  else walls_.mr.clear();
  if (twisting) walls_.mt.assign(nw, 0.0);
  else walls_.mt.clear();
  for (std::size_t q = 0; q < nw; ++q)
    if (const std::uint32_t s = carry_.find_slot(p_.id[walls_.i[q]], -1 - walls_.wall[q]); s != HistoryMap::kNone) {
      const ContactHistory h = carry_.at(s);
      walls_.touching[q] = 1;
      walls_.fs[q] = h.fs;
      if (rolling) walls_.mr[q] = h.mr;
      if (twisting) walls_.mt[q] = h.mt;
    }
  search_.build(p_, cell_, par_.skin, pairs_);
  attach_springs();  // releases the carry: the springs live in the lists until the next rebuild
  if (forces_spent) p_.zero_forces();

  // 4. Reference for the displacement criterion.
  const Vec3& L = cell_.lengths();
  s_ref_.resize(p_.n_owned());
  for (std::size_t a = 0; a < p_.n_owned(); ++a) s_ref_[a] = p_.x[a].cwiseQuotient(L);
  L_ref_ = L;
  driven_.clear();
  if (!par_.driven.empty())
    for (std::size_t a = 0; a < p_.n_owned(); ++a)
      for (std::size_t k = 0; k < par_.driven.size(); ++k)
        if (par_.driven[k].contains(p_.id[a])) {
          driven_.emplace_back(Index(a), std::int32_t(k));
          break;
        }
  wall_ref_.resize(par_.walls.size());
  for (std::size_t w = 0; w < par_.walls.size(); ++w) wall_ref_[w] = par_.walls[w].point;
  ++rebuilds_;
  rebuilt_last_ = true;
}

}  // namespace fabrica
