// A state of a run that later runs branch from (the triaxial sweep's consolidated state, its
// common re-equilibration: apps/triaxial_sweep.hpp), with its lifetime explicit: it lives until
// its last branch, which takes the state over (moved: no second copy of the specimen in memory
// for the rest of the run nor in its checkpoints); every branch before it runs on a copy.
// release() ends the life without a branch. The Simulation object itself stays (emptied once
// spent), for those that hold a reference to it.
#pragma once
#include "core/domain.hpp"
#include "core/simulation.hpp"

#include <memory>
#include <utility>

namespace fabrica {

class BranchPoint {
 public:
  // A simulation and its domain (null on one rank): simulation.domain() is 'domain'.
  struct State {
    std::unique_ptr<Domain> domain;
    std::unique_ptr<Simulation> sim;
  };

  BranchPoint() = default;
  explicit BranchPoint(State s) : s_(std::move(s)), alive_(true) {}
  // A copy of 'sim' on a copy of its domain (null on one rank).
  BranchPoint(const Simulation& sim, const Domain* domain) : alive_(true) {
    s_.domain = domain ? domain->clone() : nullptr;
    s_.sim = std::make_unique<Simulation>(sim, s_.domain.get());
  }

  bool alive() const { return alive_; }
  Simulation& state() { return *s_.sim; }
  const Simulation& state() const { return *s_.sim; }
  const Domain* domain() const { return s_.domain.get(); }

  // A branch on a copy of the domain: a copy of the state or, when 'last', the state itself,
  // which ends this life.
  State branch(bool last) {
    State b;
    b.domain = s_.domain ? s_.domain->clone() : nullptr;
    if (last) {
      b.sim = std::make_unique<Simulation>(std::move(*s_.sim), b.domain.get());
      alive_ = false;
    } else {
      b.sim = std::make_unique<Simulation>(*s_.sim, b.domain.get());
    }
    return b;
  }
  // Ends the life without a branch: the state's memory goes now.
  void release() {
    if (alive_) { const Simulation released(std::move(*s_.sim), nullptr); }
    alive_ = false;
  }

 private:
  State s_;
  bool alive_ = false;
};

}  // namespace fabrica
