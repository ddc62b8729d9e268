#include "runout/scenarios/thread_share.hpp"

#include <algorithm>

namespace runout {

ThreadShare::ThreadShare(int cores) : cores_(std::max(1, cores)) {}

int ThreadShare::share() const {
  return std::max(1, cores_ / std::max(1, running_.load()));
}

}  // namespace runout
