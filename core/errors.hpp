// Errors in user input. Every message names the file, the field (or line) and the value.
#pragma once
#include <sstream>
#include <stdexcept>
#include <string>

namespace fabrica {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A value as the messages show it: 6 significant digits unless told.
inline std::string number_text(double v, int digits = 6) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace fabrica
