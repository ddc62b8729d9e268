#include "impl.hpp"
#include "runout/engine/eos.hpp"
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace runout {

// Inlets ------------------------------------------------------------------------------------------------

int inlet_buffer_layers(const SolverConfig& c) {
  return static_cast<int>(std::ceil(2 * c.smoothing_length / c.dp - 1e-9)) + 1;
}

template <int D>
real InletSpec<D>::speed_at(real t) const {
  if (speed.empty()) return 0;
  if (t <= speed.front()[0]) return speed.front()[1];
  for (size_t k = 1; k < speed.size(); ++k)
    if (t < speed[k][0]) {
      const auto& a = speed[k - 1];
      const auto& b = speed[k];
      return a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0]);
    }
  return speed.back()[1];
}

template <int D>
size_t InletSpec<D>::lane_of(const Vec<D>& p, real dp) const {
  if constexpr (D == 2) {
    return 0;
  } else {
    const real l = std::floor((p - origin).dot(across) / dp);
    return static_cast<size_t>(std::clamp<real>(l, 0, static_cast<real>(lanes()) - 1));
  }
}

template <int D>
int InletSpec<D>::layers_in_depth(real dp) const {
  return static_cast<int>(std::floor(depth / dp + 1e-9));
}

template <int D>
real InletSpec<D>::opening_area(real dp) const {
  const real height = layers_in_depth(dp) * dp;
  return D == 2 ? height : static_cast<real>(lanes()) * dp * height;
}

template <int D>
real Solver<D>::inlet_density(const InletSpec<D>& in, const Vec<D>& p) const {
  // Hydrostatic below the opening's top (the inflow's free surface), inverted through Tait.
  const TaitEOS eos(config_.speed_of_sound, materials_[in.material].density, config_.eos_gamma);
  const real g = std::abs(config_.gravity[D - 1]);
  const real top = in.floor_at(in.lane_of(p, config_.dp), in.along(p)) + in.depth;
  return eos.density(eos.rho0 * g * std::max(real(0), top - p[D - 1]));
}

template <int D>
bool Solver<D>::in_inlet_buffer(const Vec<D>& p) const {
  const real dp = config_.dp;
  const real length = inlet_buffer_layers(config_) * dp;
  for (const auto& in : inlets_) {
    const real s = in.along(p);
    // Half a spacing of slack: a particle that just crossed may jitter back a little.
    if (-s < 0.5 * dp || -s > length) continue;
    if constexpr (D == 3) {
      const real l = (p - in.origin).dot(in.across);
      if (l < 0 || l > in.lanes() * dp) continue;
    }
    // Over the opening at any height: flow that piles up and spills back over the buffer leaves there too
    // (the inlet is the domain's upstream end).
    if (p[D - 1] >= in.floor_at(in.lane_of(p, dp), s) - 0.5 * dp) return true;
  }
  return false;
}

namespace {
template <int D>
void check_inlet(const InletSpec<D>& in, size_t materials, real dp) {
  const std::string what = "inlet '" + in.name + "'";
  if (std::abs(in.normal.norm() - 1) > 1e-9 || in.normal[D - 1] != 0)
    throw std::invalid_argument(what + ": the normal must be a horizontal unit vector");
  if (D == 3 && (std::abs(in.across.norm() - 1) > 1e-9 || in.across[D - 1] != 0 ||
                 std::abs(in.across.dot(in.normal)) > 1e-9))
    throw std::invalid_argument(what + ": `across` must be a horizontal unit vector normal to the flow");
  if (in.floor.empty() || (D == 2 && in.floor.size() != 1) || in.slope.size() != in.floor.size())
    throw std::invalid_argument(what + ": one floor height and slope per lane (one lane in 2D)");
  for (size_t k = 0; k < in.floor.size(); ++k)
    if (!std::isfinite(in.floor[k]) || !std::isfinite(in.slope[k]))
      throw std::invalid_argument(what + ": floor heights and slopes must be finite");
  if (in.material >= materials) throw std::invalid_argument(what + ": unknown material");
  if (in.speed.empty()) throw std::invalid_argument(what + ": needs a speed");
  for (const auto& s : in.speed)
    if (!(s[1] >= 0) || !std::isfinite(s[1])) throw std::invalid_argument(what + ": speeds must be >= 0");
  if (in.layers_in_depth(dp) < 1)
    throw std::invalid_argument(what + ": the opening must be at least dp (" + std::to_string(dp) + " m) deep");
}
}  // namespace

template <int D>
void Solver<D>::create_inlet_buffers() {
  const real dp = config_.dp;
  const int layers = inlet_buffer_layers(config_);
  for (size_t k = 0; k < inlets_.size(); ++k) {
    const auto& in = inlets_[k];
    check_inlet(in, materials_.size(), dp);
    const real m = materials_[in.material].density * std::pow(dp, D);
    for (size_t lane = 0; lane < in.lanes(); ++lane) {
      const Vec<D> front = in.origin + (D == 3 ? (lane + 0.5) * dp : 0.0) * in.across;
      for (int d = 0; d < D - 1; ++d) {
        const real back = front[d] - layers * dp * in.normal[d];
        if (!config_.periodic[d] && (std::min(back, front[d]) < config_.domain_min[d] ||
                                     std::max(back, front[d]) > config_.domain_max[d]))
          throw std::invalid_argument("inlet '" + in.name + "': its buffer (" + std::to_string(layers) +
                                      " layers of dp behind the plane) must lie inside the domain");
      }
      for (int l = 0; l < layers; ++l)
        for (int z = 0; z < in.layers_in_depth(dp); ++z) {
          const real s = -(l + 0.5) * dp;
          Vec<D> p = front + s * in.normal;
          p[D - 1] = in.floor_at(lane, s) + (z + 0.5) * dp;
          fluid_.add(p, inlet_density(in, p), m, in.material, kInletBufferBit | static_cast<uint32_t>(k));
          fluid_.id.back() = next_id_++;
          const Vec<D> v = in.speed_at(0) * in.motion(lane);
          for (int d = 0; d < D; ++d) fluid_.vel[d].back() = v[d];
        }
    }
  }
}

template <int D>
void Solver<D>::impose_inlet_state() {
  const size_t n = fluid_.size();
  const bool verlet = config_.integrator == Integrator::verlet;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    if (!is_inlet_buffer(fluid_.tag[i])) continue;
    const auto& in = inlets_[fluid_.tag[i] & ~kInletBufferBit];
    const Vec<D> p = fluid_.position(i);
    const Vec<D> v = in.speed_at(record_.time) * in.motion(in.lane_of(p, config_.dp));
    for (int d = 0; d < D; ++d) {
      fluid_.vel[d][i] = v[d];
      if (verlet) saved_.vel[d][i] = fluid_.vel[d][i];
    }
    fluid_.rho[i] = inlet_density(in, p);
    if (verlet) saved_.rho[i] = fluid_.rho[i];
  }
}

template <int D>
void Solver<D>::advance_inlets() {
  const real length = inlet_buffer_layers(config_) * config_.dp;
  const size_t n = fluid_.size();
  for (size_t i = 0; i < n; ++i) {
    if (!is_inlet_buffer(fluid_.tag[i])) continue;
    const uint32_t k = fluid_.tag[i] & ~kInletBufferBit;
    const auto& in = inlets_[k];
    Vec<D> p = fluid_.position(i);
    if (in.along(p) < 0) continue;
    // Across the plane: it is flow from now on, and its place at the back of the buffer is taken.
    fluid_.tag[i] = 0;
    const uint16_t mat = fluid_.material[i];
    balance_.mass.inflow[mat] += fluid_.mass[i];
    real gx = 0, v2 = 0;
    for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i], v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    balance_.potential_initial -= fluid_.mass[i] * gx;
    balance_.kinetic_inflow += 0.5 * fluid_.mass[i] * v2;
    p -= length * in.motion(in.lane_of(p, config_.dp));
    fluid_.add(p, fluid_.rho[i], fluid_.mass[i], mat, kInletBufferBit | k);
    fluid_.id.back() = next_id_++;
    for (int d = 0; d < D; ++d) fluid_.vel[d].back() = fluid_.vel[d][i];
  }
  // Per-particle state the integrators keep between steps must cover the new particles.
  const size_t m = fluid_.size();
  if (m > n) {
    for (int d = 0; d < D; ++d) {
      saved_.pos[d].resize(m);
      saved_.vel[d].resize(m);
      for (size_t i = n; i < m; ++i) saved_.pos[d][i] = fluid_.pos[d][i], saved_.vel[d][i] = fluid_.vel[d][i];
    }
    saved_.rho.resize(m);
    for (size_t i = n; i < m; ++i) saved_.rho[i] = fluid_.rho[i];
  }
}

template struct InletSpec<2>;
template struct InletSpec<3>;
template real Solver<2>::inlet_density(const InletSpec<2>&, const Vec<2>&) const;
template bool Solver<2>::in_inlet_buffer(const Vec<2>&) const;
template void Solver<2>::create_inlet_buffers();
template void Solver<2>::impose_inlet_state();
template void Solver<2>::advance_inlets();
template real Solver<3>::inlet_density(const InletSpec<3>&, const Vec<3>&) const;
template bool Solver<3>::in_inlet_buffer(const Vec<3>&) const;
template void Solver<3>::create_inlet_buffers();
template void Solver<3>::impose_inlet_state();
template void Solver<3>::advance_inlets();

}  // namespace runout
