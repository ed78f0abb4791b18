// The domain of a run on one process (core/domain.hpp): no ghosts, no migration, and every
// reduction is the identity. It holds no state, so one instance can serve any number of
// simulations (serial_domain()).
#pragma once
#include "core/domain.hpp"

namespace fabrica {

class SerialDomain final : public Domain {
 public:
  SerialDomain() = default;
  SerialDomain(const SerialDomain&) = default;

  void begin_ghost_update(Particles& p, const GhostDrift* drift) override;
  void end_ghost_update(Particles& p) override;
  real_t max_all(real_t local) override;
  void max_all(std::span<double> values) override;
  void sum_all(std::span<double> values) override;
  void sum_all(std::span<std::int64_t> values) override;
  void adopt(Particles& p, const PeriodicCell& cell, real_t cutoff, const DecompositionRecord* decomposed_as = nullptr,
             Holding holding = Holding::Whole, HistoryMap* history = nullptr) override;
  DecompositionRecord decomposition_record() const override;
  void migrate(Particles& p, const PeriodicCell& cell, HistoryMap& history,
               const std::vector<std::int32_t>* work) override;
  void build_ghosts(Particles& p, const PeriodicCell& cell, real_t cutoff) override;
  std::unique_ptr<Domain> clone() const override;
  int rank() const override;
  int size() const override;
};

// The shared serial domain: what a Simulation built without a domain communicates through.
// Stateless, so a copy or a move of that Simulation keeps a valid domain.
SerialDomain& serial_domain();

}  // namespace fabrica
