// The list of contact models. A model is a type with the members of LinearRolling
// (linear_rolling.hpp): its per-pair constants Pair<T> and their lane-generic pair(), the
// scalar constants() (a wall when R2 is infinite), evaluate() (the law over lanes, rolling and
// twisting resistance and dashpots template switches), and the scalar state queries (forces,
// stiffnesses, dashpots, rolling limit, energies, the twisting spring's included). The kernels,
// records, servo and time step are templates over the model, instantiated for each one here:
// the per-contact loop has no virtual call and no branch on the model. Adding a model: its file
// in this folder, one 'case' below and in model_name / the scene parser's list (docs/design.md,
// "Adding a contact model").
#pragma once
#include "core/contact/hertz_mindlin.hpp"
#include "core/contact/linear_rolling.hpp"

namespace fabrica {

// Calls f(Model{}) with the model type of 'm'.
template <class F>
decltype(auto) with_model(ContactModel m, F&& f) {
  switch (m) {
    case ContactModel::HertzMindlin:
      return f(HertzMindlin{});
    case ContactModel::Linear:
      break;
  }
  return f(LinearRolling{});
}

}  // namespace fabrica
