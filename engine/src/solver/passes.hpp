#pragma once
// The two pair passes of a force evaluation, templated on the kernel and the wall's pair terms (no model
// switch inside the pair loops). Each walks the pair lists (pair_lists.cpp): a fluid pair's term goes to both
// particles, the j side and the wall side into per-thread accumulators (Impl::accumulate), so no two threads
// write the same memory and no pair is evaluated twice.
#include <algorithm>
#include <cmath>

#include "pass_context.hpp"

namespace runout {
namespace solver_detail {

// Strain-rate magnitude sqrt(2 D':D') of the velocity gradient L: D = sym(L), deviator with the 3D trace
// (plane strain in 2D), floored.
template <int D>
real shear_rate_of(const Mat<D>& L, real floor) {
  const Mat<D> Ds = 0.5 * (L + L.transpose());
  const real tr3 = Ds.trace() / 3.0;
  Mat<D> Dd = Ds;
  for (int d = 0; d < D; ++d) Dd(d, d) -= tr3;
  real dd = Dd.squaredNorm();
  if constexpr (D == 2) dd += tr3 * tr3;  // the zz component of the plane-strain deviator
  return std::max(std::sqrt(2.0 * dd), floor);
}

// Pass 1 (scenes with a stress term): continuity with density diffusion, the velocity gradient
// L = -sum V_j v_ij (x) grad W, the kernel-averaged pressure for the yield stress, and the walls' continuity.
template <class Pairs, int D, class Kernel, class ImplT>
void velocity_gradient_pass(const PassContext<D>& c, const Kernel& kernel, ImplT& I, size_t n, real shear_rate_floor) {
  using PK = Pack<D>;
  constexpr int kPw = 2, kWw = 3, kL = 4;  // L: D*D fields, row-major
  constexpr int kS1 = kL + D * D;
  I.accumulate(
      n, kS1, kWallFields,
      [&](real* A, real* Bacc, PassMaxima&) {
        PairGeometry<D> G;
        I.for_each_fluid([&](uint32_t i) {
          Vec<D> xi, vi;
          for (int d = 0; d < D; ++d) xi[d] = c.P[d][i], vi[d] = c.V[d][i];
          const real rhoi = c.rho[i], Vi = c.vol[i], pi = c.press[i];
          const int mi = c.mat[i];
          real div = 0, diff = 0, pw = 0, ww = 0;
          Mat<D> L = Mat<D>::Zero();
          const uint32_t* list = I.list_of(i);
          const uint32_t nfl = I.pairs.lists.nf[i], nbl = I.pairs.lists.nb[i];
          prepare_pairs(c, kernel, G, xi, rhoi, list, nfl, nbl);
          for (uint32_t q = 0; q < nfl; ++q) {
            const uint32_t j = list[q];
            Vec<D> dx, vij;
            real vdotdx;
            const real* pk = c.pack + PK::kStride * j;
            G.fluid_at(q, vi, pk, dx, vij, vdotdx);
            const real F = G.F[q], W = kernel.W(G.r[q]);
            const real Vj = pk[PK::kVol];
            real* Aj = A + j * kS1;
            continuity_pair(c, j, mi, rhoi, pk[PK::kRho], Vi, Vj, F, vdotdx, dx, div, diff, Aj);
            // L_i -= V_j F v_ij dx^T and L_j -= V_i F v_ji dx_ji^T = V_i F v_ij dx^T.
            for (int a = 0; a < D; ++a)
              for (int b = 0; b < D; ++b) {
                const real vd = F * vij[a] * dx[b];
                L(a, b) -= Vj * vd;
                Aj[kL + a * D + b] -= Vi * vd;
              }
            pw += Vj * W * pk[PK::kPm];
            ww += Vj * W;
            Aj[kPw] += Vi * W * pi;
            Aj[kWw] += Vi * W;
          }
          Pairs::gradient_pairs(c, G, list, nfl, nfl + nbl, vi, Vi, div, L, Bacc);
          real* Ai = A + i * kS1;
          Ai[kDiv] += div;
          Ai[kDiff] += diff;
          Ai[kPw] += pw;
          Ai[kWw] += ww;
          for (int a = 0; a < D; ++a)
            for (int b = 0; b < D; ++b) Ai[kL + a * D + b] += L(a, b);
        });
      },
      [&](auto&& sum, size_t i, PassMaxima&) {
        // The kernel-averaged pressure includes the particle itself.
        const real self = c.mass[i] / c.rho[i] * kernel.W(0);
        c.yield_pressure[i] = (sum(kPw, i) + self * c.press[i]) / (sum(kWw, i) + self);
        c.drho[i] = density_rate(c, sum, i);
        Mat<D> L;
        for (int a = 0; a < D; ++a)
          for (int b = 0; b < D; ++b) L(a, b) = sum(kL + a * D + b, i);
        c.shear_rate[i] = shear_rate_of<D>(L, shear_rate_floor);
      },
      [&](auto&& bsum, uint32_t b, uint32_t s) { c.boundary_drho[b] = c.brho[b] * bsum(kDiv, s); });
}

// Momentum of fluid particle i from its fluid pairs: pressure, artificial viscosity and (kViscous) the Morris
// et al. (1997) viscous term; in inviscid scenes also continuity. Returns i's acceleration from these pairs;
// the j sides go to A (record stride kS, acceleration fields from kAcc).
template <bool kViscous, int kS, int kAcc, int D>
Vec<D> momentum_fluid_pairs(const PassContext<D>& c, const PairGeometry<D>& G, const uint32_t* list, uint32_t nfl,
                            uint32_t i, const Vec<D>& vi, real& div, real& diff, real& visc_max, real* A) {
  using PK = Pack<D>;
  const real rhoi = c.rho[i], mi_mass = c.mass[i], Vi = c.vol[i], pi_term = c.pt[i];
  const int mi = c.mat[i];
  const real mui = kViscous ? c.mu_eff[i] : 0.0;
  Vec<D> a = Vec<D>::Zero();
  for (uint32_t q = 0; q < nfl; ++q) {
    const uint32_t j = list[q];
    Vec<D> dx, vij;
    real vdotdx;
    const real* pk = c.pack + PK::kStride * j;
    const real r2 = G.fluid_at(q, vi, pk, dx, vij, vdotdx);
    const real rhoj = pk[PK::kRho], Vj = pk[PK::kVol], mj = Vj * rhoj;
    const real r = G.r[q], e = r2 + c.eta2, rs = rhoi + rhoj, inv = G.inv[q];
    const real inv_e = inv * r * rs;
    const real F = G.F[q];
    if constexpr (!kViscous) continuity_pair(c, j, mi, rhoi, rhoj, Vi, Vj, F, vdotdx, dx, div, diff, A + j * kS);
    real pterm = pi_term + pk[PK::kPt];
    const real mu_ij = c.h * vdotdx * inv_e;
    visc_max = std::max(visc_max, std::abs(mu_ij));
    // Monaghan: approaching pairs only, over the mean density; a select, not a branch (the sign is as good as
    // random).
    if (c.alpha > 0) pterm -= 2.0 * c.alpha * c.c0 * std::min(mu_ij, real(0)) * (inv * r * e);
    // a_i = m_j s, a_j = -m_i s with s = -pterm F dx + (Morris) visc v_ij: antisymmetric in i, j.
    Vec<D> s = (-pterm * F) * dx;
    if constexpr (kViscous) {
      // Morris et al. (1997): (mu_i + mu_j) / (rho_i rho_j) (r_ij . grad W) / (r^2 + eta^2) v_ij,
      // r_ij . grad W = F r^2 (F < 0: the pair force opposes v_ij). The implicit step uses the same weights.
      if (c.explicit_viscosity) s += ((mui + pk[PK::kPm]) * c.inv_rho[i] * pk[PK::kInvRho] * F * r2 * inv_e) * vij;
    }
    a += mj * s;
    for (int d = 0; d < D; ++d) A[j * kS + (kAcc + d)] -= mi_mass * s[d];
  }
  return a;
}

// Pass 2: momentum (pressure, artificial viscosity, rheology stress, gravity); in inviscid scenes also
// continuity and the walls' continuity. The rheology stress acts through the Morris et al. (1997) viscous
// operator with each particle's capped mu_eff from pass 1 (the same for every rheology): a one-step Laplacian
// stencil, with no odd-even null mode, unlike the divergence of tau = 2 mu_eff D' built from the SPH velocity
// gradient (alternate particle rows slid past each other). It approximates div(mu_eff grad v) and drops the
// grad(mu_eff) . (grad v)^T part of div(2 mu_eff D'), which vanishes in simple shear (docs/design.md).
// Pairwise symmetric and v_ij-parallel, so it conserves momentum and can only dissipate energy.
template <bool kViscous, class Pairs, int D, class Kernel, class ImplT>
void momentum_pass(const PassContext<D>& c, const Kernel& kernel, ImplT& I, size_t n) {
  constexpr int kAcc = kViscous ? 0 : 2;  // first of D acceleration fields (inviscid: after div and diff)
  constexpr int kS2 = kAcc + D;
  I.accumulate(
      n, kS2, kViscous ? 0 : kWallFields,
      [&](real* A, real* Bacc, PassMaxima& mx) {
        PairGeometry<D> G;
        I.for_each_fluid([&](uint32_t i) {
          Vec<D> xi, vi;
          for (int d = 0; d < D; ++d) xi[d] = c.P[d][i], vi[d] = c.V[d][i];
          const real friction_i = kViscous ? c.wall_friction[c.mat[i]] : 0.0;
          real visc_max = 0, div = 0, diff = 0;
          const uint32_t* list = I.list_of(i);
          const uint32_t nfl = I.pairs.lists.nf[i], nbl = I.pairs.lists.nb[i];
          prepare_pairs(c, kernel, G, xi, c.rho[i], list, nfl, nbl);
          Vec<D> a = momentum_fluid_pairs<kViscous, kS2, kAcc>(c, G, list, nfl, i, vi, div, diff, visc_max, A);
          typename Pairs::Contact w;
          Pairs::template momentum_pairs<kViscous>(c, G, list, nfl, nfl + nbl, i, vi, c.pt[i],
                                                   kViscous ? c.mu_wall[i] : 0.0, div, a, visc_max, w, Bacc);
          Pairs::template finish<kViscous>(c, i, vi, friction_i, w, a);
          real* Ai = A + i * kS2;
          if constexpr (!kViscous) {
            Ai[kDiv] += div;
            Ai[kDiff] += diff;
          }
          for (int d = 0; d < D; ++d) Ai[kAcc + d] += a[d];
          mx.visc_term = std::max(mx.visc_term, visc_max);
        });
      },
      [&](auto&& sum, size_t i, PassMaxima& mx) {
        Vec<D> a;
        for (int d = 0; d < D; ++d) a[d] = sum(kAcc + d, i) + c.g[d];
        for (int d = 0; d < D; ++d) c.acc[d][i] = a[d];
        mx.acc2 = std::max(mx.acc2, a.squaredNorm());
        if constexpr (!kViscous) c.drho[i] = density_rate(c, sum, i);
      },
      [&](auto&& bsum, uint32_t b, uint32_t s) {
        if constexpr (!kViscous) c.boundary_drho[b] = c.brho[b] * bsum(kDiv, s);
      });
}

}  // namespace solver_detail
}  // namespace runout
