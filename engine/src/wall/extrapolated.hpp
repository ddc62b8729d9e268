#pragma once
// Extrapolated wall pressure (Adami, Hu & Adams 2012, with the hydrostatic term across the wall): each step
// p_b = sum_f (p_f + rho_f (g.n_b)(n_b.(x_b - x_f))) W_bf / sum_f W_bf, clamped at 0, and the density from
// the EOS; n_b the wall's normal (all of g where it has none). No memory, so no pressure cushion under a
// thinning, spreading layer. Only g's component across the wall: along a bed, gravity drives a flow against
// its basal shear, not against a pressure gradient, and Adami's full g.(x_b - x_f) made the wall particles
// downslope of a sheet's edge push harder than those upslope, holding a one-particle row on a 30 degree slope
// to a third of the Coulomb slide's speed (docs/design.md, "Thin sheets, walls and basal friction").
#include <algorithm>
#include <cmath>

#include "particle_wall.hpp"
#include "runout/engine/eos.hpp"

namespace runout {
namespace wall {

struct extrapolated {
  template <int D>
  using Pairs = ParticleWall<D>;

  // Shepard sums over the fluid-wall pairs of the lists (n fluid particles), then p_b and rho_b.
  template <int D, class Kernel, class ImplT>
  static void update_pressure(const PassContext<D>& c, const Kernel& kernel, ImplT& I, size_t n, const TaitEOS& eos,
                              real* pressure, real* density) {
    // Each active wall particle's accumulator record: the Shepard sum of W and of the pressure it extrapolates.
    constexpr int kW = 0, kPW = 1, kFields = 2;
    I.accumulate(
        n, 0, kFields,
        [&](real*, real* Bacc, auto&) {
          I.for_each_fluid([&](uint32_t i) {
            const uint32_t* L = I.list_of(i) + I.pairs.lists.nf[i];
            for (uint32_t q = 0; q < I.pairs.lists.nb[i]; ++q) {
              const uint32_t b = L[q];
              real r2 = 0, gdx = 0, gn = 0, ndx = 0, nn = 0;
              for (int d = 0; d < D; ++d) {
                // x_b - x_f up to the periodic image: the same as -(x_i - x_b) from the fluid's side.
                real dxd = c.BP[d][b] - c.P[d][i];
                if (c.any_periodic && c.period[d] > 0) dxd -= c.period[d] * std::round(dxd / c.period[d]);
                r2 += dxd * dxd;
                gdx += c.g[d] * dxd;
                const real nd = c.BN[d][b];
                gn += c.g[d] * nd, ndx += nd * dxd, nn += nd * nd;
              }
              if (nn > 0) gdx = gn * ndx;
              const real w = kernel.W(std::sqrt(r2));
              real* rec = Bacc + kFields * c.bslot[b];
              rec[kW] += w;
              rec[kPW] += (c.press[i] + c.rho[i] * gdx) * w;
            }
          });
        },
        [](auto&&, size_t, auto&) {},
        [&](auto&& bsum, uint32_t b, uint32_t s) {
          const real sw = bsum(kW, s), spw = bsum(kPW, s);
          const real pb = sw > 0 ? std::max(spw / sw, 0.0) : 0.0;
          pressure[b] = pb;
          density[b] = eos.density(pb);
        });
  }
};

}  // namespace wall
}  // namespace runout
