#include "impl.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace runout {


// Guards: non-finite values, leaks through walls or closed domain faces. Also tracks the Mach number.
template <int D>
void Solver<D>::check_state() {
  const size_t n = fluid_.size();
  long bad = std::numeric_limits<long>::max();
  real vmax2 = 0;
#pragma omp parallel for reduction(min : bad) reduction(max : vmax2)
  for (size_t i = 0; i < n; ++i) {
    bool ok = std::isfinite(fluid_.rho[i]);
    real v2 = 0;
    for (int d = 0; d < D; ++d) {
      ok = ok && std::isfinite(fluid_.pos[d][i]) && std::isfinite(fluid_.vel[d][i]);
      v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    }
    if (!ok) bad = std::min(bad, static_cast<long>(i));
    vmax2 = std::max(vmax2, v2);
  }
  if (bad != std::numeric_limits<long>::max()) {
    const size_t i = static_cast<size_t>(bad);
    std::string what = !std::isfinite(fluid_.rho[i]) ? "density" : "velocity";
    for (int d = 0; d < D; ++d)
      if (!std::isfinite(fluid_.pos[d][i])) what = "position";
    std::ostringstream s;
    s << fmt_time(record_.time) << ": fluid particle " << fluid_.id[i] << " has a non-finite " << what << " (step "
      << record_.steps << ", dt " << record_.stats.dt << " s)";
    throw SimulationError(s.str(), SimulationError::Cause::non_finite);
  }
  record_.stats.max_speed = std::sqrt(vmax2);
  record_.max_mach = std::max(record_.max_mach, record_.stats.max_speed / config_.speed_of_sound);

  long leak = std::numeric_limits<long>::max();
  int leak_region = -1;
  // Leak regions with their axes worked out once, not per particle.
  struct Region {
    Vec<D> origin, size;
    std::array<Vec<D>, D> axis;
    bool contains(const Vec<D>& p) const {
      const Vec<D> r = p - origin;
      for (int d = 0; d < D; ++d) {
        const real l = r.dot(axis[d]);
        if (l < 0.0 || l > size[d]) return false;
      }
      return true;
    }
  };
  std::vector<Region> regions;
  for (const auto& r : leak_regions_) {
    Region q{r.box.origin, r.box.size, {}};
    for (int d = 0; d < D; ++d) q.axis[d] = r.box.axis(d);
    regions.push_back(q);
  }
  size_t leaked = 0;
#pragma omp parallel for reduction(min : leak) reduction(+ : leaked)
  for (size_t i = 0; i < n; ++i) {
    if (is_inlet_buffer(fluid_.tag[i])) continue;  // moved by their inlet, checked when it is built
    const Vec<D> p = fluid_.position(i);
    bool out = false;
    for (int d = 0; d < D; ++d) {
      if (config_.periodic[d] || d == D - 1) continue;  // the vertical top is open; the bottom is a wall
      out = out || (p[d] < config_.domain_min[d] && !config_.outflow[d][0]) ||
            (p[d] > config_.domain_max[d] && !config_.outflow[d][1]);
    }
    out = out || (!config_.periodic[D - 1] && p[D - 1] < config_.domain_min[D - 1] && !config_.outflow[D - 1][0]);
    for (const auto& r : regions) out = out || r.contains(p);
    if (out) {
      leak = std::min(leak, static_cast<long>(i));
      ++leaked;
    }
  }
  if (leak != std::numeric_limits<long>::max()) {
    const size_t i = static_cast<size_t>(leak);
    const Vec<D> p = fluid_.position(i);
    for (size_t k = 0; k < leak_regions_.size(); ++k)
      if (leak_regions_[k].contains(p)) leak_region = static_cast<int>(k);
    std::ostringstream s;
    s << fmt_time(record_.time) << ": fluid particle " << fluid_.id[i] << " leaked through ";
    if (leak_region >= 0)
      s << "boundary tag " << leak_regions_[leak_region].tag;
    else
      s << "a closed domain face";
    s << " at position (";
    for (int d = 0; d < D; ++d) s << (d ? ", " : "") << p[d];
    s << ") m";
    if (leaked > 1) s << " (" << leaked << " particles in all)";
    throw SimulationError(s.str(), SimulationError::Cause::leak, leaked);
  }
}

template void Solver<2>::check_state();
template void Solver<3>::check_state();

}  // namespace runout
