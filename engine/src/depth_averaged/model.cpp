// The thickness-integrated SPH model: thickness and its gradient by one pair pass in plan, the momentum balance
// along the bed, the basal resistance and a kick-drift-kick leapfrog step (docs/design.md, "Thickness-integrated SPH
// (screening rung)").
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "neighbours.hpp"
#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged {

struct Model::Impl {
  detail::PlanCells cells;
  std::vector<real> gx, gy;  // G_i = sum_j V_j grad W_ij (plan), from the last pass
  // With Savage-Hutter earth pressure: sum_j V_j (u_j - u_i) (x) grad W_ij (plan, row-major xx xy yx yy), the
  // velocity gradient up to a positive factor (only its signs along and across the flow are used).
  std::vector<real> lxx, lxy, lyx, lyy;
  EarthPressureCoefficients earth{};
  // Per-step scratch: acceleration without friction, bed samples, friction inputs and output.
  std::vector<real> ax, ay, az, normal_stress, speed, tau;
  std::vector<BedSample> bed;
};

namespace {

template <class T>
void permute(std::vector<T>& v, const std::vector<uint32_t>& order, std::vector<T>& buf) {
  buf.resize(v.size());
  for (size_t k = 0; k < v.size(); ++k) buf[k] = v[order[k]];
  v.swap(buf);
}

// The volume density in plan, rho_i = sum_j V_j W(r_ij, h_k,i), and its plan gradient G_i = sum_j V_j grad_i
// W(r_ij, h_k,i): a gather with the particle's own kernel (self included in rho, not in G), over the cells its
// support reaches. One kernel per particle, so a particle with a wide kernel costs more and the rest nothing.
template <class K, bool kStrain>
void density_pass(const detail::PlanCells& cells, const Particles& p, std::vector<real>& rho, std::vector<real>& gx,
                  std::vector<real>& gy, const std::array<std::vector<real>*, 4>& strain) {
  const size_t ncell = cells.keys.size();
#pragma omp parallel
  {
    std::vector<detail::PlanCells::Range> ranges;
#pragma omp for schedule(dynamic, 16)
    for (size_t c = 0; c < ncell; ++c) {
      const uint32_t i0 = cells.begin[c];
      const int64_t cx = cells.coord(p.x[i0], 0), cy = cells.coord(p.y[i0], 1);
      real reach_for = -1;  // the support the ranges were gathered for (particles of a cell mostly share it)
      for (uint32_t i = i0; i < cells.begin[c + 1]; ++i) {
        const K kernel(p.smoothing[i]);
        const real support = kernel.support(), support2 = support * support;
        if (support > reach_for) {
          cells.neighbour_ranges(cx, cy, cells.reach(support, 0), cells.reach(support, 1), ranges);
          reach_for = cells.reach(support, 0) * cells.cell[0];
          reach_for = std::min(reach_for, cells.reach(support, 1) * cells.cell[1]);
        }
        real s = 0, sx = 0, sy = 0, l[4] = {0, 0, 0, 0};
        for (const auto& r : ranges)
          for (uint32_t j = r.begin; j < r.end; ++j) {
            const real dx = p.x[i] - p.x[j] - r.sx, dy = p.y[i] - p.y[j] - r.sy;
            const real r2 = dx * dx + dy * dy;
            if (r2 >= support2) continue;
            const real rr = std::sqrt(r2);
            s += p.volume[j] * kernel.W(rr);
            if (rr > 0) {
              const real f = p.volume[j] * kernel.grad_factor(rr);
              sx += f * dx;
              sy += f * dy;
              if constexpr (kStrain) {
                const real dux = p.ux[j] - p.ux[i], duy = p.uy[j] - p.uy[i];
                l[0] += dux * f * dx, l[1] += dux * f * dy, l[2] += duy * f * dx, l[3] += duy * f * dy;
              }
            }
          }
        rho[i] = s;
        gx[i] = sx;
        gy[i] = sy;
        if constexpr (kStrain)
          for (int q = 0; q < 4; ++q) (*strain[q])[i] = l[q];
      }
    }
  }
}

// The component of a plan gradient G lifted onto the bed: the surface gradient whose plan projection gives the
// directional derivatives G.t for tangent vectors t, w = G - b (b.G) cos^2 (inverse metric), lifted by (w, b.w).
Vec3 lift(const Vec2& G, const BedSample& s) {
  const real c2 = 1.0 / (1.0 + s.grad.squaredNorm());
  const Vec2 w = G - s.grad * (s.grad.dot(G) * c2);
  return Vec3(w.x(), w.y(), s.grad.dot(w));
}

}  // namespace

const std::vector<ParameterSpec>& config_parameters() {
  static const std::vector<ParameterSpec> specs = {
      {"earth_pressure", "", 1.0, 0.0, 10.0, false, false, false, "earth-pressure coefficient k (1: hydrostatic)"},
      {"smoothing_ratio", "", 1.5, 1.0, 4.0, false, false, false, "kernel smoothing length / particle spacing"},
      {"cfl", "", 0.2, 0.0, 1.0, true, false, false, "time-step factor on h_k / (sqrt(k g_n h) + |u|)"},
      {"dt_max", "s", 0.1, 0.0, 10.0, true, false, false, "largest time step"},
  };
  return specs;
}

EarthPressureCoefficients savage_hutter_coefficients(real phi_deg, real delta_deg) {
  if (!(delta_deg >= 0 && delta_deg <= phi_deg && phi_deg < 90))
    throw std::invalid_argument("depth_averaged: Savage-Hutter earth pressure needs 0 <= bed_friction_angle <= "
                                "internal_friction_angle < 90 deg");
  const real phi = phi_deg * kPi / 180, delta = delta_deg * kPi / 180;
  const real cos2phi = std::cos(phi) * std::cos(phi), tan2delta = std::tan(delta) * std::tan(delta);
  const real root1 = std::sqrt(std::max<real>(0, 1 - cos2phi / (std::cos(delta) * std::cos(delta))));
  EarthPressureCoefficients e{};
  e.kx[0] = 2 / cos2phi * (1 - root1) - 1;
  e.kx[1] = 2 / cos2phi * (1 + root1) - 1;
  for (int a = 0; a < 2; ++a) {
    const real kx = e.kx[a], root2 = std::sqrt((1 - kx) * (1 - kx) + 4 * tan2delta);
    e.ky[a][0] = 0.5 * (kx + 1 - root2);
    e.ky[a][1] = 0.5 * (kx + 1 + root2);
  }
  return e;
}

void Particles::add(real px, real py, real vol) {
  x.push_back(px), y.push_back(py), volume.push_back(vol);
  ux.push_back(0), uy.push_back(0), uz.push_back(0), h.push_back(0), smoothing.push_back(0);
  id.push_back(static_cast<uint32_t>(id.size()));
}

Model::Model(const Config& config, Bed bed, Particles particles)
    : config_(config), bed_(std::move(bed)), p_(std::move(particles)), impl_(std::make_unique<Impl>()) {
  if (!(config_.spacing > 0)) throw std::invalid_argument("depth_averaged: spacing must be positive");
  friction_ = make_friction(config_.friction, config_.friction_parameters, config_.gravity);
  h_kernel_ = config_.smoothing_ratio * config_.spacing;
  if (!(config_.smoothing_ratio > 0) || !(config_.max_smoothing_growth >= 1))
    throw std::invalid_argument("depth_averaged: smoothing_ratio must be positive, max_smoothing_growth at least 1");
  for (int d = 0; d < 2; ++d)
    if (config_.periodic[d] && !(config_.domain_max[d] > config_.domain_min[d]))
      throw std::invalid_argument("depth_averaged: a periodic axis needs domain_max > domain_min");
  if (config_.savage_hutter)
    impl_->earth = savage_hutter_coefficients(config_.internal_friction_angle, config_.bed_friction_angle);
  impl_->cells.configure(2.0 * h_kernel_, config_);
  const size_t n = p_.size();
  p_.h.resize(n), p_.ux.resize(n), p_.uy.resize(n), p_.uz.resize(n);
  p_.smoothing.assign(n, h_kernel_);
  if (p_.id.size() != n) {
    p_.id.resize(n);
    for (size_t i = 0; i < n; ++i) p_.id[i] = static_cast<uint32_t>(i);
  }
  for (size_t i = 0; i < n; ++i)
    for (int d = 0; d < 2; ++d) (d == 0 ? p_.x : p_.y)[i] = impl_->cells.wrap((d == 0 ? p_.x : p_.y)[i], d);
  refresh();
  if (config_.adaptive_smoothing) refresh();  // the smoothing lengths of the initial thickness
}

void Model::add_particles(const Particles& more) {
  const size_t n0 = p_.size();
  for (size_t k = 0; k < more.size(); ++k) {
    p_.x.push_back(impl_->cells.wrap(more.x[k], 0)), p_.y.push_back(impl_->cells.wrap(more.y[k], 1));
    p_.volume.push_back(more.volume[k]);
    p_.ux.push_back(more.ux[k]), p_.uy.push_back(more.uy[k]), p_.uz.push_back(more.uz[k]);
    p_.h.push_back(0), p_.smoothing.push_back(h_kernel_);
    p_.id.push_back(static_cast<uint32_t>(n0 + k));
  }
  refresh();  // the new particles' bed samples are not there yet: the adaptive update waits for the next step
  accelerations_current_ = false;
}

Model::~Model() = default;
Model::Model(Model&&) noexcept = default;

real Model::total_volume() const {
  real v = 0;
  for (real x : p_.volume) v += x;
  return v;
}

// Sorts the particles by cell and computes the thickness h_i = cos(theta_i) rho_i and G_i, so the state is
// consistent after every public call. The adaptive smoothing length is set from the last step's thickness
// first (one explicit update per step, not iterated).
void Model::refresh() {
  auto& I = *impl_;
  const size_t n = p_.size();
  if (config_.adaptive_smoothing && I.bed.size() == n) {
    const real hi = config_.max_smoothing_growth * h_kernel_;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      const real rho = p_.h[i] / I.bed[i].cos_slope();
      p_.smoothing[i] = std::clamp(config_.smoothing_ratio * std::sqrt(p_.volume[i] / rho), h_kernel_, hi);
    }
  }
  I.cells.sort(p_.x, p_.y);
  std::vector<real> rbuf;
  std::vector<uint32_t> ibuf;
  for (auto* v : {&p_.x, &p_.y, &p_.volume, &p_.ux, &p_.uy, &p_.uz, &p_.smoothing}) permute(*v, I.cells.order, rbuf);
  permute(p_.id, I.cells.order, ibuf);
  I.gx.resize(n), I.gy.resize(n), I.bed.resize(n);
  with_kernel<2>(config_.kernel, h_kernel_, [&](const auto& k) {
    using K = std::decay_t<decltype(k)>;
    if (config_.savage_hutter) {
      I.lxx.resize(n), I.lxy.resize(n), I.lyx.resize(n), I.lyy.resize(n);
      density_pass<K, true>(I.cells, p_, p_.h, I.gx, I.gy, {&I.lxx, &I.lxy, &I.lyx, &I.lyy});
    } else {
      density_pass<K, false>(I.cells, p_, p_.h, I.gx, I.gy, {});
    }
  });
  real hk_max = h_kernel_;
#pragma omp parallel for schedule(static) reduction(max : hk_max)
  for (size_t i = 0; i < n; ++i) {
    I.bed[i] = bed_.sample(p_.x[i], p_.y[i]);
    p_.h[i] *= I.bed[i].cos_slope();
    hk_max = std::max(hk_max, p_.smoothing[i]);
  }
  h_kernel_max_ = hk_max;
}

real Model::thickness_at(real x, real y) const {
  const auto& cells = impl_->cells;
  x = cells.wrap(x, 0), y = cells.wrap(y, 1);
  std::vector<detail::PlanCells::Range> ranges;
  const real support = 2.0 * h_kernel_max_;
  cells.neighbour_ranges(cells.coord(x, 0), cells.coord(y, 1), cells.reach(support, 0), cells.reach(support, 1),
                         ranges);
  return with_kernel<2>(config_.kernel, h_kernel_, [&](const auto& k0) {
    using K = std::decay_t<decltype(k0)>;
    real s = 0;
    for (const auto& r : ranges)
      for (uint32_t j = r.begin; j < r.end; ++j) {
        const real dx = x - p_.x[j] - r.sx, dy = y - p_.y[j] - r.sy;
        s += p_.volume[j] * K(p_.smoothing[j]).W(std::sqrt(dx * dx + dy * dy));
      }
    return s * bed_.sample(x, y).cos_slope();
  });
}

real Model::step() { return step_to(std::numeric_limits<real>::infinity()); }

void Model::advance_to(real t) {
  while (time_ < t) step_to(t);
}

// Kick-drift-kick leapfrog: half the step's velocity change (gravity, pressure, friction) at the old positions,
// the move with that mid-step velocity, the other half at the new positions. Positions are second order (exact
// under a constant acceleration: a sliding or stopping block travels its analytic distance), and the scheme is
// symplectic, so the pressure term's oscillations are not amplified, as they are by a position update from the
// mean of the old and new velocities. The new positions' accelerations serve the next step's first half: one
// thickness pass and one acceleration pass a step.
real Model::step_to(real t_limit) {
  if (!accelerations_current_) next_dt_ = accelerations();
  const real dt = std::min(next_dt_, t_limit - time_);
  kick(0.5 * dt);
  drift(dt);
  time_ = std::min(time_ + dt, t_limit);
  ++steps_;
  refresh();
  next_dt_ = accelerations();
  kick(0.5 * dt);
  accelerations_current_ = true;
  check_finite();
  return dt;
}

// Gravity along the bed and the pressure term for every particle; returns the step: the CFL limit on the
// wave speed sqrt(k g_n h) plus |u|, the same factor on sqrt(h_k / |a|), and dt_max.
real Model::accelerations() {
  auto& I = *impl_;
  const size_t n = p_.size();
  I.ax.resize(n), I.ay.resize(n), I.az.resize(n);
  const real g = config_.gravity, k = config_.earth_pressure;
  real wave = 0, acc = 0;
  // Two instantiations: the isotropic loop stays the statements it was (its rounding, and so its runs, unchanged).
  auto pass = [&](auto savage_hutter) {
#pragma omp parallel for schedule(static) reduction(max : wave, acc)
    for (size_t i = 0; i < n; ++i) {
      const BedSample& s = I.bed[i];
      const real c = s.cos_slope();
      // Gravity minus its normal part: -g cos^2 (z_x, z_y, |grad z|^2).
      const Vec3 gt = -g * c * c * Vec3(s.grad.x(), s.grad.y(), s.grad.squaredNorm());
      const real u = std::sqrt(p_.ux[i] * p_.ux[i] + p_.uy[i] * p_.uy[i] + p_.uz[i] * p_.uz[i]);
      if constexpr (decltype(savage_hutter)::value) {
        real k_max = 0;
        const Vec3 a = gt - g * c * c * lift(savage_hutter_gradient(i, k_max), s);
        I.ax[i] = a.x(), I.ay[i] = a.y(), I.az[i] = a.z();
        wave = std::max(wave, std::sqrt(k_max * g * c * p_.h[i]) + u);
        acc = std::max(acc, a.norm());
      } else {
        // -k g_n grad_s h with g_n = g cos and the plan gradient of h = cos * (plan volume density).
        const Vec3 a = gt - k * g * c * c * lift(Vec2(I.gx[i], I.gy[i]), s);
        I.ax[i] = a.x(), I.ay[i] = a.y(), I.az[i] = a.z();
        wave = std::max(wave, std::sqrt(k * g * c * p_.h[i]) + u);
        acc = std::max(acc, a.norm());
      }
    }
  };
  if (config_.savage_hutter)
    pass(std::true_type{});
  else
    pass(std::false_type{});
  real dt = config_.dt_max;
  if (wave > 0) dt = std::min(dt, config_.cfl * h_kernel_ / wave);
  if (acc > 0) dt = std::min(dt, config_.cfl * std::sqrt(h_kernel_ / acc));
  return dt;
}

// The plan gradient G_i weighted by Savage and Hutter's coefficients in the flow's frame: e1 along the plan
// velocity (the x axis at rest), e2 across; k_x active where the flow stretches along e1, k_y by the sign of
// the strain along e2. k_max: the larger coefficient (the wave speed's).
Vec2 Model::savage_hutter_gradient(size_t i, real& k_max) const {
  const auto& I = *impl_;
  const Vec2 G(I.gx[i], I.gy[i]), u(p_.ux[i], p_.uy[i]);
  const real speed = u.norm();
  const Vec2 e1 = speed > 0 ? Vec2(u / speed) : Vec2(1, 0), e2(-e1.y(), e1.x());
  Mat2 L;
  L << I.lxx[i], I.lxy[i], I.lyx[i], I.lyy[i];
  const bool x_passive = e1.dot(L * e1) < 0, y_passive = e2.dot(L * e2) < 0;
  const real kx = I.earth.kx[x_passive], ky = I.earth.ky[x_passive][y_passive];
  k_max = std::max(kx, ky);
  return e1 * (kx * e1.dot(G)) + e2 * (ky * e2.dot(G));
}

// u* = u + dt a; the basal resistance decelerates |u*| by dt tau_b / (rho h) and stops a particle whose friction
// impulse exceeds its momentum (it never reverses it).
void Model::kick(real dt) {
  auto& I = *impl_;
  const size_t n = p_.size();
  I.normal_stress.resize(n), I.speed.resize(n), I.tau.resize(n);
  const real g = config_.gravity;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    p_.ux[i] += dt * I.ax[i], p_.uy[i] += dt * I.ay[i], p_.uz[i] += dt * I.az[i];
    const BedSample& s = I.bed[i];
    const real c = s.cos_slope();
    const Vec2 up(p_.ux[i], p_.uy[i]);
    // The bed's normal load per unit mass: g cos plus the centripetal term cos u_p^T H u_p; none in lift-off.
    const real gn = g * c + (config_.curvature ? c * up.dot(s.hess * up) : 0.0);
    I.normal_stress[i] = p_.h[i] * std::max(gn, 0.0);
    I.speed[i] = std::sqrt(p_.ux[i] * p_.ux[i] + p_.uy[i] * p_.uy[i] + p_.uz[i] * p_.uz[i]);
  }
  friction_->shear_stress(I.normal_stress, I.speed, p_.h, I.tau);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const real du = dt * I.tau[i] / p_.h[i];
    const real scale = du >= I.speed[i] ? 0.0 : 1.0 - du / I.speed[i];
    p_.ux[i] *= scale, p_.uy[i] *= scale, p_.uz[i] *= scale;
  }
}

// x += dt u (plan); then u is turned onto the bed's tangent plane at the new position with its magnitude kept.
void Model::drift(real dt) {
  auto& I = *impl_;
  const size_t n = p_.size();
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    Vec3 u(p_.ux[i], p_.uy[i], p_.uz[i]);
    p_.x[i] = I.cells.wrap(p_.x[i] + dt * u.x(), 0);
    p_.y[i] = I.cells.wrap(p_.y[i] + dt * u.y(), 1);
    const real speed = u.norm();
    if (speed > 0) {
      const Vec3 nn = bed_.sample(p_.x[i], p_.y[i]).normal();
      u -= nn * nn.dot(u);
      const real m = u.norm();
      u = m > 0 ? Vec3(u * (speed / m)) : Vec3::Zero();
    }
    p_.ux[i] = u.x(), p_.uy[i] = u.y(), p_.uz[i] = u.z();
  }
}

void Model::check_finite() const {
  for (size_t i = 0; i < p_.size(); ++i) {
    if (std::isfinite(p_.x[i]) && std::isfinite(p_.y[i]) && std::isfinite(p_.ux[i]) && std::isfinite(p_.uy[i]) &&
        std::isfinite(p_.uz[i]) && std::isfinite(p_.h[i]))
      continue;
    char buf[160];
    std::snprintf(buf, sizeof buf, "depth_averaged: non-finite state at t=%.6g s, particle %u", time_, p_.id[i]);
    throw SimulationError(buf, SimulationError::Cause::non_finite);
  }
}

}  // namespace runout::depth_averaged
