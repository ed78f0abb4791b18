// The parameters of a contact law: which model, its elastic constants, friction, rolling
// resistance and dashpots. Units: SI. The models that read them are in this folder
// (linear_rolling.hpp, hertz_mindlin.hpp), listed in models.hpp; docs/scene.md gives the keys.
#pragma once
#include "core/types.hpp"

#include <array>
#include <cstdint>
#include <iterator>
#include <optional>
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
  real_t youngs_modulus = 100e6;  // E [Pa]: linear (deformability mode) and Hertz-Mindlin
  real_t poisson_ratio = 0.25;    // nu [-], Hertz-Mindlin only
  real_t normal_stiffness = 0.0;  // k_n [N/m], linear, direct mode
  real_t stiffness_ratio = 1.0;   // kappa = k_n / k_s [-], linear only
  real_t friction = 0.3;          // mu_s [-]
  real_t rolling_friction = 0.0;  // mu_r [-]
  RollingModel rolling_model = RollingModel::ElasticPlastic;
  real_t rolling_damping = 0.0;    // eta_r [-], the epsd model's rolling dashpot (of its critical)
  real_t twisting_friction = 0.0;  // mu_t [-], the twisting spring-slider (rolling.hpp); 0: none
  // Dashpots. Linear: beta is the critical damping ratio, c = 2 beta sqrt(m_eff k).
  // Hertz-Mindlin: beta is Tsuji's coefficient, c = 2 sqrt(5/6) beta sqrt(m_eff S) with S the
  // tangent stiffness of the contact (hertz_mindlin.hpp).
  real_t damping_ratio_n = 0.0;  // beta_n [-]
  real_t damping_ratio_s = 0.0;  // beta_s [-]
  real_t damping_rate_n = 0.0;   // eta_n [1/s], c_n = eta_n m_eff (linear only)
  real_t damping_rate_s = 0.0;   // eta_s [1/s] (linear only)
  // Hertz-Mindlin between two materials (core/contact/materials.hpp): the pair's effective
  // moduli E*, G* [Pa], which no single (E, nu) gives; 0 for one material (E*, G* from E, nu).
  // Not scene keys: the mixing rule sets them.
  real_t pair_estar = 0.0;
  real_t pair_gstar = 0.0;

  bool rolling() const { return rolling_friction > 0.0; }
  bool twisting() const { return twisting_friction > 0.0; }
  bool viscous() const {
    return damping_ratio_n > 0 || damping_ratio_s > 0 || damping_rate_n > 0 || damping_rate_s > 0 ||
        (rolling_damping > 0 && rolling_model == RollingModel::Epsd);
  }
};

// The numbers of a law that differ between the contacts of a scene of several materials, lane by
// lane (core/forces.cpp's Mixed kernel: T = simd::d4, each lane its pair of materials' law),
// under ContactLawParams' names, so that a model's lane-generic code reads either. estar, gstar:
// Hertz-Mindlin's effective moduli of the lane's pair. The model, stiffness mode and rolling model
// are the scene's.
template <class T>
struct LawLanes {
  ContactModel model = ContactModel::Linear;
  NormalStiffnessMode stiffness_mode = NormalStiffnessMode::Deformability;
  RollingModel rolling_model = RollingModel::ElasticPlastic;
  T youngs_modulus{}, normal_stiffness{}, stiffness_ratio{}, friction{}, rolling_friction{}, twisting_friction{};
  T rolling_damping{}, damping_ratio_n{}, damping_ratio_s{}, damping_rate_n{}, damping_rate_s{}, estar{}, gstar{};
};

// The name a scene file gives a model ([contact] model, rolling_model).
inline const char* model_name(ContactModel m) { return m == ContactModel::HertzMindlin ? "hertz_mindlin" : "linear"; }
inline const char* rolling_model_name(RollingModel m) {
  return m == RollingModel::Epsd ? "epsd" : m == RollingModel::ConstantTorque ? "constant_torque" : "elastic_plastic";
}

// The law's parameters, declared once: the scene parsers ([contact], [[wall]], [[stage]]:
// io/serial/scene.cpp, io/serial/stage_parse.cpp), the checkpoint (io/mpi/state_fields.cpp) and the HDF5 scene
// record (io/mpi/run_output.cpp) all go through this list, and docs/scene.md lists every key of it
// with its unit (tests/io/test_scene.cpp checks). In the checkpoint's order: fields are never
// removed or reordered (the format); 'since' is the checkpoint format that added a field.
enum class LawValue : std::uint8_t { Real, StiffnessMode, Model, RollingModel };
// The check of a value read from a scene, with the words of its message.
enum class Bound : std::uint8_t { None, Positive, NonNegative, Fraction, Poisson };
// Which contact model takes a scene key (the other refuses it with the key and the model).
enum class ForModel : std::uint8_t { Any, Linear, HertzMindlin };

struct LawParameter {
  const char* field;  // its name in the checkpoint and the HDF5 record
  const char* key;    // the scene key (nullptr: not a scene number: the enums, read by name)
  const char* unit;
  LawValue value;
  real_t ContactLawParams::*member;  // a Real's place
  Bound bound;
  ForModel model;
  bool wall;   // a [[wall]] may replace it for its contacts
  bool stage;  // a [[stage]] may set it from its start
  int since;   // the checkpoint format that added it
  // The dashpot a damping ratio replaces when given (its rate form set to 0), or nullptr.
  real_t ContactLawParams::*clears = nullptr;
};

inline constexpr LawParameter kLawParameters[] = {
    // field, scene key, unit, kind, member; bound, model, [[wall]], [[stage]], since (, clears)
    {"law.stiffness_mode", nullptr, "-", LawValue::StiffnessMode, nullptr, Bound::None, ForModel::Linear, false, false,
     6},
    {"law.youngs_modulus", "youngs_modulus", "Pa", LawValue::Real, &ContactLawParams::youngs_modulus, Bound::Positive,
     ForModel::Any, true, false, 6},
    {"law.normal_stiffness", "normal_stiffness", "N/m", LawValue::Real, &ContactLawParams::normal_stiffness,
     Bound::Positive, ForModel::Linear, true, false, 6},
    {"law.stiffness_ratio", "stiffness_ratio", "-", LawValue::Real, &ContactLawParams::stiffness_ratio, Bound::Positive,
     ForModel::Linear, true, false, 6},
    {"law.friction", "friction", "-", LawValue::Real, &ContactLawParams::friction, Bound::NonNegative, ForModel::Any,
     true, true, 6},
    {"law.rolling_friction", "rolling_friction", "-", LawValue::Real, &ContactLawParams::rolling_friction,
     Bound::NonNegative, ForModel::Any, true, true, 6},
    {"law.damping_ratio_n", "damping_ratio_normal", "-", LawValue::Real, &ContactLawParams::damping_ratio_n,
     Bound::Fraction, ForModel::Any, true, true, 6, &ContactLawParams::damping_rate_n},
    {"law.damping_ratio_s", "damping_ratio_shear", "-", LawValue::Real, &ContactLawParams::damping_ratio_s,
     Bound::Fraction, ForModel::Any, true, true, 6, &ContactLawParams::damping_rate_s},
    {"law.damping_rate_n", "damping_rate_normal", "1/s", LawValue::Real, &ContactLawParams::damping_rate_n,
     Bound::NonNegative, ForModel::Linear, false, false, 6},
    {"law.damping_rate_s", "damping_rate_shear", "1/s", LawValue::Real, &ContactLawParams::damping_rate_s,
     Bound::NonNegative, ForModel::Linear, false, false, 6},
    {"law.model", nullptr, "-", LawValue::Model, nullptr, Bound::None, ForModel::Any, false, false, 8},
    {"law.poisson_ratio", "poisson_ratio", "-", LawValue::Real, &ContactLawParams::poisson_ratio, Bound::Poisson,
     ForModel::HertzMindlin, true, false, 8},
    {"law.rolling_model", nullptr, "-", LawValue::RollingModel, nullptr, Bound::None, ForModel::Any, false, false, 8},
    {"law.rolling_damping", "rolling_damping", "-", LawValue::Real, &ContactLawParams::rolling_damping, Bound::Fraction,
     ForModel::Any, false, false, 8},
    {"law.twisting_friction", "twisting_friction", "-", LawValue::Real, &ContactLawParams::twisting_friction,
     Bound::NonNegative, ForModel::Any, true, true, 9},
};

// Whether v passes the bound, and the words that say why not.
inline bool within(Bound b, real_t v) {
  switch (b) {
    case Bound::Positive:
      return v > 0;
    case Bound::NonNegative:
      return v >= 0;
    case Bound::Fraction:
      return v >= 0 && v < 1;
    case Bound::Poisson:
      return v > -1 && v < 0.5;
    case Bound::None:
      break;
  }
  return true;
}
inline const char* bound_text(Bound b) {
  switch (b) {
    case Bound::Positive:
      return "must be positive";
    case Bound::NonNegative:
      return "must be >= 0";
    case Bound::Fraction:
      return "must lie in [0, 1)";
    case Bound::Poisson:
      return "must lie in (-1, 0.5) (the Poisson ratio of an isotropic elastic solid)";
    case Bound::None:
      break;
  }
  return "";
}

// Some of a law's numbers given anew (a [[stage]]'s), by entry of kLawParameters.
struct LawChanges {
  std::array<std::optional<real_t>, std::size(kLawParameters)> value;

  static std::size_t index(real_t ContactLawParams::*m) {
    for (std::size_t k = 0; k < std::size(kLawParameters); ++k)
      if (kLawParameters[k].member == m) return k;
    return std::size(kLawParameters);  // not a number of the list: a programming error
  }
  void set(real_t ContactLawParams::*m, real_t v) { value.at(index(m)) = v; }
  std::optional<real_t> get(real_t ContactLawParams::*m) const { return value.at(index(m)); }
  bool any() const {
    for (const auto& v : value)
      if (v) return true;
    return false;
  }
  // The law with the changes: each given number replaces the law's (a damping ratio also sets
  // its rate form to 0).
  ContactLawParams applied_to(ContactLawParams law) const {
    for (std::size_t k = 0; k < value.size(); ++k) {
      if (!value[k] || !kLawParameters[k].member) continue;  // (the enums are not numbers)
      law.*kLawParameters[k].member = *value[k];
      if (kLawParameters[k].clears) law.*kLawParameters[k].clears = 0;
    }
    return law;
  }
};

// The law's fields in the list's order: io.field(name, value) for each (FieldWriter,
// FieldReader, or any visitor; 'l' const for writing; the enums as u8). 'more(io, name)' tells
// whether the list goes on with the first field of a later format (a reader of an older file:
// false, and the rest keeps its defaults).
template <class Io, class Law, class More>
void law_fields(Io& io, Law& l, More more) {
  int since = kLawParameters[0].since;
  for (const LawParameter& p : kLawParameters) {
    if (p.since != since) {
      since = p.since;
      if (!more(io, p.field)) return;
    }
    if (p.value == LawValue::Real) {
      io.field(p.field, l.*p.member);
      continue;
    }
    std::uint8_t v = p.value == LawValue::StiffnessMode ? (l.stiffness_mode == NormalStiffnessMode::Direct ? 1 : 0)
        : p.value == LawValue::Model                    ? std::uint8_t(l.model)
                                                        : std::uint8_t(l.rolling_model);
    io.field(p.field, v);
    if constexpr (!std::is_const_v<Law>) {
      if (p.value == LawValue::StiffnessMode)
        l.stiffness_mode = v ? NormalStiffnessMode::Direct : NormalStiffnessMode::Deformability;
      else if (p.value == LawValue::Model) l.model = ContactModel(v);
      else l.rolling_model = RollingModel(v);
    }
  }
}
template <class Io, class Law>
void law_fields(Io& io, Law& l) {
  law_fields(io, l, [](const Io&, const char*) { return true; });
}

}  // namespace fabrica
