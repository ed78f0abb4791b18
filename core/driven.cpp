#include "core/driven.hpp"

namespace fabrica {

void DrivenMembers::find(const Particles& p, const std::vector<DrivenSet>& sets) {
  members_.clear();
  if (sets.empty()) return;
  for (std::size_t a = 0; a < p.n_owned(); ++a)
    for (std::size_t k = 0; k < sets.size(); ++k)
      if (sets[k].contains(p.id[a])) {
        members_.emplace_back(Index(a), std::int32_t(k));
        break;
      }
}

real_t DrivenMembers::impose(Particles& p, const std::vector<DrivenSet>& sets, real_t dt_half) const {
  real_t work = 0;
  for (const auto& [a, k] : members_) {
    const DrivenSet& d = sets[std::size_t(k)];
    work -= (p.f[a].dot(d.velocity) + p.t[a].dot(d.spin)) * dt_half;
    p.v[a] = d.velocity;
    p.w[a] = d.spin;
  }
  return work;
}

}  // namespace fabrica
