// [parallel] balance = "count": a particle weighs its work over the last list, 1 + the list
// pairs it is in (the force loop's work, counted).
#include "parallel/balance_policy.hpp"

namespace fabrica {

namespace {
class CountBalance final : public BalancePolicy {
 public:
  bool timed() const override { return false; }
  std::vector<std::int64_t> weigh(const std::vector<std::int32_t>& work, double) const override {
    return {work.begin(), work.end()};
  }
};
}  // namespace

std::shared_ptr<const BalancePolicy> make_count_balance() { return std::make_shared<CountBalance>(); }

}  // namespace fabrica
