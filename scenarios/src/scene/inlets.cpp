// The inlets section: velocity inlets across a vertical plane (engine InletSpec); the speed is given, or the
// discharge over the opening's area as the buffer fills it (whole particles: floor(size / dp) per axis).
#include "readers.hpp"

#include <algorithm>
#include <cmath>

namespace runout::scene_reader {

const std::set<std::string>& inlet_keys() {
  static const std::set<std::string> keys = {"name", "material", "direction", "at", "min", "max", "speed", "discharge"};
  return keys;
}

namespace {

// The opening across the plane (2D: [z]; 3D: the other horizontal axis, then z) as lanes of dp over a flat
// floor at min's z; returns its area (whole particles per axis).
template <int D>
real read_opening(const Fields& f, real dp, int axis, InletSpec<D>& in) {
  const auto lo = f.vector("min", D - 1), hi = f.vector("max", D - 1);
  for (int a = 0; a < D - 1; ++a)
    if (std::floor((hi[a] - lo[a]) / dp + 1e-9) < 1)
      throw SceneError(f.at("max"), "must exceed min by at least dp = " + fmt(dp) + " m on every axis (got " +
                                        fmt(hi[a] - lo[a]) + " m)");
  size_t lanes = 1;
  if constexpr (D == 3) {
    const int side = 1 - axis;  // the other horizontal axis
    in.origin[side] = lo[0];
    in.across = Vec<D>::Unit(side);
    lanes = static_cast<size_t>(std::floor((hi[0] - lo[0]) / dp + 1e-9));
  }
  in.floor.assign(lanes, lo[D - 2]);
  in.slope.assign(lanes, 0.0);
  in.depth = hi[D - 2] - lo[D - 2];
  return in.opening_area(dp);
}

// speed or discharge: a number, or a hydrograph of [t, value] pairs; discharges become speeds over `area`.
template <int D>
void read_speed(const Fields& f, const std::string& path, real area, InletSpec<D>& in) {
  if (f.has("speed") == f.has("discharge"))
    throw SceneError(path, "give exactly one of speed (m/s) and discharge (m3/s; m2/s in 2D)");
  const std::string key = f.has("speed") ? "speed" : "discharge";
  const real scale = key == "speed" ? 1.0 : 1.0 / area;
  const json& v = f.raw(key);
  if (v.is_number()) {
    in.speed.push_back({0.0, scale * Fields::check_number(v, f.at(key), 0.0, 1e6, false, false)});
  } else if (v.is_array() && !v.empty()) {
    for (size_t q = 0; q < v.size(); ++q) {
      const std::string at = f.at(key) + "[" + std::to_string(q) + "]";
      if (!v[q].is_array() || v[q].size() != 2) throw SceneError(at, "must be a [t (s), value] pair");
      const real t = Fields::check_number(v[q][0], at + "[0]", 0.0, 1e7, false, false);
      if (q > 0 && !(t > in.speed.back()[0])) throw SceneError(at + "[0]", "times must increase");
      in.speed.push_back({t, scale * Fields::check_number(v[q][1], at + "[1]", 0.0, 1e6, false, false)});
    }
  } else {
    throw SceneError(f.at(key), "must be a number >= 0 or an array of [t, value] pairs (a hydrograph)");
  }
}

template <int D>
InletSpec<D> read_inlet(Build<D>& b, const json& j, size_t k, const std::vector<std::string>& dirs) {
  const std::string path = item("inlets", k);
  Fields f(j, path, inlet_keys());
  InletSpec<D> in;
  in.name = f.string_or("name", "inlet" + std::to_string(k + 1));
  const std::string mat = f.string("material");
  if (!b.material_index.count(mat)) throw SceneError(f.at("material"), "no material named '" + mat + "'");
  in.material = b.material_index[mat];
  const std::string dir = f.string("direction", dirs);
  const int axis = dir[1] == 'x' ? 0 : 1;
  in.normal = (dir[0] == '+' ? 1.0 : -1.0) * Vec<D>::Unit(axis);
  in.origin[axis] = f.number("at", -1e7, 1e7);
  const real area = read_opening(f, b.dp, axis, in);
  read_speed(f, path, area, in);
  return in;
}

// A terrain's hydrograph release as an inlet: lanes of dp along the line, each over the bed. The floor of a
// lane is the secant of the bed over the strip behind the line, raised where the bed rises above it, so the
// buffer never runs through the ground (it may float a little over a hollow, as a surge does).
template <int D>
InletSpec<D> terrain_inlet(const Build<D>& b) {
  const auto& tm = *b.tmodel;
  const auto& fields = hydrograph_fields();
  const Fields r(b.j.at("release"), "release", field_keys(release_fields()));
  const Fields h(r.raw("hydrograph"), "release.hydrograph", field_keys(fields));
  InletSpec<D> in;
  in.name = "release";
  in.material = b.material_index.at(b.release_material);
  const auto& line = tm.inflow_line;
  const real length = std::hypot(line[1][0] - line[0][0], line[1][1] - line[0][1]);
  const size_t lanes = static_cast<size_t>(std::floor(length / b.dp + 1e-6));  // map coordinates: ~1e-9 m rounding
  if (lanes < 1) throw SceneError(h.at("line"), "must be at least dp = " + fmt(b.dp) + " m long");
  in.normal = Vec<D>::Zero();
  in.normal[0] = tm.inflow_normal[0];
  in.normal[1] = tm.inflow_normal[1];
  in.origin = Vec<D>::Zero();
  in.origin[0] = line[0][0] - tm.origin_x;
  in.origin[1] = line[0][1] - tm.origin_y;
  in.across = Vec<D>::Zero();
  in.across[0] = (line[1][0] - line[0][0]) / length;
  in.across[1] = (line[1][1] - line[0][1]) / length;
  in.depth = read_parameter(h, field_spec(fields, "depth").parameters.front());
  const real strip = kInflowStripLayers * b.dp;
  for (size_t k = 0; k < lanes; ++k) {
    const Vec<D> front = in.origin + (k + 0.5) * b.dp * in.across;
    auto bed = [&](real s) {
      const Vec<D> p = front + s * in.normal;
      return tm.bed_at(p[0], p[1]);
    };
    const real z0 = bed(0), zb = bed(-strip);
    if (std::isnan(z0) || std::isnan(zb))
      throw SceneError(h.at("line"), "lane " + std::to_string(k) + " of the inflow has no bed under it or behind it");
    const real slope = (z0 - zb) / strip;
    real lift = 0;
    for (real s = -strip; s <= 0; s += 0.5 * b.dp) {
      const real z = bed(s);
      if (!std::isnan(z)) lift = std::max(lift, z - (z0 + slope * s));
    }
    in.floor.push_back(z0 + lift);
    in.slope.push_back(slope);
  }
  const real area = in.opening_area(b.dp);
  if (!(area > 0)) throw SceneError(h.at("depth"), "must be at least dp = " + fmt(b.dp) + " m");
  if (h.has("discharge") == (h.has("volume") || h.has("duration")) || h.has("volume") != h.has("duration"))
    throw SceneError("release.hydrograph",
                     "give either discharge ([[t, Q], ...] in m3/s) or volume (m3) with duration (s)");
  if (h.has("discharge")) {
    read_speed(h, "release.hydrograph", area, in);
  } else {
    // A surge: the peak at once, falling linearly to nothing at `duration`, its integral the volume.
    auto needed = [&](const std::string& key) {  // volume and duration come together (checked above)
      ParameterSpec p = field_spec(fields, key).parameters.front();
      p.required = true;
      return read_parameter(h, p);
    };
    const real volume = needed("volume"), duration = needed("duration");
    in.speed = {{0.0, 2 * volume / duration / area}, {duration, 0.0}};
  }
  return in;
}

}  // namespace

template <int D>
void read_inlets(Build<D>& b) {
  if (b.tmodel && !b.tmodel->inflow_line.empty()) {
    InletSpec<D> in = terrain_inlet(b);
    for (const auto& sp : in.speed) b.inlet_speed_max = std::max(b.inlet_speed_max, sp[1]);
    b.setup.inlets.push_back(std::move(in));
  }
  if (!b.top.has("inlets")) return;
  if (b.tmodel) throw SceneError("inlets", "inlets are for scenes without terrain (flumes, channels) in this version");
  const json& ins = b.top.raw("inlets");
  if (!ins.is_array() || ins.empty()) throw SceneError("inlets", "must be a non-empty array of inlet objects");
  std::vector<std::string> dirs = {"+x", "-x"};
  if (D == 3) dirs.insert(dirs.end(), {"+y", "-y"});
  for (size_t k = 0; k < ins.size(); ++k) {
    InletSpec<D> in = read_inlet(b, ins[k], k, dirs);
    for (const auto& sp : in.speed) b.inlet_speed_max = std::max(b.inlet_speed_max, sp[1]);
    for (real z : in.floor) {
      b.fluid_top = std::max(b.fluid_top, z + in.depth);
      b.fluid_bottom = std::min(b.fluid_bottom, z);
    }
    b.setup.inlets.push_back(std::move(in));
  }
}

template void read_inlets<2>(Build<2>&);
template void read_inlets<3>(Build<3>&);

}  // namespace runout::scene_reader
