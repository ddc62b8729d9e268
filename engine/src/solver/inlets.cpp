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

namespace {
// The coordinates of the opening, in axis order: 2D: z; 3D: the other horizontal axis, then z.
template <int D>
std::array<int, D - 1> opening_axes(int axis) {
  std::array<int, D - 1> a{};
  int k = 0;
  for (int d = 0; d < D; ++d)
    if (d != axis) a[k++] = d;
  return a;
}
}  // namespace

template <int D>
real Solver<D>::inlet_density(const InletSpec<D>& in, real z) const {
  // Hydrostatic below the opening's top (the inflow's free surface), inverted through Tait.
  const TaitEOS eos(config_.speed_of_sound, materials_[in.material].density, config_.eos_gamma);
  const real g = std::abs(config_.gravity[D - 1]);
  const real p = eos.rho0 * g * std::max(real(0), in.hi[D - 2] - z);
  return eos.density(p);
}

template <int D>
bool Solver<D>::in_inlet_buffer(const Vec<D>& p) const {
  const real length = inlet_buffer_layers(config_) * config_.dp;
  for (const auto& in : inlets_) {
    const real behind = in.direction * (in.at - p[in.axis]);  // distance upstream of the plane
    // Half a spacing of slack: a particle that just crossed may jitter back a little.
    if (behind < 0.5 * config_.dp || behind > length) continue;
    // Over the opening at any height: flow that piles up and spills back over the buffer leaves there too
    // (the inlet is the domain's upstream end).
    const auto ax = opening_axes<D>(in.axis);
    bool inside = p[D - 1] >= in.lo[D - 2] - 0.5 * config_.dp;
    for (int k = 0; k < D - 2; ++k) inside = inside && p[ax[k]] >= in.lo[k] && p[ax[k]] <= in.hi[k];
    if (inside) return true;
  }
  return false;
}

template <int D>
void Solver<D>::create_inlet_buffers() {
  const real dp = config_.dp;
  const int layers = inlet_buffer_layers(config_);
  for (size_t k = 0; k < inlets_.size(); ++k) {
    const auto& in = inlets_[k];
    const std::string what = "inlet '" + in.name + "'";
    if (in.axis < 0 || in.axis >= D - 1) throw std::invalid_argument(what + ": the axis must be horizontal");
    if (in.direction != 1 && in.direction != -1) throw std::invalid_argument(what + ": direction must be +1 or -1");
    if (in.material >= materials_.size()) throw std::invalid_argument(what + ": unknown material");
    if (in.speed.empty()) throw std::invalid_argument(what + ": needs a speed");
    for (const auto& s : in.speed)
      if (!(s[1] >= 0) || !std::isfinite(s[1])) throw std::invalid_argument(what + ": speeds must be >= 0");
    const auto ax = opening_axes<D>(in.axis);
    std::array<int, D - 1> count{};
    for (int j = 0; j < D - 1; ++j) {
      count[j] = static_cast<int>(std::floor((in.hi[j] - in.lo[j]) / dp + 1e-9));
      if (count[j] < 1)
        throw std::invalid_argument(what + ": the opening must be at least dp (" + std::to_string(dp) + " m) across");
    }
    const real back = in.at - in.direction * layers * dp;
    if (!config_.periodic[in.axis] && (std::min(back, in.at) < config_.domain_min[in.axis] ||
                                       std::max(back, in.at) > config_.domain_max[in.axis]))
      throw std::invalid_argument(what + ": its buffer (" + std::to_string(layers) + " layers of dp behind the plane) "
                                  "must lie inside the domain");
    const uint16_t mat = in.material;
    const real m = materials_[mat].density * std::pow(dp, D);
    const int total = D == 2 ? count[0] : count[0] * count[D - 2];
    for (int l = 0; l < layers; ++l)
      for (int c = 0; c < total; ++c) {
        Vec<D> p;
        p[in.axis] = in.at - in.direction * (l + 0.5) * dp;
        int rem = c;
        for (int j = 0; j < D - 1; ++j) {
          p[ax[j]] = in.lo[j] + (rem % count[j] + 0.5) * dp;
          rem /= count[j];
        }
        fluid_.add(p, inlet_density(in, p[D - 1]), m, mat, kInletBufferBit | static_cast<uint32_t>(k));
        fluid_.id.back() = next_id_++;
        fluid_.vel[in.axis].back() = in.direction * in.speed_at(0);
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
    const real u = in.direction * in.speed_at(time_);
    for (int d = 0; d < D; ++d) {
      fluid_.vel[d][i] = d == in.axis ? u : 0;
      if (verlet) vel_saved_[d][i] = fluid_.vel[d][i];
    }
    fluid_.rho[i] = inlet_density(in, fluid_.pos[D - 1][i]);
    if (verlet) rho_saved_[i] = fluid_.rho[i];
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
    if (in.direction * (fluid_.pos[in.axis][i] - in.at) < 0) continue;
    // Across the plane: it is flow from now on, and its place at the back of the buffer is taken.
    fluid_.tag[i] = 0;
    const uint16_t mat = fluid_.material[i];
    mass_.inflow[mat] += fluid_.mass[i];
    real gx = 0, v2 = 0;
    for (int d = 0; d < D; ++d) gx += config_.gravity[d] * fluid_.pos[d][i], v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
    potential_initial_ -= fluid_.mass[i] * gx;
    kinetic_inflow_ += 0.5 * fluid_.mass[i] * v2;
    Vec<D> p = fluid_.position(i);
    p[in.axis] -= in.direction * length;
    fluid_.add(p, fluid_.rho[i], fluid_.mass[i], mat, kInletBufferBit | k);
    fluid_.id.back() = next_id_++;
    for (int d = 0; d < D; ++d) fluid_.vel[d].back() = fluid_.vel[d][i];
  }
  // Per-particle state the integrators keep between steps must cover the new particles.
  const size_t m = fluid_.size();
  if (m > n) {
    for (int d = 0; d < D; ++d) {
      pos_saved_[d].resize(m);
      vel_saved_[d].resize(m);
      for (size_t i = n; i < m; ++i) pos_saved_[d][i] = fluid_.pos[d][i], vel_saved_[d][i] = fluid_.vel[d][i];
    }
    rho_saved_.resize(m);
    for (size_t i = n; i < m; ++i) rho_saved_[i] = fluid_.rho[i];
  }
}


template real Solver<2>::inlet_density(const InletSpec<2>&, real) const;
template bool Solver<2>::in_inlet_buffer(const Vec<2>&) const;
template void Solver<2>::create_inlet_buffers();
template void Solver<2>::impose_inlet_state();
template void Solver<2>::advance_inlets();
template real Solver<3>::inlet_density(const InletSpec<3>&, real) const;
template bool Solver<3>::in_inlet_buffer(const Vec<3>&) const;
template void Solver<3>::create_inlet_buffers();
template void Solver<3>::impose_inlet_state();
template void Solver<3>::advance_inlets();

}  // namespace runout
