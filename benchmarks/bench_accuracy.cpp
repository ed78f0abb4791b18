// bench_accuracy: run time against error (docs/accuracy.md).
//
//   bench_accuracy impact   OUTDIR                 impact scenes against their closed forms
//   bench_accuracy triaxial OUTDIR [N=500] [EPS=0.1] a small triaxial test against reference runs
//
// impact: two equal spheres (R = 10 mm, E = 100 MPa, rho = 2650) meet head-on at 0.2 m/s.
//   elastic:  contact time T = pi sqrt(m_eff / k_n) and rebound speed = approach speed;
//   viscous:  normal dashpot beta = 0.2, restitution e(beta) with the no-tension clamp
//             (docs/verification.md section 2);
//   against the time step as a fraction of the critical estimate. Writes OUTDIR/impact.csv.
//
// triaxial: N spheres of the demo's gradation and contact law (mu_s = 0.3, mu_r = 0.2),
//   consolidated to 200 kPa and re-equilibrated once (fraction 0.25, skin 1 mm); every setting
//   then shears a copy of that state along axis 1 to eps_1 = EPS with the lateral stresses held.
//   Curves q/p(eps_1) and eps_v(eps_1) are sampled every 0.0025 of eps_1 (linear interpolation
//   between series rows) and compared with a reference:
//     time step and skin settings (rate 0.5 /s):  the reference is fraction 0.025 (10x smaller);
//     strain rate, density scaling and combined settings: the reference is rate 0.05 /s (10x
//     slower).
//   Error = RMS over the samples of the difference; max of |difference| too. Run time = wall
//   seconds and CPU seconds of the shear stage alone. Writes OUTDIR/triaxial.csv (one row per setting) and
//   OUTDIR/triaxial_curves.csv (every sampled curve).
#include "apps/triaxial.hpp"
#include "core/timestep.hpp"
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

using clock_type = std::chrono::steady_clock;
double since(clock_type::time_point t0) { return std::chrono::duration<double>(clock_type::now() - t0).count(); }
// CPU seconds of this (single-threaded) process: less sensitive than wall time to other jobs
// sharing the cores (the machine this was written on had 2 cores for 5 users).
double cpu_seconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

// ---------------------------------------------------------------------------------------------
// Impact

struct ImpactResult {
  double contact_time = 0, rebound = 0, seconds = 0;
  long steps = 0;
};

// Two spheres approaching along x at v each; contact start and end located by linear
// interpolation of the gap between steps (as tests/unit/test_impact.cpp).
ImpactResult impact(double fraction, double beta) {
  const double R = 0.01, v = 0.1;
  Particles p;
  p.add({0, R, 2650, Vec3(0.5 - R - 1e-4, 0.5, 0.5), Vec3(v, 0, 0)});
  p.add({1, R, 2650, Vec3(0.5 + R + 1e-4, 0.5, 0.5), Vec3(-v, 0, 0)});
  SimulationParams sp;
  sp.law.youngs_modulus = 100e6;
  sp.law.friction = 0.3;
  sp.law.damping_ratio_n = beta;
  sp.dt = fraction * critical_time_step(p, sp.law, false);
  sp.skin = 0.2 * R;
  const auto t0 = clock_type::now();
  Simulation sim(std::move(p), PeriodicCell(Vec3::Constant(1.0)), sp);
  auto state = [&](double& gap, double& vrel) {
    const Particles& q = sim.particles();
    const std::size_t a = q.id[0] == 0 ? 0 : 1, b = 1 - a;
    gap = (q.x[b] - q.x[a]).norm() - 2 * R;
    vrel = (q.v[b] - q.v[a])[0];
  };
  double gap_prev, vrel, t_in = -1, t_out = -1;
  state(gap_prev, vrel);
  ImpactResult r;
  while (t_out < 0 && r.steps < 10000000) {
    sim.step();
    ++r.steps;
    double gap;
    state(gap, vrel);
    const double t = sim.time(), dt = sim.params().dt;
    if (t_in < 0 && gap < 0) t_in = t - dt * gap / (gap - gap_prev);
    if (t_in >= 0 && gap >= 0) t_out = t - dt * gap / (gap - gap_prev);
    gap_prev = gap;
  }
  for (int k = 0; k < 3; ++k) sim.step();  // free flight: the velocity after the contact
  state(gap_prev, vrel);
  r.seconds = since(t0);
  r.contact_time = t_out - t_in;
  r.rebound = vrel / (2 * v);
  return r;
}

// Restitution of the clamped linear dashpot (docs/verification.md section 2).
double restitution(double beta, double w0) {
  const double z = beta * w0, wd = w0 * std::sqrt(1 - beta * beta);
  const double ts = (std::numbers::pi - std::atan(2 * z * wd / (w0 * w0 - 2 * z * z))) / wd;
  return std::exp(-z * ts) * (-std::cos(wd * ts) + (z / wd) * std::sin(wd * ts));
}

int run_impact(const std::string& out) {
  const double R = 0.01, m = 2650 * 4.0 / 3.0 * std::numbers::pi * R * R * R, meff = m / 2;
  const double kn = std::numbers::pi * R * R * 100e6 / (2 * R);
  const double T = std::numbers::pi * std::sqrt(meff / kn), w0 = std::sqrt(kn / meff);
  const double e02 = restitution(0.2, w0);
  std::ofstream f(out + "/impact.csv");
  f << "case,fraction,steps_per_contact,contact_time_error,rebound_error,seconds\n";
  std::printf("%-8s %8s %8s %14s %14s %10s\n", "case", "fraction", "steps/T", "T error", "v_out error", "seconds");
  for (double frac : {0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0}) {
    for (int viscous = 0; viscous < 2; ++viscous) {
      const ImpactResult r = impact(frac, viscous ? 0.2 : 0.0);
      const double steps_per_T = T / (frac * std::sqrt(m / kn));
      // Elastic: contact time and rebound against T and 1. Viscous: restitution against e(0.2)
      // (its contact ends when the force does, not at zero overlap: no contact-time error).
      const double terr = viscous ? NAN : (r.contact_time - T) / T;
      const double verr = viscous ? (r.rebound - e02) / e02 : r.rebound - 1.0;
      const char* name = viscous ? "viscous" : "elastic";
      f << name << ',' << frac << ',' << steps_per_T << ',' << terr << ',' << verr << ',' << r.seconds << '\n';
      std::printf("%-8s %8.3f %8.1f %14.3e %14.3e %10.2e\n", name, frac, steps_per_T, terr, verr, r.seconds);
    }
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// Triaxial

std::string scene_text(int n, double eps) {
  std::ostringstream s;
  s << "[particles]\ncount = " << n
    << "\nfractal_dimension = 1.9\nd_min = 0.010\nd_max = 0.060\nseed = 2021\n"
       "solid_fraction = 0.30\naspect = [2.0, 1.0, 1.0]\ndensity = 2650.0\n"
       "[contact]\nyoungs_modulus = 100e6\nstiffness_ratio = 1.0\nfriction = 0.3\n"
       "rolling_friction = 0.2\n"
       "[run]\ntime_step_fraction = 0.25\nskin = 0.001\noutput_every = 1000\n"
       "[triaxial]\nconfining_pressure = 200e3\nconsolidation_friction = 1.0\nservo_gain = 12.0\n"
       "servo_integral_gain = 4000.0\nmax_strain_rate = 1.0\naxial_strain_rate = 0.5\n"
       "axial_strain = "
    << eps << "\n";
  return s.str();
}

struct Setting {
  std::string family;  // dt, skin, rate, density
  double fraction = 0.25, skin = 0.001, rate = 0.5, density_scaling = 1.0;
  std::string label() const {
    char b[128];
    std::snprintf(b, sizeof b, "%s f=%g skin=%g rate=%g ds=%g", family.c_str(), fraction, skin, rate, density_scaling);
    return b;
  }
};

struct Curve {
  std::vector<double> qp, epsv;  // at eps1 = (k + 1) * kDe
};
constexpr double kDe = 0.0025;

struct ShearResult {
  Curve curve;
  double seconds = 0, cpu = 0, dt = 0, inertial = 0;
  long steps = 0;
  std::int64_t rebuilds = 0;
};

// Linear interpolation of (eps1, q/p, eps_v) rows of the series text at the sample points.
Curve sample(const std::string& series, double eps_max) {
  std::istringstream in(series);
  std::string line;
  std::vector<double> e1, qp, ev;
  while (std::getline(in, line)) {
    std::vector<std::string> c;
    std::stringstream ls(line);
    std::string cell;
    while (std::getline(ls, cell, ',')) c.push_back(cell);
    if (c.size() < 16 || c[0] != "shear") continue;
    e1.push_back(std::stod(c[3]));  // stage,step,time,eps1,eps2,eps3,epsv,...,q_p (column 15)
    ev.push_back(std::stod(c[6]));
    qp.push_back(std::stod(c[15]));
  }
  Curve r;
  for (double x = kDe; x <= eps_max + 1e-12; x += kDe) {
    std::size_t k = 1;
    while (k + 1 < e1.size() && e1[k] < x) ++k;
    if (e1.size() < 2) break;
    const double w = (x - e1[k - 1]) / (e1[k] - e1[k - 1]);
    r.qp.push_back(qp[k - 1] + w * (qp[k] - qp[k - 1]));
    r.epsv.push_back(ev[k - 1] + w * (ev[k] - ev[k - 1]));
  }
  return r;
}

ShearResult shear(const Scene& base, const Simulation& equilibrated, const TriaxialRun& parent, double d_mean,
                  double density, const Setting& s, double eps_max) {
  Scene sc = base;
  sc.triaxial.axial_strain_rate = s.rate;
  Simulation sim(equilibrated, nullptr);
  if (s.density_scaling != 1.0) sim.particles().scale_density(s.density_scaling);
  const double crit = critical_time_step(sim.particles(), sim.params().law, false);
  sim.set_time_step(s.fraction * crit);
  if (s.skin != sim.params().skin) sim.set_skin(s.skin);
  // A row about every kDe / 4 of strain.
  sc.output_every = std::max<std::int64_t>(1, std::llround(kDe / 4 / (s.rate * sim.params().dt)));
  std::ostringstream series;
  const std::int64_t rb0 = sim.rebuild_count();
  TriaxialRun run(sc, sim, d_mean, density * s.density_scaling, &series, nullptr, &parent);
  const auto t0 = clock_type::now();
  const double c0 = cpu_seconds();
  const StageResult r = run.shear(sim.params().law.rolling_friction);
  ShearResult out;
  out.seconds = since(t0);
  out.cpu = cpu_seconds() - c0;
  out.steps = long(r.steps);
  out.dt = sim.params().dt;
  out.rebuilds = sim.rebuild_count() - rb0;
  out.inertial = s.rate * d_mean * std::sqrt(density * s.density_scaling / r.state.p);
  out.curve = sample(series.str(), eps_max);
  return out;
}

void errors(const Curve& a, const Curve& ref, double& rms_qp, double& max_qp, double& rms_ev, double& max_ev) {
  rms_qp = max_qp = rms_ev = max_ev = 0;
  const std::size_t n = std::min(a.qp.size(), ref.qp.size());
  for (std::size_t k = 0; k < n; ++k) {
    const double dq = a.qp[k] - ref.qp[k], dv = a.epsv[k] - ref.epsv[k];
    rms_qp += dq * dq, rms_ev += dv * dv;
    max_qp = std::max(max_qp, std::abs(dq)), max_ev = std::max(max_ev, std::abs(dv));
  }
  rms_qp = std::sqrt(rms_qp / double(n)), rms_ev = std::sqrt(rms_ev / double(n));
}

int run_triaxial(const std::string& out, int n, double eps) {
  const Scene scene = parse_scene(scene_text(n, eps), "<bench_accuracy triaxial>");
  Setup s = make_setup(scene);
  real_t dsum = 0, msum = 0, vsum = 0;
  for (std::size_t a = 0; a < s.particles.n_owned(); ++a) {
    const real_t R = s.particles.radius[a];
    dsum += 2 * R, msum += s.particles.mass[a], vsum += 4.0 / 3.0 * std::numbers::pi * R * R * R;
  }
  const double d_mean = dsum / double(s.particles.n_owned()), density = msum / vsum;
  auto t0 = clock_type::now();
  Simulation sim(std::move(s.particles), s.cell, s.params);
  TriaxialRun prep(scene, sim, d_mean, density, nullptr, nullptr);
  const StageResult c = prep.consolidate();
  const StageResult e = prep.equilibrate(scene.law.rolling_friction);
  std::printf(
      "triaxial: %d spheres, consolidated (%lld steps) and equilibrated (%lld steps) in "
      "%.1f s: p = %.1f kPa, void ratio %.4f, time step %.3e s\n",
      n, (long long)c.steps, (long long)e.steps, since(t0), e.state.p / 1e3, e.state.void_ratio, sim.params().dt);
  std::fflush(stdout);

  std::vector<Setting> settings;
  auto add = [&](const char* fam, double f, double skin, double rate, double ds) {
    settings.push_back({fam, f, skin, rate, ds});
  };
  add("ref_dt", 0.025, 0.001, 0.5, 1);    // reference of the dt and skin families
  add("ref_rate", 0.25, 0.001, 0.05, 1);  // reference of the rate and density families
  for (double f : {0.05, 0.1, 0.25, 0.5, 0.75, 1.0}) add("dt", f, 0.001, 0.5, 1);
  for (double sk : {0.0002, 0.0005, 0.002, 0.004}) add("skin", 0.25, sk, 0.5, 1);
  for (double r : {0.1, 0.25, 0.5, 1.0, 2.0, 5.0}) add("rate", 0.25, 0.001, r, 1);
  for (double ds : {4.0, 16.0, 100.0}) add("density", 0.25, 0.001, 0.5, ds);
  // Spending the time saved by a larger step on a lower rate (same cost as the defaults).
  add("combo", 0.5, 0.001, 0.25, 1);
  add("combo", 0.5, 0.002, 0.25, 1);

  std::ofstream rows(out + "/triaxial.csv"), curves(out + "/triaxial_curves.csv");
  rows << "family,fraction,skin,rate,density_scaling,dt,steps,rebuilds,inertial_number,seconds,"
          "cpu_seconds,rms_qp,max_qp,rms_epsv,max_epsv,reference\n";
  curves << "family,fraction,skin,rate,density_scaling,eps1,q_p,eps_v\n";
  Curve ref_dt, ref_rate;
  std::printf("%-42s %9s %8s %6s %9s %8s %8s %9s %9s %9s %9s\n", "setting", "dt_s", "steps", "rebld", "I", "seconds",
              "cpu_s", "rms_qp", "max_qp", "rms_epsv", "max_epsv");
  for (const Setting& st : settings) {
    const ShearResult r = shear(scene, sim, prep, d_mean, density, st, eps);
    const bool rate_family =
        st.family == "rate" || st.family == "density" || st.family == "combo" || st.family == "ref_rate";
    if (st.family == "ref_dt") ref_dt = r.curve;
    if (st.family == "ref_rate") ref_rate = r.curve;
    const Curve& ref = rate_family ? ref_rate : ref_dt;
    double rq, mq, rv, mv;
    errors(r.curve, ref, rq, mq, rv, mv);
    rows << st.family << ',' << st.fraction << ',' << st.skin << ',' << st.rate << ',' << st.density_scaling << ','
         << r.dt << ',' << r.steps << ',' << r.rebuilds << ',' << r.inertial << ',' << r.seconds << ',' << r.cpu << ','
         << rq << ',' << mq << ',' << rv << ',' << mv << ',' << (rate_family ? "ref_rate" : "ref_dt") << '\n';
    for (std::size_t k = 0; k < r.curve.qp.size(); ++k)
      curves << st.family << ',' << st.fraction << ',' << st.skin << ',' << st.rate << ',' << st.density_scaling << ','
             << (k + 1) * kDe << ',' << r.curve.qp[k] << ',' << r.curve.epsv[k] << '\n';
    std::printf("%-42s %9.3e %8ld %6lld %9.2e %8.2f %8.2f %9.2e %9.2e %9.2e %9.2e\n", st.label().c_str(), r.dt, r.steps,
                (long long)r.rebuilds, r.inertial, r.seconds, r.cpu, rq, mq, rv, mv);
    std::fflush(stdout);
    rows.flush();
    curves.flush();
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_accuracy impact|triaxial OUTDIR [N=500] [EPS=0.1]\n");
    return 2;
  }
  const std::string what = argv[1], out = argv[2];
  try {
    if (what == "impact") return run_impact(out);
    if (what == "triaxial")
      return run_triaxial(out, argc > 3 ? std::atoi(argv[3]) : 500, argc > 4 ? std::atof(argv[4]) : 0.1);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_accuracy: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "bench_accuracy: unknown mode '%s'\n", what.c_str());
  return 2;
}
