#pragma once
// The pair terms of a wall made of particles (both wall models, dbc and extrapolated, differ only in how
// the wall particles get their pressure): no-slip (v_b = 0), a push that never pulls, the wall contact and
// basal Coulomb friction against the push.
#include <algorithm>
#include <cmath>

#include "../solver/pass_context.hpp"

namespace runout {
namespace wall {

using solver_detail::PairGeometry;
using solver_detail::PassContext;
using solver_detail::kDiv;
using solver_detail::kWallFields;

// DBC continuity of wall particle b and its share of i's divergence:
// drho_b/dt = rho_b sum V_f (0 - v_f) . grad_b W = rho_b sum V_f F v_f . dx.
template <int D>
inline void wall_continuity(const PassContext<D>& c, uint32_t b, real Vi, real F, real vdotdx, real& div,
                            real* Bacc) {
  div += c.bvol[b] * F * vdotdx;
  Bacc[kWallFields * c.bslot[b] + kDiv] += Vi * F * vdotdx;
}

// What a particle's wall pairs sum to in the momentum pass.
template <int D>
struct WallContact {
  Vec<D> push = Vec<D>::Zero();    // the walls' pressure force on the particle, per unit mass
  Vec<D> normal = Vec<D>::Zero();  // -sum_b V_b grad W: points away from the wall
  bool contact = false;            // closer than kWallContact dp to a wall particle
};

template <int D>
struct ParticleWall {
  using Contact = WallContact<D>;

  // Pass 1: continuity and the velocity gradient over the wall entries [q0, q1) of i's list.
  static void gradient_pairs(const PassContext<D>& c, const PairGeometry<D>& G, const uint32_t* list, uint32_t q0,
                             uint32_t q1, const Vec<D>& vi, real Vi, real& div, Mat<D>& L, real* Bacc) {
    for (uint32_t q = q0; q < q1; ++q) {
      const uint32_t b = list[q];
      Vec<D> dx;
      real vdotdx;
      G.wall_at(q, vi, dx, vdotdx);
      const real F = G.F[q];
      // No-slip wall, v_b = 0: the same wall velocity the viscous force of pass 2 acts against. (A mirrored
      // v_b = -v_i overestimates the wall shear rate: the Bingham Poiseuille plug then ran 9 % fast.)
      L.noalias() -= (c.bvol[b] * F) * vi * dx.transpose();
      wall_continuity(c, b, Vi, F, vdotdx, div, Bacc);
    }
  }

  // Pass 2: pressure push, artificial viscosity, the viscous wall shear with mu_b = mu_wall_i (kViscous) and,
  // in inviscid scenes, continuity, over the wall entries [q0, q1) of i's list.
  template <bool kViscous>
  static void momentum_pairs(const PassContext<D>& c, const PairGeometry<D>& G, const uint32_t* list, uint32_t q0,
                             uint32_t q1, uint32_t i, const Vec<D>& vi, real pi_term, real mu_wall_i, real& div,
                             Vec<D>& a, real& visc_max, WallContact<D>& w, real* Bacc) {
    const real rhoi = c.rho[i], Vi = c.vol[i];
    for (uint32_t q = q0; q < q1; ++q) {
      const uint32_t b = list[q];
      Vec<D> dx;
      real vdotdx;
      const real r2 = G.wall_at(q, vi, dx, vdotdx);
      const real rhob = c.brho[b], mb = c.bmass[b];
      const real r = G.r[q], e = r2 + c.eta2, rs = rhoi + rhob, inv = G.inv[q];
      const real inv_e = inv * r * rs;
      const real F = G.F[q];
      if constexpr (!kViscous) wall_continuity(c, b, Vi, F, vdotdx, div, Bacc);
      // A wall pushes and never pulls: where a fluid particle's pressure is negative (a liquid may carry
      // tension) the pair term would draw it into the wall's particle lattice.
      real pterm = std::max(pi_term + c.bpt[b], real(0));
      const real mu_ij = c.h * vdotdx * inv_e;
      visc_max = std::max(visc_max, std::abs(mu_ij));
      if (c.alpha > 0) pterm -= 2.0 * c.alpha * c.c0 * std::min(mu_ij, real(0)) * (inv * r * e);
      const Vec<D> push = (-mb * pterm * F) * dx;
      a += push;
      w.push += push;
      if constexpr (kViscous)
        if (c.explicit_viscosity) a += (mb * 2.0 * mu_wall_i * c.inv_rho[i] / rhob * F * r2 * inv_e) * vi;
      w.contact = w.contact || r2 < c.contact2;
      w.normal -= (c.bvol[b] * F) * dx;
    }
  }

  // After i's pairs: basal Coulomb friction (friction rheologies) against the walls' normal push N, along the
  // tangential velocity, smoothed over a slip speed v_slip so a resting particle is not chattered by sign
  // flips; and the contact normal the integrator's wall contact uses.
  template <bool kViscous>
  static void finish(const PassContext<D>& c, uint32_t i, const Vec<D>& vi, real friction_i, const WallContact<D>& w,
                     Vec<D>& a) {
    if constexpr (kViscous) {
      const real push = w.push.norm();
      if (friction_i > 0 && push > 0) {
        const Vec<D> nrm = w.push / push;
        const Vec<D> vt = vi - vi.dot(nrm) * nrm;
        const real vts = vt.norm();
        // The secant drag of the regularised law, mu N (1 - exp(-|v_t| / v_slip)) / |v_t| (mu N / v_slip at rest).
        const real drag = vts > 0 ? friction_i * push * -std::expm1(-vts / c.v_slip) / vts : friction_i * push / c.v_slip;
        if (c.explicit_viscosity) {
          a -= drag * vt;
        } else {
          c.friction_drag[i] = drag;
          for (int d = 0; d < D; ++d) c.friction_normal[d][i] = nrm[d];
        }
      }
    }
    const real nn = w.normal.norm();
    for (int d = 0; d < D; ++d) c.contact_normal[d][i] = w.contact && nn > 0 ? w.normal[d] / nn : 0;
  }
};

}  // namespace wall
}  // namespace runout
