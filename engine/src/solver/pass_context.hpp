#pragma once
// What the pair passes of one force evaluation read and write (PassContext), the pair geometry worked out
// ahead of a particle's force loop (PairGeometry, prepare_pairs) and the continuity terms both passes share.
// The passes (passes.hpp) and the wall models (engine/src/wall/) are templates over these.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {
namespace solver_detail {

// The neighbour pack: what a pair loop reads of its neighbour j, one 64-byte record per fluid particle (one
// cache line instead of one per array): velocity, rho, m / rho, p / rho^2, p (pass 1) or mu_eff (pass 2), 1 / rho.
template <int D>
struct Pack {
  static constexpr int kStride = 8, kRho = D, kVol = D + 1, kPt = D + 2, kPm = D + 3, kInvRho = D + 4;
  static_assert(kInvRho < kStride);
};

// Raw pointers and constants, set once per evaluation: the loops hold no references to the solver's vectors,
// so the compiler need not reload them after every accumulator store.
template <int D>
struct PassContext {
  // Constants.
  real h, c0, eta2, alpha, inv_c0_sq, contact2, v_slip;
  real ddt_coef;    // 2 delta h c0, or 0 without density diffusion
  bool fourtakas;   // density diffusion with the hydrostatic correction
  bool any_periodic;
  bool explicit_viscosity;  // the viscous terms in the momentum pass (false: the implicit step carries them)
  Vec<D> g, period;
  const real* rho0;           // per material
  const real* wall_friction;  // per material
  // Fluid.
  std::array<const real*, D> P, V;
  const real *mass, *rho, *press, *vol, *pt, *inv_rho, *pack;
  const uint16_t* mat;
  // Boundary (bvol, bpt: the active ones).
  std::array<const real*, D> BP;
  std::array<const real*, D> BN;  // the wall's unit normal (zero: unknown)
  const real *bmass, *brho, *bvol, *bpt;
  const uint32_t* bslot;
  // Viscous scenes: each particle's capped mu_eff and the viscosity its wall pairs see.
  const real *mu_eff, *mu_wall;
  // What the passes write: density rates (fluid, boundary), the kernel-averaged pressure the yield stress sees,
  // the shear rate, the acceleration and the wall normal of particles in wall contact (else 0).
  real *drho, *boundary_drho, *yield_pressure, *shear_rate;
  std::array<real*, D> acc, contact_normal;
  // Implicit viscous step: the basal Coulomb friction as a drag coefficient k (per unit mass, along the wall's
  // tangent plane, normal n), lagged from this evaluation's slip, for the solve to apply (0: none).
  real* friction_drag;
  std::array<real*, D> friction_normal;

  // Density diffusion of one same-material fluid pair: the term for i is -dr F V_j, for j +dr F V_i.
  // Fourtakas et al. (2019) subtract the hydrostatic density difference, linearised:
  // rho0 g.(x_j - x_i) / c0^2 (exact to O((g h / c0^2)^2)).
  real diffusion_dr(real rhoi, real rhoj, int mi, const Vec<D>& dx) const {
    real dr = rhoj - rhoi;
    if (fourtakas) dr += rho0[mi] * g.dot(dx) * inv_c0_sq;
    return dr;
  }
};

// Fields of the pass accumulators shared by every pass that carries continuity: the velocity divergence and
// the density-diffusion sum come first.
constexpr int kDiv = 0, kDiff = 1;
// A wall particle's accumulator record in the passes that carry its continuity (DBC): the divergence alone.
constexpr int kWallFields = 1;

// Continuity (and density diffusion) of the fluid pair (i, j), i's share into div and diff, j's into its
// accumulator record Aj.
template <int D>
inline void continuity_pair(const PassContext<D>& c, uint32_t j, int mi, real rhoi, real rhoj, real Vi, real Vj,
                            real F, real vdotdx, const Vec<D>& dx, real& div, real& diff, real* Aj) {
  div += Vj * F * vdotdx;
  Aj[kDiv] += Vi * F * vdotdx;
  if (c.ddt_coef > 0 && c.mat[j] == mi) {
    const real dr = c.diffusion_dr(rhoi, rhoj, mi, dx);
    diff -= dr * F * Vj;
    Aj[kDiff] += dr * F * Vi;
  }
}

// drho_i/dt from the summed divergence and diffusion fields.
template <int D, class Sum>
inline real density_rate(const PassContext<D>& c, Sum&& sum, size_t i) {
  return c.rho[i] * sum(kDiv, i) + c.ddt_coef * sum(kDiff, i);
}

// One particle's pair list, worked out before its force loop.
template <int D>
struct PairGeometry {
  std::array<std::vector<real>, D> dx;
  std::vector<real> r2, r, inv, F;
  void ensure(size_t n) {
    if (r2.size() >= n) return;
    const size_t m = std::max<size_t>({n, 2 * r2.size(), 256});
    for (auto& v : dx) v.resize(m);
    r2.resize(m);
    r.resize(m);
    inv.resize(m);
    F.resize(m);
  }
  // Entry q: dx = x_i - x_j, v_ij and v_ij . dx for a fluid j (velocity from its pack record pk); returns r^2.
  real fluid_at(uint32_t q, const Vec<D>& vi, const real* pk, Vec<D>& d, Vec<D>& vij, real& vdotdx) const {
    vdotdx = 0;
    for (int k = 0; k < D; ++k) {
      d[k] = dx[k][q];
      vij[k] = vi[k] - pk[k];
      vdotdx += vij[k] * d[k];
    }
    return r2[q];
  }
  // The same for a wall particle (v = 0, so v_ij = v_i).
  real wall_at(uint32_t q, const Vec<D>& vi, Vec<D>& d, real& vdotdx) const {
    vdotdx = 0;
    for (int k = 0; k < D; ++k) {
      d[k] = dx[k][q];
      vdotdx += vi[k] * d[k];
    }
    return r2[q];
  }
};

// Pair geometry of list entries [q0, q1) of a particle at x with density rho_i (no periodic axes): separations,
// r^2, r, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)) and F. A vector loop (gathers).
template <int D, class Kernel>
void pair_geometry(const Kernel& kernel, const uint32_t* __restrict list, uint32_t q0, uint32_t q1,
                   const real* __restrict qa, const real* __restrict qb, const real* __restrict qc,
                   const real* __restrict rhoq, real xa, real xb, real xc, real rhoi, real eta2, real* __restrict da,
                   real* __restrict db, real* __restrict dc, real* __restrict r2o, real* __restrict ro,
                   real* __restrict invo, real* __restrict Fo) {
  for (uint32_t q = q0; q < q1; ++q) {
    const uint32_t j = list[q];
    const real a = xa - qa[j], b = xb - qb[j];
    real r2 = a * a + b * b;
    da[q] = a;
    db[q] = b;
    if constexpr (D == 3) {
      const real cc = xc - qc[j];
      r2 += cc * cc;
      dc[q] = cc;
    }
    const real r = std::sqrt(r2), e = r2 + eta2, rs = rhoi + rhoq[j];
    const real inv = 1.0 / (r * e * rs);
    r2o[q] = r2;
    ro[q] = r;
    invo[q] = inv;
    Fo[q] = kernel.grad_factor_in_support(r, inv * e * rs);
  }
}

// The same with periodic axes: each separation takes the nearest image.
template <int D, class Kernel>
void pair_geometry_periodic(const PassContext<D>& c, const Kernel& kernel, PairGeometry<D>& G, const Vec<D>& x,
                            real rhoi, const uint32_t* list, uint32_t q0, uint32_t q1,
                            const std::array<const real*, D>& Q, const real* __restrict rhoQ) {
  for (uint32_t q = q0; q < q1; ++q) {
    const uint32_t j = list[q];
    real r2 = 0;
    for (int d = 0; d < D; ++d) {
      real dxd = x[d] - Q[d][j];
      if (c.period[d] > 0) dxd -= c.period[d] * std::round(dxd / c.period[d]);
      G.dx[d][q] = dxd;
      r2 += dxd * dxd;
    }
    const real r = std::sqrt(r2), e = r2 + c.eta2, rs = rhoi + rhoQ[j];
    const real inv = 1.0 / (r * e * rs);
    G.r2[q] = r2;
    G.r[q] = r;
    G.inv[q] = inv;
    G.F[q] = kernel.grad_factor_in_support(r, inv * e * rs);
  }
}

// A particle's whole list (nfl fluid, then nbl wall entries) before its force loop: separations, r, F and one
// reciprocal per pair, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)), from which 1/r, 1/(r^2 + eta^2) and
// 1/(rho_i + rho_j) follow by products. A short loop of independent square roots and divisions keeps the
// pipelines full; inside the long force loop their latency stalled it.
template <int D, class Kernel>
void prepare_pairs(const PassContext<D>& c, const Kernel& kernel, PairGeometry<D>& G, const Vec<D>& xi, real rhoi,
                   const uint32_t* list, uint32_t nfl, uint32_t nbl) {
  G.ensure(nfl + nbl);
  if (c.any_periodic) {
    pair_geometry_periodic<D>(c, kernel, G, xi, rhoi, list, 0, nfl, c.P, c.rho);
    pair_geometry_periodic<D>(c, kernel, G, xi, rhoi, list, nfl, nfl + nbl, c.BP, c.brho);
    return;
  }
  // Restrict-qualified locals: the stores cannot alias the loads, so the loop vectorises (gathers).
  real* __restrict gdx[3] = {G.dx[0].data(), G.dx[D > 1 ? 1 : 0].data(), G.dx[D > 2 ? 2 : 0].data()};
  const real xc = D == 3 ? xi[D - 1] : 0.0;
  pair_geometry<D>(kernel, list, 0, nfl, c.P[0], c.P[1], c.P[D - 1], c.rho, xi[0], xi[1], xc, rhoi, c.eta2, gdx[0],
                   gdx[1], gdx[2], G.r2.data(), G.r.data(), G.inv.data(), G.F.data());
  pair_geometry<D>(kernel, list, nfl, nfl + nbl, c.BP[0], c.BP[1], c.BP[D - 1], c.brho, xi[0], xi[1], xc, rhoi,
                   c.eta2, gdx[0], gdx[1], gdx[2], G.r2.data(), G.r.data(), G.inv.data(), G.F.data());
}

}  // namespace solver_detail
}  // namespace runout
