// Fickian particle shifting (Lind, Xu, Stansby & Rogers 2012, J. Comput. Phys. 231; the form DualSPHysics
// runs): a particle moves down the gradient of the particle concentration C = sum_j V_j W_ij,
//   delta r_i = -A h |v_i| dt grad C_i,  grad C_i = sum_j V_j grad_i W_ij (fluid and wall neighbours),
// so the particles stay evenly spread as they shear past each other. Without it a sheared SPH layer opens
// voids that its continuity density does not see, and its pressure gradient then reads low (docs/design.md,
// "Particle shifting"). At a free surface grad C points out of the fluid, so the shift is off where the
// position divergence div r_i = -sum_j V_j (x_i - x_j) . grad_i W_ij (D inside the fluid) is under a
// threshold and ramps to full by div r = D (DualSPHysics' ShiftTFS: 1.5 in 2D, 2.75 in 3D). A shift is at most
// 0.1 dp (DualSPHysics' recommended cap). Velocity and density are not Taylor-corrected for the shift (as in
// DualSPHysics): the shift is a fraction of the step's own displacement.
#include <algorithm>
#include <cmath>

#include "impl.hpp"
#include "runout/engine/kernels.hpp"

namespace runout {

namespace {
constexpr real kSurfaceThreshold2D = 1.5, kSurfaceThreshold3D = 2.75;
constexpr real kMaxShift = 0.1;  // [dp]
}  // namespace

template <int D>
void Solver<D>::shifting_gradients() {
  auto& I = *impl_;
  auto& pass = I.pass;
  const size_t n = fluid_.size();
  for (int d = 0; d < D; ++d) pass.shift_gradient[d].resize(n);
  pass.shift_scale.resize(n);
  const PassMaxima maxima = pass.maxima;  // the evaluation's, which pass_context() resets
  const PassContext<D> c = pass_context();
  const real threshold = D == 2 ? kSurfaceThreshold2D : kSurfaceThreshold3D;
  constexpr int kDiv = D, kS = D + 1;  // fields: grad C (D), div r
  with_kernel<D>(config_.kernel, config_.smoothing_length, [&](auto kernel) {
    I.accumulate(
        n, kS, 0,
        [&](real* A, real*, PassMaxima&) {
          PairGeometry<D> G;
          I.for_each_fluid([&](uint32_t i) {
            Vec<D> xi;
            for (int d = 0; d < D; ++d) xi[d] = c.P[d][i];
            const uint32_t* list = I.list_of(i);
            const uint32_t nfl = I.pairs.lists.nf[i], nbl = I.pairs.lists.nb[i];
            prepare_pairs(c, kernel, G, xi, c.rho[i], list, nfl, nbl);
            const real Vi = c.vol[i];
            Vec<D> grad = Vec<D>::Zero();
            real div = 0;
            // grad_i W_ij = F dx (dx = x_i - x_j); j's side: grad_j W_ji = -F dx. div r: -V F r^2 on both sides.
            for (uint32_t q = 0; q < nfl + nbl; ++q) {
              const bool wall = q >= nfl;
              const uint32_t j = list[q];
              const real F = G.F[q], Vj = wall ? c.bvol[j] : c.vol[j];
              for (int d = 0; d < D; ++d) grad[d] += Vj * F * G.dx[d][q];
              div -= Vj * F * G.r2[q];
              if (wall) continue;
              real* Aj = A + static_cast<size_t>(j) * kS;
              for (int d = 0; d < D; ++d) Aj[d] -= Vi * F * G.dx[d][q];
              Aj[kDiv] -= Vi * F * G.r2[q];
            }
            real* Ai = A + static_cast<size_t>(i) * kS;
            for (int d = 0; d < D; ++d) Ai[d] += grad[d];
            Ai[kDiv] += div;
          });
        },
        [&](auto&& sum, size_t i, PassMaxima&) {
          for (int d = 0; d < D; ++d) pass.shift_gradient[d][i] = sum(d, i);
          const real div = sum(kDiv, i);
          const real ramp = std::clamp((div - threshold) / (D - threshold), 0.0, 1.0);
          pass.shift_scale[i] = is_inlet_buffer(fluid_.tag[i]) ? 0.0 : ramp;
        },
        [](auto&&, uint32_t, uint32_t) {});
  });
  pass.maxima = maxima;
}

template <int D>
void Solver<D>::apply_shifting(real dt) {
  const auto& pass = impl_->pass;
  const size_t n = fluid_.size();
  const real k = config_.shifting_coefficient * config_.smoothing_length * dt, cap = kMaxShift * config_.dp;
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const real s = pass.shift_scale[i];
    if (s <= 0) continue;
    real v2 = 0, g2 = 0;
    for (int d = 0; d < D; ++d) {
      v2 += fluid_.vel[d][i] * fluid_.vel[d][i];
      g2 += pass.shift_gradient[d][i] * pass.shift_gradient[d][i];
    }
    const real len = s * k * std::sqrt(v2 * g2);
    if (!(len > 0)) continue;
    const real f = -std::min(len, cap) / std::sqrt(g2);
    for (int d = 0; d < D; ++d) fluid_.pos[d][i] += f * pass.shift_gradient[d][i];
  }
}

template void Solver<2>::shifting_gradients();
template void Solver<3>::shifting_gradients();
template void Solver<2>::apply_shifting(real);
template void Solver<3>::apply_shifting(real);

}  // namespace runout
