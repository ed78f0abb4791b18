// Wall-clock seconds spent in each phase of Simulation::step(), for the benchmarks: off by
// default, when each lap costs one predictable branch.
#pragma once
#include <chrono>
#include <cstdint>

namespace fabrica {

struct PhaseTimes {
  double integrate = 0;  // both half-kicks and the drift
  double ghost = 0;      // forward ghost update
  double check = 0;      // needs_rebuild() (one allreduce of the largest displacement)
  double rebuild = 0;    // rebuild(), when triggered, without its communication:
  double migrate = 0;    //   migration of particles and history, and the ghost rebuild
  double force = 0;      // contact forces (and local damping)
  double reduce = 0;     // reduction of the measures (measuring steps only)
  std::int64_t steps = 0;
};

class PhaseTimer {
 public:
  using clock = std::chrono::steady_clock;

  // On or off; either way the sums start again from zero.
  void enable(bool on) {
    on_ = on;
    times_ = PhaseTimes{};
  }
  const PhaseTimes& times() const { return times_; }

  // The laps of one step: start() at its beginning, lap(field) at the end of each phase adds
  // the time since the previous lap to that field, end_step() counts the step.
  void start() {
    if (on_) last_ = clock::now();
  }
  void lap(double PhaseTimes::*field) {
    if (!on_) return;
    const clock::time_point now = clock::now();
    times_.*field += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }
  void end_step() { times_.steps += on_; }

  // Inside a rebuild: its communication time, the seconds of [t0, t1) and of [t2, now), noted
  // apart; the lap of the rebuild moves it from 'rebuild' to 'migrate'.
  clock::time_point now() const { return on_ ? clock::now() : clock::time_point{}; }
  void note_communication(clock::time_point t0, clock::time_point t1, clock::time_point t2) {
    if (on_)
      communication_ =
          std::chrono::duration<double>(t1 - t0).count() + std::chrono::duration<double>(clock::now() - t2).count();
  }
  void lap_rebuild() {
    lap(&PhaseTimes::rebuild);
    times_.rebuild -= communication_;
    times_.migrate += communication_;
  }

 private:
  bool on_ = false;
  PhaseTimes times_;
  clock::time_point last_;
  double communication_ = 0;  // of the last rebuild
};

}  // namespace fabrica
