#pragma once
// Scene primitives without a DEM. Everything is an oriented box: a corner `origin`, extents `size` along
// local axes, and a tilt `angle_deg` that rotates local x downwards about the horizontal axis normal to the
// x-vertical plane (so a plane at angle 30 descends along +x). Lattice points sit at (k + 1/2) dp in local
// coordinates, so fluid and walls built from the same faces stay dp apart.
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

template <int D>
struct OrientedBox {
  Vec<D> origin = Vec<D>::Zero();
  Vec<D> size = Vec<D>::Zero();
  real angle_deg = 0.0;

  Vec<D> to_world(const Vec<D>& local) const;
  Vec<D> to_local(const Vec<D>& world) const;
  Vec<D> axis(int d) const;  // world direction of local axis d
};

// Which faces of a box are open: open[d][0] is the low face of axis d, open[d][1] the high one.
template <int D>
using FaceMask = std::array<std::array<bool, 2>, D>;

// A region a fluid particle must never enter (the inside of a wall beyond its first particle layer).
template <int D>
struct LeakRegion {
  OrientedBox<D> box;
  int tag = 0;
  bool contains(const Vec<D>& p) const;
};

template <int D>
struct Lattice {
  std::vector<Vec<D>> points;
  std::vector<real> depth;  // vertical depth below the top face, for hydrostatic initial density
};

// Lattice points filling a box (fluid blocks).
template <int D>
Lattice<D> fill_box(const OrientedBox<D>& box, real dp);

// Boundary particles `layers` deep inside the faces of a solid box (a pillar, a dam, a bed slab).
// Faces marked open get no layers.
template <int D>
std::vector<Vec<D>> solid_box_shell(const OrientedBox<D>& box, real dp, int layers, const FaceMask<D>& open);

// Boundary particles in `layers` outside the closed faces of an inner box (a tank holding fluid).
template <int D>
std::vector<Vec<D>> tank_walls(const OrientedBox<D>& inner, real dp, int layers, const FaceMask<D>& open);

// Leak regions for the same shapes: the solid minus half a spacing under each closed face.
template <int D>
std::vector<LeakRegion<D>> solid_box_leak_regions(const OrientedBox<D>& box, real dp, const FaceMask<D>& open,
                                                  int tag);
template <int D>
std::vector<LeakRegion<D>> tank_leak_regions(const OrientedBox<D>& inner, real dp, int layers,
                                             const FaceMask<D>& open, int tag);

}  // namespace runout
