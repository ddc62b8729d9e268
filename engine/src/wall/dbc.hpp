#pragma once
// Dynamic boundary condition (Crespo et al. 2007): wall particles carry a density by the continuity
// equation (the passes' wall_continuity) and take their pressure from the Tait EOS.
#include "particle_wall.hpp"
#include "runout/engine/eos.hpp"

namespace runout {
namespace wall {

struct dbc {
  template <int D>
  using Pairs = ParticleWall<D>;

  // Pressure of the active wall particles from their own density.
  template <int D, class Kernel, class ImplT>
  static void update_pressure(const PassContext<D>&, const Kernel&, ImplT& I, size_t, const TaitEOS& eos,
                              real* pressure, real* density) {
    I.cells.for_each_active_wall([&](uint32_t b) { pressure[b] = eos.pressure(density[b]); });
  }
};

}  // namespace wall
}  // namespace runout
