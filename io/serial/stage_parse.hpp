// The [[stage]] tables of a scene (docs/scene.md, "[[stage]]"): read and checked, each error
// naming the file, the field (stage[2].control.axis_1, counted from 1) and the value.
#pragma once
#include "io/serial/stage_spec.hpp"

#include <toml++/toml.h>  // internal to io/ (toml++ is a private dependency of fabrica_io)

#include <string>
#include <vector>

namespace fabrica {

// 'stages' is the scene's "stage" entry (an array of tables), null when there is none.
std::vector<StageSpec> parse_stages(const toml::node* stages, const std::string& path);

}  // namespace fabrica
