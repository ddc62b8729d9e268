#include "runout/engine/geometry.hpp"

#include <algorithm>
#include <cmath>

namespace runout {

template <int D>
Vec<D> OrientedBox<D>::axis(int d) const {
  const real a = angle_deg * kPi / 180.0;
  Vec<D> e = Vec<D>::Zero();
  if (d == 0) {
    e[0] = std::cos(a);
    e[D - 1] = -std::sin(a);
  } else if (d == D - 1) {
    e[0] = std::sin(a);
    e[D - 1] = std::cos(a);
  } else {
    e[d] = 1.0;
  }
  return e;
}

template <int D>
Vec<D> OrientedBox<D>::to_world(const Vec<D>& local) const {
  Vec<D> p = origin;
  for (int d = 0; d < D; ++d) p += local[d] * axis(d);
  return p;
}

template <int D>
Vec<D> OrientedBox<D>::to_local(const Vec<D>& world) const {
  const Vec<D> r = world - origin;
  Vec<D> l;
  for (int d = 0; d < D; ++d) l[d] = r.dot(axis(d));
  return l;
}

template <int D>
bool LeakRegion<D>::contains(const Vec<D>& p) const {
  const Vec<D> l = box.to_local(p);
  for (int d = 0; d < D; ++d)
    if (l[d] < 0.0 || l[d] > box.size[d]) return false;
  return true;
}

namespace {

template <int D>
std::array<int, D> counts(const Vec<D>& lo, const Vec<D>& hi, real dp) {
  std::array<int, D> n{};
  for (int d = 0; d < D; ++d) n[d] = std::max(0, static_cast<int>(std::floor((hi[d] - lo[d]) / dp + 1e-9)));
  return n;
}

// Calls f(local point) for lattice points (k + 1/2) dp in [lo, hi) per axis.
template <int D, class F>
void for_lattice(const Vec<D>& lo, const Vec<D>& hi, real dp, F&& f) {
  const auto n = counts<D>(lo, hi, dp);
  std::array<int, D> k{};
  long total = 1;
  for (int d = 0; d < D; ++d) total *= n[d];
  for (long idx = 0; idx < total; ++idx) {
    long r = idx;
    Vec<D> p;
    for (int d = 0; d < D; ++d) {
      k[d] = static_cast<int>(r % n[d]);
      r /= n[d];
      p[d] = lo[d] + (k[d] + 0.5) * dp;
    }
    f(p);
  }
}

}  // namespace

template <int D>
Lattice<D> fill_box(const OrientedBox<D>& box, real dp) {
  Lattice<D> out;
  const real cos_a = std::cos(box.angle_deg * kPi / 180.0);
  for_lattice<D>(Vec<D>::Zero(), box.size, dp, [&](const Vec<D>& l) {
    out.points.push_back(box.to_world(l));
    out.depth.push_back((box.size[D - 1] - l[D - 1]) * cos_a);
  });
  return out;
}

template <int D>
std::vector<Vec<D>> solid_box_shell(const OrientedBox<D>& box, real dp, int layers, const FaceMask<D>& open) {
  std::vector<Vec<D>> out;
  const real skin = layers * dp;
  for_lattice<D>(Vec<D>::Zero(), box.size, dp, [&](const Vec<D>& l) {
    bool near_face = false;
    for (int d = 0; d < D; ++d) {
      if (!open[d][0] && l[d] < skin) near_face = true;
      if (!open[d][1] && box.size[d] - l[d] < skin) near_face = true;
    }
    if (near_face) out.push_back(box.to_world(l));
  });
  return out;
}

template <int D>
std::vector<Vec<D>> tank_walls(const OrientedBox<D>& inner, real dp, int layers, const FaceMask<D>& open) {
  std::vector<Vec<D>> out;
  Vec<D> lo, hi;
  for (int d = 0; d < D; ++d) {
    lo[d] = open[d][0] ? 0.0 : -layers * dp;
    hi[d] = open[d][1] ? inner.size[d] : inner.size[d] + layers * dp;
  }
  for_lattice<D>(lo, hi, dp, [&](const Vec<D>& l) {
    bool inside = true;
    for (int d = 0; d < D; ++d) inside = inside && l[d] > 0.0 && l[d] < inner.size[d];
    if (!inside) out.push_back(inner.to_world(l));
  });
  return out;
}

template <int D>
std::vector<LeakRegion<D>> solid_box_leak_regions(const OrientedBox<D>& box, real dp, const FaceMask<D>& open,
                                                  int tag) {
  // The whole solid shrunk by half a spacing on closed faces; open faces are not leak surfaces.
  Vec<D> lo, hi;
  for (int d = 0; d < D; ++d) {
    lo[d] = open[d][0] ? 0.0 : 0.5 * dp;
    hi[d] = open[d][1] ? box.size[d] : box.size[d] - 0.5 * dp;
  }
  LeakRegion<D> r;
  r.tag = tag;
  r.box.angle_deg = box.angle_deg;
  r.box.origin = box.to_world(lo);
  r.box.size = hi - lo;
  return {r};
}

template <int D>
std::vector<LeakRegion<D>> tank_leak_regions(const OrientedBox<D>& inner, real dp, int layers,
                                             const FaceMask<D>& open, int tag) {
  // One slab behind each closed face, starting half a spacing behind the face (past the first layer).
  std::vector<LeakRegion<D>> out;
  const real depth = layers * dp;
  for (int d = 0; d < D; ++d) {
    for (int side = 0; side < 2; ++side) {
      if (open[d][side]) continue;
      Vec<D> lo, hi;
      for (int e = 0; e < D; ++e) {
        lo[e] = -depth;
        hi[e] = inner.size[e] + depth;
      }
      if (side == 0) {
        lo[d] = -depth;
        hi[d] = -0.5 * dp;
      } else {
        lo[d] = inner.size[d] + 0.5 * dp;
        hi[d] = inner.size[d] + depth;
      }
      LeakRegion<D> r;
      r.tag = tag;
      r.box.angle_deg = inner.angle_deg;
      r.box.origin = inner.to_world(lo);
      r.box.size = hi - lo;
      out.push_back(r);
    }
  }
  return out;
}

#define RUNOUT_INSTANTIATE(D)                                                                                  \
  template struct OrientedBox<D>;                                                                              \
  template struct LeakRegion<D>;                                                                               \
  template Lattice<D> fill_box<D>(const OrientedBox<D>&, real);                                                \
  template std::vector<Vec<D>> solid_box_shell<D>(const OrientedBox<D>&, real, int, const FaceMask<D>&);       \
  template std::vector<Vec<D>> tank_walls<D>(const OrientedBox<D>&, real, int, const FaceMask<D>&);            \
  template std::vector<LeakRegion<D>> solid_box_leak_regions<D>(const OrientedBox<D>&, real, const FaceMask<D>&, \
                                                                int);                                          \
  template std::vector<LeakRegion<D>> tank_leak_regions<D>(const OrientedBox<D>&, real, int, const FaceMask<D>&, \
                                                           int);
RUNOUT_INSTANTIATE(2)
RUNOUT_INSTANTIATE(3)
#undef RUNOUT_INSTANTIATE

// Compiled without fused multiply-adds: the engine is built for the machine's CPU, terrain and scenarios
// (which measure their dam axes and outlines here) are not, and a grid cell exactly equidistant from two
// segments, or exactly on an axis, must come out as it did when they measured it themselves.
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
NearestSegment nearest_segment(const std::vector<std::array<double, 2>>& line, double x, double y,
                               const SegmentRules& rules) {
  NearestSegment best;
  for (size_t k = 0; k + 1 < line.size(); ++k) {
    const double ax = line[k][0], ay = line[k][1];
    const double ex = line[k + 1][0] - ax, ey = line[k + 1][1] - ay;
    const double len2 = ex * ex + ey * ey;
    if (len2 == 0 && rules.skip_zero_length) continue;
    double t = len2 > 0 ? ((x - ax) * ex + (y - ay) * ey) / len2 : 0.0;
    if (rules.ends == SegmentRules::Ends::skip && (t < 0 || t > 1)) continue;
    t = std::clamp(t, 0.0, 1.0);
    const double d = std::hypot(x - (ax + t * ex), y - (ay + t * ey));
    if (!(d < best.distance)) continue;
    const double cross = ex * (y - ay) - ey * (x - ax);
    best = {static_cast<int>(k), t, d, cross > 0 ? 1 : cross < 0 ? -1 : rules.on_line_side};
  }
  return best;
}
#pragma GCC pop_options

}  // namespace runout
