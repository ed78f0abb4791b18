// Errors in user input. Every message names the file, the field (or line) and the value.
#pragma once
#include <stdexcept>
#include <string>

namespace fabrica {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace fabrica
