// The parameters of a contact law: which model, its elastic constants, friction, rolling
// resistance and dashpots. Units: SI. The models that read them are in this folder
// (linear_rolling.hpp, hertz_mindlin.hpp), listed in models.hpp; docs/scene.md gives the keys.
#pragma once
#include "core/types.hpp"

#include <cstdint>
#include <type_traits>

namespace fabrica {

// The normal (and with it the tangential) force model. The numbers are those written to
// checkpoints (law.model): never renumber one, add new models at the end.
enum class ContactModel : std::uint8_t { Linear = 0, HertzMindlin = 1 };

enum class NormalStiffnessMode { Deformability, Direct };

// The rolling resistance model (core/contact/rolling.hpp); numbers as written to checkpoints
// (law.rolling_model).
enum class RollingModel : std::uint8_t { ElasticPlastic = 0, Epsd = 1, ConstantTorque = 2 };

struct ContactLawParams {
  ContactModel model = ContactModel::Linear;
  NormalStiffnessMode stiffness_mode = NormalStiffnessMode::Deformability;  // linear only
  real_t youngs_modulus = 100e6;   // E [Pa]: linear (deformability mode) and Hertz-Mindlin
  real_t poisson_ratio = 0.25;     // nu [-], Hertz-Mindlin only
  real_t normal_stiffness = 0.0;   // k_n [N/m], linear, direct mode
  real_t stiffness_ratio = 1.0;    // kappa = k_n / k_s [-], linear only
  real_t friction = 0.3;           // mu_s [-]
  real_t rolling_friction = 0.0;   // mu_r [-]
  RollingModel rolling_model = RollingModel::ElasticPlastic;
  real_t rolling_damping = 0.0;    // eta_r [-], the epsd model's rolling dashpot (of its critical)
  // Dashpots. Linear: beta is the critical damping ratio, c = 2 beta sqrt(m_eff k).
  // Hertz-Mindlin: beta is Tsuji's coefficient, c = 2 sqrt(5/6) beta sqrt(m_eff S) with S the
  // tangent stiffness of the contact (hertz_mindlin.hpp).
  real_t damping_ratio_n = 0.0;    // beta_n [-]
  real_t damping_ratio_s = 0.0;    // beta_s [-]
  real_t damping_rate_n = 0.0;     // eta_n [1/s], c_n = eta_n m_eff (linear only)
  real_t damping_rate_s = 0.0;     // eta_s [1/s] (linear only)

  bool rolling() const { return rolling_friction > 0.0; }
  bool viscous() const {
    return damping_ratio_n > 0 || damping_ratio_s > 0 || damping_rate_n > 0 || damping_rate_s > 0 ||
           (rolling_damping > 0 && rolling_model == RollingModel::Epsd);
  }
};

// The name a scene file gives a model ([contact] model, rolling_model).
inline const char* model_name(ContactModel m) {
  return m == ContactModel::HertzMindlin ? "hertz_mindlin" : "linear";
}
inline const char* rolling_model_name(RollingModel m) {
  return m == RollingModel::Epsd ? "epsd" : m == RollingModel::ConstantTorque ? "constant_torque" : "elastic_plastic";
}

// The law's fields, listed once for every record of it: the checkpoint (io/state_fields.cpp)
// and the HDF5 scene record. 'io' takes field(name, value) (FieldWriter or FieldReader, or any
// visitor); 'l' is const for writing. Fields are never removed or reordered (the checkpoint
// format); law.model, law.poisson_ratio, law.rolling_model and law.rolling_damping came with
// format 8 and come last.
// 'with_model(io)' tells whether the list goes on with law.model after the first ten (a reader
// of an older file: false).
template <class Io, class Law, class WithModel>
void law_fields(Io& io, Law& l, WithModel with_model) {
  std::uint8_t direct = l.stiffness_mode == NormalStiffnessMode::Direct ? 1 : 0;
  io.field("law.stiffness_mode", direct);
  if constexpr (!std::is_const_v<Law>)
    l.stiffness_mode = direct ? NormalStiffnessMode::Direct : NormalStiffnessMode::Deformability;
  io.field("law.youngs_modulus", l.youngs_modulus);
  io.field("law.normal_stiffness", l.normal_stiffness);
  io.field("law.stiffness_ratio", l.stiffness_ratio);
  io.field("law.friction", l.friction);
  io.field("law.rolling_friction", l.rolling_friction);
  io.field("law.damping_ratio_n", l.damping_ratio_n);
  io.field("law.damping_ratio_s", l.damping_ratio_s);
  io.field("law.damping_rate_n", l.damping_rate_n);
  io.field("law.damping_rate_s", l.damping_rate_s);
  if (!with_model(io)) return;
  std::uint8_t model = std::uint8_t(l.model);
  io.field("law.model", model);
  if constexpr (!std::is_const_v<Law>) l.model = ContactModel(model);
  io.field("law.poisson_ratio", l.poisson_ratio);
  std::uint8_t rolling = std::uint8_t(l.rolling_model);
  io.field("law.rolling_model", rolling);
  if constexpr (!std::is_const_v<Law>) l.rolling_model = RollingModel(rolling);
  io.field("law.rolling_damping", l.rolling_damping);
}
template <class Io, class Law>
void law_fields(Io& io, Law& l) {
  law_fields(io, l, [](const Io&) { return true; });
}

}  // namespace fabrica
