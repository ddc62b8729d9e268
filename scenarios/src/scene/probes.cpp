// The point probes' scene side (pressure_probe, depth_gauge, face_pressure): their points into the run's frame.
// On terrain a point is [x, y] in map coordinates and its height comes from the bed under it (a pressure probe's
// optional z is its height above the bed; a face sensor's z is its elevation); elsewhere it is written in the
// scene's own coordinates, the vertical last.
// Every point must lie in the run's domain (the plan axes within it, the vertical above its bottom: the top is
// open), and on terrain over the modelled bed.
#include "readers.hpp"

#include <algorithm>
#include <cmath>

namespace runout::scene_reader {
namespace {

// `key` as an array of numbers in its declared range, of one of the accepted lengths.
std::vector<real> read_coordinates(const Fields& f, const FieldSpec& key, const std::vector<size_t>& lengths) {
  const ParameterSpec& c = key.parameters.front();
  const json& v = f.raw(key.key);
  const bool length_ok = v.is_array() && std::find(lengths.begin(), lengths.end(), v.size()) != lengths.end();
  if (!length_ok) {
    std::string which;
    for (size_t n : lengths) which += (which.empty() ? "" : " or ") + std::to_string(n);
    throw SceneError(f.at(key.key), "must be an array of " + which + " numbers (m)");
  }
  std::vector<real> out;
  for (size_t k = 0; k < v.size(); ++k)
    out.push_back(Fields::check_number(v[k], f.at(key.key) + "[" + std::to_string(k) + "]", c.lo, c.hi, c.lo_open,
                                       c.hi_open));
  return out;
}

// A point of the run's frame must be in the domain; the message gives the scene's coordinates (map ones on
// terrain) and names the field (with `per_coordinate`, the coordinate's: point[1]).
template <int D>
void check_in_domain(const Build<D>& b, const std::string& field, const std::array<real, 3>& p, bool per_coordinate) {
  const real shift[2] = {b.tmodel ? b.tmodel->origin_x : 0.0, b.tmodel ? b.tmodel->origin_y : 0.0};
  for (int d = 0; d < D; ++d) {
    const real lo = b.cfg.domain_min[d], hi = b.cfg.domain_max[d];
    const bool vertical = d == D - 1;
    if (p[d] >= lo && (vertical || p[d] <= hi)) continue;
    const real s = d < 2 ? shift[d] : 0.0;
    const std::string axis = std::string(1, "xyz"[d]);
    const std::string range = vertical ? "at least " + fmt(lo + s) : "in [" + fmt(lo + s) + ", " + fmt(hi + s) + "]";
    const bool name_coordinate = per_coordinate && !(b.tmodel && vertical);  // terrain: the height is the bed's
    throw SceneError(name_coordinate ? field + "[" + std::to_string(d) + "]" : field,
                     axis + " must be " + range + " m, in the domain (got " + fmt(p[d] + s) + ")");
  }
}

// The bed's height under a local plan point; refused off the modelled corridor (no bed there).
template <int D>
real bed_under(const Build<D>& b, const std::string& field, real x, real y) {
  const double z = b.tmodel->bed_at(x, y);
  if (std::isnan(z))
    throw SceneError(field, "(" + fmt(x + b.tmodel->origin_x) + ", " + fmt(y + b.tmodel->origin_y) +
                                ") is off the modelled corridor: no bed under it");
  return z;
}

// Stations every `spacing` or closer along a polyline (the ends and every vertex included) and their
// distances along it.
void stations_along(const terrain::Polyline& line, real spacing, std::vector<std::array<real, 2>>& at,
                    std::vector<real>& along) {
  real walked = 0;
  at.push_back(line.front());
  along.push_back(0.0);
  for (size_t k = 0; k + 1 < line.size(); ++k) {
    const real dx = line[k + 1][0] - line[k][0], dy = line[k + 1][1] - line[k][1], length = std::hypot(dx, dy);
    const long n = std::max(1L, static_cast<long>(std::ceil(length / spacing - 1e-9)));
    for (long q = 1; q <= n; ++q) {
      const real s = static_cast<real>(q) / n;
      at.push_back({line[k][0] + s * dx, line[k][1] + s * dy});
      along.push_back(walked + s * length);
    }
    walked += length;
  }
}

}  // namespace

template <int D>
void read_pressure_probe(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  const FieldSpec& key = field_spec(type.fields, "point");
  std::array<real, 3> p{0, 0, 0};
  if (b.tmodel) {
    const auto c = read_coordinates(f, key, {2, 3});
    const real height = c.size() == 3 ? c[2] : b.cfg.smoothing_length;
    if (height < 0) throw SceneError(f.at(key.key) + "[2]", "the height above the bed must be at least 0 m (got " + fmt(height) + ")");
    p = {c[0] - b.tmodel->origin_x, c[1] - b.tmodel->origin_y, 0.0};
    p[2] = bed_under(b, f.at(key.key), p[0], p[1]) + height;
  } else {
    const auto c = read_coordinates(f, key, {static_cast<size_t>(D)});
    for (int d = 0; d < D; ++d) p[d] = c[d];
  }
  check_in_domain(b, f.at(key.key), p, true);
  spec.probe_points = {p};
  spec.wet_kernel_sum = read_parameter(f, field_spec(type.fields, "wet_kernel_sum").parameters.front());
}

template <int D>
void read_depth_gauge(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  const bool has_point = f.has("point"), has_line = f.has("line");
  if (has_point == has_line) throw SceneError(f.at("point"), "give one of point or line (the stations' feet)");
  if (f.has("floor") && (has_point || b.tmodel || D == 2))
    throw SceneError(f.at("floor"), has_point ? "only with a line: a point's floor is its last coordinate"
                                              : "only with a 3D line off terrain (the floor is the bed, or the line's y)");
  spec.wet_kernel_sum = read_parameter(f, field_spec(type.fields, "wet_kernel_sum").parameters.front());
  const real ox = b.tmodel ? b.tmodel->origin_x : 0.0, oy = b.tmodel ? b.tmodel->origin_y : 0.0;
  if (has_point) {
    const FieldSpec& key = field_spec(type.fields, "point");
    const auto c = read_coordinates(f, key, {static_cast<size_t>(b.tmodel ? 2 : D)});
    std::array<real, 3> p{0, 0, 0};
    for (size_t d = 0; d < c.size(); ++d) p[d] = c[d];
    if (b.tmodel) p = {c[0] - ox, c[1] - oy, bed_under(b, f.at(key.key), c[0] - ox, c[1] - oy)};
    check_in_domain(b, f.at(key.key), p, true);
    spec.probe_points = {p};
    return;
  }
  const FieldSpec& key = field_spec(type.fields, "line");
  ShapeSource src{b.base_dir, {}};
  if (b.tmodel) src.working_crs = [&b] { return b.tmodel->dem.crs_wkt; };
  terrain::Polyline line = read_shape(f.raw(key.key), f.at(key.key), key.min_points, terrain::ShapeKind::line, src);
  for (auto& q : line) q = {q[0] - ox, q[1] - oy};
  const real spacing = read_parameter(f, field_spec(type.fields, "spacing").parameters.front());
  std::vector<std::array<real, 2>> at;
  stations_along(line, spacing > 0 ? spacing : b.dp, at, spec.probe_stations);
  constexpr size_t kMaxStations = 100000;  // each sample searches every station's vertical
  if (at.size() > kMaxStations)
    throw SceneError(f.at("spacing"), "gives " + std::to_string(at.size()) + " stations along the line (at most " +
                                          std::to_string(kMaxStations) + "): raise it");
  const real floor = read_parameter(f, field_spec(type.fields, "floor").parameters.front());
  for (const auto& q : at) {
    std::array<real, 3> p = {q[0], q[1], 0.0};  // 2D: x and the floor's height
    if constexpr (D == 3) p[2] = b.tmodel ? bed_under(b, f.at(key.key), q[0], q[1]) : floor;
    check_in_domain(b, f.at(key.key), p, false);
    spec.probe_points.push_back(p);
  }
}

template <int D>
void read_face_point(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  const FieldSpec& key = field_spec(type.fields, "point");
  const auto c = read_coordinates(f, key, {static_cast<size_t>(D)});
  std::array<real, 3> p{0, 0, 0};
  for (int d = 0; d < D; ++d) p[d] = c[d];
  if (b.tmodel) p[0] -= b.tmodel->origin_x, p[1] -= b.tmodel->origin_y;
  check_in_domain(b, f.at(key.key), p, true);
  spec.probe_points = {p};
}

template void read_face_point<2>(const Build<2>&, const Fields&, const MonitorType&, MonitorSpec&);
template void read_face_point<3>(const Build<3>&, const Fields&, const MonitorType&, MonitorSpec&);
template void read_pressure_probe<2>(const Build<2>&, const Fields&, const MonitorType&, MonitorSpec&);
template void read_pressure_probe<3>(const Build<3>&, const Fields&, const MonitorType&, MonitorSpec&);
template void read_depth_gauge<2>(const Build<2>&, const Fields&, const MonitorType&, MonitorSpec&);
template void read_depth_gauge<3>(const Build<3>&, const Fields&, const MonitorType&, MonitorSpec&);

}  // namespace runout::scene_reader
