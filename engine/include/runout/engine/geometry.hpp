#pragma once
// Scene primitives without a DEM. Everything is an oriented box: a corner `origin`, extents `size` along
// local axes, and a tilt `angle_deg` that rotates local x downwards about the horizontal axis normal to the
// x-vertical plane (so a plane at angle 30 descends along +x). Lattice points sit at (k + 1/2) dp in local
// coordinates, so fluid and walls built from the same faces stay dp apart.
#include <array>
#include <limits>
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

// The segment of a plane polyline nearest to a point (section lines, dam axes, structure outlines: map or
// scene x, y). One loop for every caller; where callers genuinely want different answers, the rule is an
// option. Equally near segments: the first (lowest index) wins, for every caller.
struct SegmentRules {
  // A point that projects beyond a segment's ends: `clamp` measures to the nearest end, so every segment
  // competes and a point beyond the line's ends is nearest to an end segment; `skip` leaves the segment out,
  // so only segments whose extent the point is in compete (there may be none).
  enum class Ends { clamp, skip } ends = Ends::clamp;
  // The side of a point exactly on the nearest segment's line (its cross product 0): +1 or -1.
  int on_line_side = 1;
  // A zero-length segment (two equal consecutive points): a point to measure to, or left out.
  bool skip_zero_length = false;
};

struct NearestSegment {
  int index = -1;     // segment k joins points k and k + 1; -1: no segment competed
  double t = 0;       // parameter along it, 0 at point k, 1 at point k + 1 (in [0, 1] under both rules)
  double distance = std::numeric_limits<double>::infinity();  // to the point at t
  int side = 0;       // +1 left of the segment's direction (counter-clockwise), -1 right; 0 if index is -1
};

NearestSegment nearest_segment(const std::vector<std::array<double, 2>>& line, double x, double y,
                               const SegmentRules& rules = {});

}  // namespace runout
