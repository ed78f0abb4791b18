// What a rank's load is weighed by, for the Cartesian runs of bins placed by the work
// ([parallel] balance, docs/scene.md). The rebalancer (parallel/rebalancer.hpp) decides when
// and where the runs move by these weights; MpiDomain moves the data. A policy is a file of its
// own that defines its maker, named once in the table of parallel/balance_policy.cpp.
//
// The weights never reach the trajectory: a run is the same bit for bit whatever the runs of
// bins (contacts across ranks are computed on both, identically), so a policy may weigh by
// what differs from run to run, such as measured time.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fabrica {

class BalancePolicy {
 public:
  virtual ~BalancePolicy() = default;
  // True when weigh() reads the force phase's seconds: the domain then asks the simulation for
  // them (Domain::wants_force_seconds).
  virtual bool timed() const = 0;
  // Each owned particle's weight, from its work over the last list (1 + the list pairs it is
  // in) and the seconds this rank spent in the force phase over that list (0 on every rank
  // when none was measured: no force phase since the last rebuild is the same on every rank).
  // Local, no communication; integers, so that their sums over the ranks are exact and every
  // rank takes the same decision from them.
  virtual std::vector<std::int64_t> weigh(const std::vector<std::int32_t>& work, double force_seconds) const = 0;
};

// The policy of a [parallel] balance name; std::invalid_argument for a name of none (the
// scene parser refuses those first).
std::shared_ptr<const BalancePolicy> make_balance_policy(const std::string& name);

}  // namespace fabrica
