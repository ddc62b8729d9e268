#include "runout/engine/kernels.hpp"

#include <stdexcept>

namespace runout {

KernelKind kernel_from_name(std::string_view name) {
  if (name == "wendland" || name == "wendland-c2") return KernelKind::wendland;
  if (name == "cubic" || name == "cubic-spline") return KernelKind::cubic;
  throw std::invalid_argument("unknown kernel '" + std::string(name) + "' (accepted: wendland, cubic)");
}

std::string_view kernel_name(KernelKind kind) {
  return kind == KernelKind::cubic ? "cubic" : "wendland";
}

std::vector<std::string> kernel_names() { return {"wendland", "cubic"}; }

}  // namespace runout
