#include "runout/engine/kernels.hpp"

namespace runout {

KernelKind kernel_from_name(std::string_view name) {
#define RUNOUT_KERNEL_PARSE(id, type) \
  if (name == type<2>::name || name == type<2>::alias) return KernelKind::id;
  RUNOUT_KERNELS(RUNOUT_KERNEL_PARSE)
#undef RUNOUT_KERNEL_PARSE
  std::string accepted;
  for (const auto& n : kernel_names()) accepted += (accepted.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown kernel '" + std::string(name) + "' (accepted: " + accepted + ")");
}

std::string_view kernel_name(KernelKind kind) {
  switch (kind) {
#define RUNOUT_KERNEL_NAME(id, type) \
  case KernelKind::id:               \
    return type<2>::name;
    RUNOUT_KERNELS(RUNOUT_KERNEL_NAME)
#undef RUNOUT_KERNEL_NAME
  }
  return "unknown";
}

std::vector<std::string> kernel_names() {
  return {
#define RUNOUT_KERNEL_LIST(id, type) std::string(type<2>::name),
      RUNOUT_KERNELS(RUNOUT_KERNEL_LIST)
#undef RUNOUT_KERNEL_LIST
  };
}

}  // namespace runout
