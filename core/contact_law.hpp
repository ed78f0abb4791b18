// The contact laws: their parameters (contact/params.hpp), the lane types they share
// (contact/lanes.hpp), the materials and their mixing (contact/materials.hpp) and the models (contact/models.hpp: the linear law with rolling
// resistance, Hertz-Mindlin).
#pragma once
#include "core/contact/lanes.hpp"
#include "core/contact/materials.hpp"
#include "core/contact/models.hpp"
#include "core/contact/params.hpp"
