// [parallel] balance = "time": ranks weighed by their measured force-phase time, as LAMMPS'
// `balance ... weight time`. A rank's seconds in the force phase over the last list are shared
// among its particles by their counted work (1 + list pairs), in nanoseconds: a particle on a
// rank that computes slower (a slower core, a busier node, a worse cache) weighs more than one
// with the same pairs on a faster rank. The weights differ from run to run; the trajectory
// does not (balance_policy.hpp).
#include "parallel/balance_policy.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace fabrica {

namespace {
class TimeBalance final : public BalancePolicy {
 public:
  bool timed() const override { return true; }
  std::vector<std::int64_t> weigh(const std::vector<std::int32_t>& work, double force_seconds) const override {
    std::vector<std::int64_t> w(work.begin(), work.end());
    const std::int64_t total = std::accumulate(w.begin(), w.end(), std::int64_t(0));
    if (force_seconds <= 0 || total == 0) return w;  // nothing measured (on every rank): the count
    const double ns_per_unit = force_seconds * 1e9 / double(total);
    for (std::size_t a = 0; a < w.size(); ++a)
      w[a] = std::max<std::int64_t>(1, std::llround(double(work[a]) * ns_per_unit));
    return w;
  }
};
}  // namespace

std::shared_ptr<const BalancePolicy> make_time_balance() { return std::make_shared<TimeBalance>(); }

}  // namespace fabrica
