#include "apps/stage_run.hpp"

#include "apps/stage_end.hpp"
#include "apps/stage_record.hpp"
#include "core/contact_snapshot.hpp"
#include "core/fabric.hpp"
#include "core/principal.hpp"
#include "io/mpi/run_output.hpp"
#include "parallel/guard.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

namespace fabrica {

void write_series_header(std::ostream& out, bool shear, bool localisation) {
  out << "stage,step,time,eps1,eps2,eps3,epsv,s11,s22,s33,s12,s23,s13,p,q,q_p,void_ratio,Z,Z_m,"
         "sliding_fraction,rolling_fraction,inertial_number,unbalanced,kinetic,e_normal,e_shear,"
         "e_rolling,diss_friction,diss_rolling,diss_viscous,diss_local,boundary_work,"
         "energy_error,mean_overlap_d,max_overlap_r";
  if (shear) out << ",gamma_12,gamma_13,gamma_23,sigma_1,sigma_2,sigma_3,n1,n2,n3,theta_12";
  if (localisation) out << ",localisation";
  out << '\n';
}

StageRun::StageRun(const Scene& scene, Simulation& sim, real_t mean_diameter, real_t density, std::ostream* series,
                   std::ostream* log, const StageRun* parent)
    : scene_(scene), sim_(sim), d_mean_(mean_diameter), density_(density), series_(series), log_(log),
      shear_out_(any_shears(scene.stages) || sim.cell().sheared()), l0_(sim.cell().lengths()) {
  std::ostringstream h;
  write_series_header(h, shear_out_, scene.fields.localisation());
  header_ = h.str();
  if (sim.cell().sheared()) ls_ = sim.cell().lengths();  // no better reference is known
  if (parent) {                                          // a branch of the parent's simulation: the account continues
    in_pos_ = parent->in_pos_;
    input_seen_ = parent->input_seen_;
    l0_ = parent->l0_;
    ls_ = parent->ls_;
    e0_ = parent->e0_;
  } else {
    input_seen_ = sim_.macro().energy_input - sim_.energy_account().e0;
  }
}

void StageRun::track_input(const MacroState& m) {
  const real_t input = m.energy_input - sim_.energy_account().e0;  // boundary + gravity work
  in_pos_ += std::max<real_t>(0, input - input_seen_);
  input_seen_ = input;
}

real_t StageRun::energy_error(const MacroState& m) const {
  const real_t in = energy_in();
  return in > 0 ? (m.energy_input - energy_books(m)) / in : 0.0;
}

Vec3 StageRun::strain(const Vec3& l0) const {
  Vec3 e;
  if (!sim_.cell().sheared()) {
    for (int k = 0; k < 3; ++k) e[k] = std::log(l0[k] / sim_.cell().lengths()[k]);
    return e;
  }
  for (int k = 0; k < 3; ++k) e[k] = std::log(l0[k] / ls_[k]) - sim_.cell().strain()(k, k);
  return e;
}

Vec3 StageRun::reference() const {
  if (!sim_.cell().sheared()) return sim_.cell().lengths();
  return ls_.cwiseProduct(Vec3(sim_.cell().strain().diagonal()).array().exp().matrix());
}

Vec3 StageRun::shear_strain(const Mat3& e0) const {
  const Mat3 d = sim_.cell().strain() - e0;
  return Vec3(2 * d(0, 1), 2 * d(0, 2), 2 * d(1, 2));
}

void StageRun::row(const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma, real_t localisation) {
  if (!series_ && !output_) return;
  const real_t nc = std::max<real_t>(1.0, real_t(m.contacts));
  real_t rate = std::abs(sim_.cell().strain_rate()[0]);
  if (sim_.cell().sheared()) {  // the largest of |edot_1| and the engineering shear rates
    const Mat3 G = sim_.cell().velocity_gradient();
    for (const auto& ij : kShearPairs) rate = std::max(rate, std::abs(G(ij[0], ij[1]) + G(ij[1], ij[0])));
  }
  const real_t inertial = m.p > 0 ? rate * d_mean_ * std::sqrt(density_ / m.p) : 0;
  const Dissipation& d = m.dissipated;
  const real_t values[] = {sim_.time(),
                           eps[0],
                           eps[1],
                           eps[2],
                           eps.sum(),
                           m.stress(0, 0),
                           m.stress(1, 1),
                           m.stress(2, 2),
                           m.stress(0, 1),
                           m.stress(1, 2),
                           m.stress(0, 2),
                           m.p,
                           m.q,
                           m.p > 0 ? m.q / m.p : 0.0,
                           m.void_ratio,
                           m.coordination,
                           m.mech_coordination,
                           real_t(m.sliding) / nc,
                           real_t(m.rolling) / nc,
                           inertial,
                           m.unbalanced,
                           m.kinetic,
                           m.e_normal,
                           m.e_shear,
                           m.e_rolling,
                           d.friction,
                           d.rolling,
                           d.viscous,
                           d.local,
                           sim_.boundary_work(),
                           energy_error(m),
                           m.mean_overlap / d_mean_,
                           m.max_overlap_ratio};
  std::vector<real_t> all(std::begin(values), std::end(values));
  if (shear_out_) {  // the shear strains, the principal stresses and the major direction
    const Principal pr = principal(m.stress);
    all.insert(all.end(),
               {gamma[0], gamma[1], gamma[2], pr.values[0], pr.values[1], pr.values[2], pr.major[0], pr.major[1],
                pr.major[2], pr.angle_12});
  }
  if (scene_.fields.localisation()) all.push_back(localisation);  // NaN without a strain increment
  if (output_) {
    output_->series_row(case_, header_, st.name, sim_.step_count(), all);
    if (record_) record_->h5_row(st.name, sim_.step_count(), all.data(), all.size());
  }
  if (!series_) return;
  std::string line = fmt::format("{},{}", st.name, sim_.step_count());
  for (real_t v : all) line += fmt::format(",{:.10g}", v);
  line += '\n';
  *series_ << line;
  if (record_) record_->series << line;
}

void StageRun::fabric_row(const StageSpec& st, const Vec3& eps) {
  if (!scene_.fabric.enabled) return;
  const auto t0 = std::chrono::steady_clock::now();
  // The records listed afresh for each of the analysis' three passes, not held (memory at 10^6
  // spheres: 128 bytes per contact).
  const Particles& p = std::as_const(sim_).particles();  // const: the ghosts keep drifting
  const auto records = [&](const ContactVisitor& fn) {
    for_each_contact_record(p, sim_.cell(), sim_.params().law, sim_.pairs(), fn, &sim_.params().materials);
  };
  const FabricOptions opt{scene_.fabric.strong_ratio, int(scene_.fabric.rose_bins)};
  const FabricResult r = analyse_fabric(records, sim_.cell().volume(), opt, sim_.domain());
  if (fabric_out_) write_fabric_rows(*fabric_out_, st.name, sim_.step_count(), eps[0], r, shear_out_);
  if (fabric_out_ && record_) write_fabric_rows(record_->fabric(), st.name, sim_.step_count(), eps[0], r, shear_out_);
  fabric_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void StageRun::apply_contact(const StageSpec& st) {
  if (st.own_law) {
    Materials m = scene_materials(scene_);
    m.apply(st.law);
    sim_.set_laws(st.law.applied_to(scene_.law), m);
  } else if (st.law.any()) {
    sim_.change_law(st.law);  // the scene's law and every material's
  }
  if (st.local_damping) sim_.set_local_damping(*st.local_damping);
}

namespace {
// Runs a control update, turning the servo's divergence into the run's error (the same on every
// rank: reduced values only).
template <class F>
auto guarded(const Scene& scene, const Simulation& sim, const StageSpec& st, const StageControl& c, const MacroState& m,
             F update) {
  try {
    return update();
  } catch (const ServoDivergence& e) {
    const Vec3 t = c.targets();
    throw CollectiveError(fmt::format(
        "{}: {} the {} stage stopped at step {}: {} (p = {:.6g} Pa, "
        "target {:.6g} Pa; servo {})",
        scene.path, st.where, st.name, sim.step_count(), e.what(), m.p, t.maxCoeff(), c.servo().describe()));
  }
}
}  // namespace

Vec3 StageRun::update(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps, real_t elapsed) {
  // Collective when needed: every rank takes the same decision from the reduced stress.
  const SpecimenResponse R = c.needs_response(m.stress) ? specimen_response(sim_) : SpecimenResponse{};
  return guarded(scene_, sim_, st, c, m, [&] { return c.update(m.stress, eps, elapsed, R); });
}

Vec3 StageRun::update_gradient(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps,
                               const Vec3& gamma, real_t elapsed, real_t stage_time) {
  const SpecimenResponse R =
      c.needs_response(m.stress) ? specimen_response(sim_, c.needs_shear_response()) : SpecimenResponse{};
  const Mat3 G =
      guarded(scene_, sim_, st, c, m, [&] { return c.update_gradient(m.stress, eps, gamma, elapsed, stage_time, R); });
  const bool was = sim_.cell().sheared();
  sim_.cell().set_velocity_gradient(G);
  if (!was && sim_.cell().sheared()) ls_ = sim_.cell().lengths();  // the strains continue from here
  return G.diagonal();
}

Vec3 StageRun::drive(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma,
                     real_t elapsed, real_t stage_time) {
  // A stage that does not shear, on a cell never sheared: the orthorhombic path, bit for bit.
  if (!st.shears() && !sim_.cell().sheared()) {
    const Vec3 rates = update(c, st, m, eps, elapsed);
    sim_.cell().set_strain_rate(rates);
    return rates;
  }
  return update_gradient(c, st, m, eps, gamma, elapsed, stage_time);
}

// A servo that cannot follow the loading: a stress axis at the rate cap while its stress is far
// from the target (10 x the stage's tolerance), in a stage that drives another axis, after the
// stage's first 50 servo updates.
bool StageRun::warn_cap(const StageSpec& st, const StageControl& c, const MacroState& m, const Vec3& rates) {
  const real_t cap = st.servo.max_strain_rate, tol = st.servo.stress_tolerance;
  const Vec3 t = c.targets();
  for (int a = 0; a < 3; ++a) {
    if (!c.stress_axes()[a] || std::abs(rates[a]) < cap) continue;
    if (std::abs(m.stress(a, a) - t[a]) <= 10 * tol * t[a]) continue;
    if (st.shears()) {  // the shear paths drive no axial rate
      *log_ << fmt::format(
          "  warning: step {}: the servo is at its rate cap ({} max_strain_rate = {} 1/s) on axis {} and s{}{} = "
          "{:.4g} Pa is {:.1f} % from the target {:.4g} Pa: it cannot follow the shear loading; raise "
          "max_strain_rate or lower the shear rate\n",
          sim_.step_count(), st.where, cap, a + 1, a + 1, a + 1, m.stress(a, a),
          100 * std::abs(m.stress(a, a) - t[a]) / t[a], t[a]);
      log_->flush();
      return true;
    }
    *log_ << fmt::format(
        "  warning: step {}: the servo is at its rate cap ({} max_strain_rate = {} "
        "1/s) on axis {} and s{}{} = {:.4g} Pa is {:.1f} % from the target {:.4g} "
        "Pa: it cannot follow the axial loading ({} 1/s); raise max_strain_rate "
        "or lower axial_strain_rate\n",
        sim_.step_count(), st.where, cap, a + 1, a + 1, a + 1, m.stress(a, a),
        100 * std::abs(m.stress(a, a) - t[a]) / t[a], t[a], std::abs(st.rate[0]));
    log_->flush();
    return true;
  }
  return false;
}

// Over the rows: the peak q/p and the largest relative error of the stress-controlled components
// (a shear component's relative to the control's shear scale).
void StageRun::track(StageResult& res, const StageControl& c, const MacroState& m, const Vec3& eps) const {
  const real_t qp = m.p > 0 ? m.q / m.p : 0;
  if (qp > res.peak_q_p) res.peak_q_p = qp, res.peak_eps1 = eps[0];
  const Vec3 targets = c.targets();
  for (int a = 0; a < 3; ++a)
    if (c.stress_axes()[a])
      res.max_lateral_error = std::max(res.max_lateral_error, std::abs(m.stress(a, a) - targets[a]) / targets[a]);
  const Vec3 shear = c.shear_targets();
  for (int q = 0; q < 3; ++q) {
    if (!c.shear_axes()[q]) continue;
    const int i = kShearPairs[q][0], j = kShearPairs[q][1];
    const real_t s = 0.5 * (m.stress(i, j) + m.stress(j, i));
    res.max_lateral_error = std::max(res.max_lateral_error, std::abs(s - shear[q]) / c.shear_scale());
  }
}

void StageRun::progress(const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma, double secs,
                        std::int64_t steps) {
  std::string eta;
  if (st.end.strain) {
    const real_t x = eps[st.end.strain_axis] / *st.end.strain;
    if (x > 0) eta = fmt::format(", {:.0f} s left", secs * (1 - x) / x);
  }
  if (st.end.shear_strain) {
    const real_t x = gamma[st.end.shear_component] / *st.end.shear_strain;
    if (x > 0) eta = fmt::format(", {:.0f} s left", secs * (1 - x) / x);
  }
  if (st.shears()) eta = fmt::format(", gamma ({:.4f}, {:.4f}, {:.4f}){}", gamma[0], gamma[1], gamma[2], eta);
  *log_ << fmt::format(
      "  [{}] step {}: eps1 {:.4f}, p {:.1f} kPa, q/p {:.4f}, e {:.4f}, "
      "unbalanced {:.2e}, {:.0f} steps/s{}\n",
      st.name, sim_.step_count(), eps[0], m.p / 1e3, m.p > 0 ? m.q / m.p : 0, m.void_ratio, m.unbalanced,
      double(steps) / secs, eta);
  log_->flush();
}

bool StageRun::row_due(const StageSpec&, std::int64_t k) const { return k % scene_.output_every == 0; }

bool StageRun::measures(const StageSpec& st, std::int64_t k, bool at_row) const {
  return at_row || k % st.servo.interval == 0 || (st.end.steps && k == *st.end.steps);
}

void StageRun::rows(const StageSpec& st, std::int64_t k, const MacroState& m, const Vec3& eps, const Vec3& gamma) {
  // [fields] first: the row carries the instant's localisation index.
  const real_t index = output_ && output_->fields_due(k) ? output_->fields(case_, sim_) : kNoLocalisation;
  row(st, m, eps, gamma, index);
  if (st.fabric == StageFabric::AtRows) fabric_row(st, eps);
  if (row_check_) row_check_();
}

void StageRun::end_rows(const StageSpec& st, std::int64_t, const MacroState& m, const Vec3& eps, const Vec3& gamma,
                        bool at_row) {
  if (!at_row) row(st, m, eps, gamma, kNoLocalisation);
  if ((!at_row && st.fabric == StageFabric::AtRows) || st.fabric == StageFabric::AtEnd) fabric_row(st, eps);
  if (row_check_) row_check_();
}

void StageRun::unended(const StageSpec& st, const StageResult& res, const StageControl& c) const {
  throw CollectiveError(
      fmt::format("{}: {} = {}: the {} stage did not converge (last p = {:.6g} Pa, target {:.6g} Pa, "
                  "s11 {:.6g}, s22 {:.6g}, s33 {:.6g} Pa, unbalanced-force ratio {:.3g}; servo {}); raise "
                  "it or the damping",
                  scene_.path, st.where == "[triaxial]" ? "[triaxial] max_stage_steps" : st.where + ".max_steps",
                  st.max_steps, st.name, res.state.p, c.targets().maxCoeff(), res.state.stress(0, 0),
                  res.state.stress(1, 1), res.state.stress(2, 2), res.state.unbalanced, c.servo().describe()));
}

StageResult StageRun::run(const StageSpec& st, std::int32_t index, const StageCursor* resume) {
  using clock = std::chrono::steady_clock;
  StageControl control(st, real_t(st.servo.interval) * sim_.params().dt);
  StageResult res;
  bool warned = false;
  std::int64_t updates = 0;  // servo updates of this stage in this process (for the warning)
  real_t last_servo = sim_.time();
  std::int64_t k = 1;
  Vec3 stage_l0 = reference();
  Mat3 stage_e0 = sim_.cell().strain();
  const real_t dt = sim_.params().dt;
  const bool drives =
      st.mode[0] == AxisMode::StrainRate || st.mode[1] == AxisMode::StrainRate || st.mode[2] == AxisMode::StrainRate;
  if (resume) {  // the rates, the contact parameters and the account are the checkpoint's
    res = resume->result;
    control.set_state(resume->control);
    last_servo = resume->last_servo;
    k = resume->k + 1;
    stage_l0 = resume->stage_l0;
    stage_e0 = resume->stage_e0;
  } else {
    apply_contact(st);
    if (st.reset_strain) l0_ = reference(), e0_ = sim_.cell().strain();
    drive(control, st, sim_.macro(), Vec3::Zero(), Vec3::Zero(), 0.0, 0.0);
  }
  const std::int64_t k0 = k - 1;
  const auto t0 = clock::now();
  auto last_print = t0;
  for (;; ++k) {
    if (k > st.max_steps) unended(st, res, control);
    const bool out = row_due(st, k);
    const bool measure = measures(st, k, out);
    sim_.step(measure);  // the boundary work is the simulation's (Simulation::boundary_work)
    if (!sim_.step_guard().empty()) throw BlowUpError(sim_.step_guard());  // every step
    if (output_ && output_->snapshot_due(sim_.step_count())) output_->snapshot(case_, sim_, strain(l0_));
    if (measure) {
      const MacroState& m = sim_.macro();
      track_input(m);
      res.state = m;
      const std::string bad = diagnose(m, sim_.step_count(), scene_.max_overlap, scene_.kinetic_runaway);
      if (!bad.empty()) throw BlowUpError(bad);
      const Vec3 eps = strain(l0_), eps_stage = strain(stage_l0);
      const Vec3 gamma = shear_strain(e0_), gamma_stage = shear_strain(stage_e0);
      const real_t stage_time = real_t(k) * dt;
      res.max_energy_error = std::max(res.max_energy_error, std::abs(energy_error(m)));
      const bool finished = stage_done(
          st,
          EndProbe{k, &m, eps_stage, control.targets(),
                   control.cycles_done(m.stress, eps_stage) || control.shear_cycles_done(m.stress, gamma_stage),
                   gamma_stage, control.shear_targets(), control.shear_scale(), control.angle_done(stage_time)});
      // Over every row of the series: the output instants and the stage's last row (a stage
      // shorter than output_every has only that one).
      if (st.track_peak && (out || finished)) track(res, control, m, eps);
      if (out) rows(st, k, m, eps, gamma);
      const Vec3 rates = drive(control, st, m, eps_stage, gamma_stage, sim_.time() - last_servo, stage_time);
      last_servo = sim_.time();
      // Said once, and not in the stage's first 50 updates: a new stage's targets may jump
      // (constant p after an anisotropic state), and the servo at its cap then is no failure.
      if (drives && !warned && log_ && ++updates > 50) warned = warn_cap(st, control, m, rates);
      const auto now = clock::now();
      if (log_ && std::chrono::duration<double>(now - last_print).count() > scene_.triaxial.progress_seconds) {
        last_print = now;
        progress(st, m, eps_stage, gamma_stage, std::chrono::duration<double>(now - t0).count(), k - k0);
      }
      if (finished) {
        res.steps = k;
        res.strain = eps;
        res.gamma = gamma;
        end_rows(st, k, m, eps, gamma, out);
        if (output_) output_->snapshot(case_, sim_, eps);  // always one at the end of a stage
        return res;
      }
    }
    if (hook_)
      hook_(StageCursor{index, k, control.state(), last_servo, res, l0_, stage_l0, in_pos_, input_seen_, ls_, e0_,
                        stage_e0});
  }
}

StageCursor StageRun::account() const {
  StageCursor a;
  a.l0 = l0_;
  a.sheared_lengths = ls_;
  a.e0 = e0_;
  a.input_positive = in_pos_;
  a.input_seen = input_seen_;
  return a;
}

void StageRun::set_account(const StageCursor& a) {
  l0_ = a.l0;
  in_pos_ = a.input_positive;
  input_seen_ = a.input_seen;
  if (!a.sheared_lengths.isZero()) ls_ = a.sheared_lengths;
  e0_ = a.e0;
}

}  // namespace fabrica
