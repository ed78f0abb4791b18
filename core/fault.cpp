#include "core/fault.hpp"

#include <cstdlib>

namespace fabrica {
namespace {
int g_rank = 0;
}  // namespace

void set_fault_rank(int rank) { g_rank = rank; }

bool fault_injected(std::string_view site) {
  const char* env = std::getenv("FABRICA_FAULT_INJECT");
  if (!env || !*env) return false;
  const std::string_view all(env);
  std::size_t pos = 0;
  while (pos <= all.size()) {
    const std::size_t end = std::min(all.find(',', pos), all.size());
    const std::string_view item = all.substr(pos, end - pos);
    const std::size_t colon = item.find(':');
    if (colon != std::string_view::npos && item.substr(colon + 1) == site &&
        item.substr(0, colon) == std::to_string(g_rank))
      return true;
    pos = end + 1;
  }
  return false;
}

std::string fault_text(std::string_view site) {
  return "failure injected at site '" + std::string(site) + "' on rank " + std::to_string(g_rank) +
      " (FABRICA_FAULT_INJECT, a test hook)";
}

}  // namespace fabrica
