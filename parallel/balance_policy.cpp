#include "parallel/balance_policy.hpp"

#include <stdexcept>
#include <utility>

namespace fabrica {

// Each policy's maker, in its own file.
std::shared_ptr<const BalancePolicy> make_count_balance();  // parallel/balance_count.cpp
std::shared_ptr<const BalancePolicy> make_time_balance();   // parallel/balance_time.cpp

namespace {
using Maker = std::shared_ptr<const BalancePolicy> (*)();
// The policies by their name in the scene ([parallel] balance; io/serial/scene.cpp accepts
// the same names).
const std::pair<const char*, Maker> kPolicies[] = {{"count", make_count_balance}, {"time", make_time_balance}};
}  // namespace

std::shared_ptr<const BalancePolicy> make_balance_policy(const std::string& name) {
  for (const auto& [n, make] : kPolicies)
    if (name == n) return make();
  throw std::invalid_argument("no balance policy \"" + name + "\"");
}

}  // namespace fabrica
