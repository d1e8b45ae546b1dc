#include "command_registry.h"

#include <algorithm>

namespace ndsid::desk {
namespace {
std::vector<RegisteredCommand>& Registry() {
  static std::vector<RegisteredCommand> registry;
  return registry;
}
}  // namespace

int RegisterCommand(const char* name, CommandRegistrar registrar) {
  auto& r = Registry();
  r.push_back({name, registrar});
  std::sort(r.begin(), r.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return static_cast<int>(r.size());
}

const std::vector<RegisteredCommand>& Commands() { return Registry(); }

}  // namespace ndsid::desk
