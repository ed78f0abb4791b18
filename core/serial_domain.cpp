#include "core/serial_domain.hpp"

namespace fabrica {

// One process holds every particle: there is nothing to exchange, and a reduction over one
// rank is the value itself.
void SerialDomain::begin_ghost_update(Particles&, const GhostDrift*) {}
void SerialDomain::end_ghost_update(Particles&) {}
real_t SerialDomain::max_all(real_t local) { return local; }
void SerialDomain::max_all(std::span<double>) {}
void SerialDomain::sum_all(std::span<double>) {}
void SerialDomain::sum_all(std::span<std::int64_t>) {}
void SerialDomain::adopt(Particles&, const PeriodicCell&, real_t, const DecompositionRecord*, Holding, HistoryMap*) {}
DecompositionRecord SerialDomain::decomposition_record() const { return {}; }
void SerialDomain::migrate(Particles&, const PeriodicCell&, HistoryMap&, const std::vector<std::int32_t>*) {}
void SerialDomain::build_ghosts(Particles&, const PeriodicCell&, real_t) {}
std::unique_ptr<Domain> SerialDomain::clone() const { return std::make_unique<SerialDomain>(); }
int SerialDomain::rank() const { return 0; }
int SerialDomain::size() const { return 1; }

SerialDomain& serial_domain() {
  static SerialDomain d;  // no state: shared by every serial Simulation, on any thread
  return d;
}

}  // namespace fabrica
