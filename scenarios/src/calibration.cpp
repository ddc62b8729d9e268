// Material calibration: one scene number over a list of values, fitted to an observed runout or area
// (calibration.hpp).
#include "runout/scenarios/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/terrain/vector.hpp"

namespace runout {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Where the piecewise-linear response through `points` crosses `level`: every crossing, ascending.
std::vector<double> crossings(const std::vector<std::pair<double, double>>& points, double level) {
  std::vector<double> out;
  for (size_t k = 0; k < points.size(); ++k) {
    const auto [v0, r0] = points[k];
    if (r0 == level) out.push_back(v0);
    if (k + 1 == points.size()) break;
    const auto [v1, r1] = points[k + 1];
    if ((r0 - level) * (r1 - level) < 0) out.push_back(v0 + (level - r0) * (v1 - v0) / (r1 - r0));
  }
  return out;
}

// The layout the calibration runs: the scene with every structure it has, or the sweep's variant `name`.
std::pair<fs::path, std::vector<std::string>> calibrated_layout(const fs::path& file, const std::string& variant) {
  std::ifstream in(file);
  if (!in) throw SceneError("(file)", "cannot read " + file.string());
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw SceneError("(json)", std::string("malformed JSON: ") + e.what());
  }
  if (j.is_object() && j.contains("base")) {
    const Sweep sw = load_sweep(file);
    for (const auto& v : sw.variants)
      if (v.name == variant && v.member < 0) return {fs::absolute(sw.base_path), v.structures};
    std::string names;
    for (const auto& v : sw.variants) names += (names.empty() ? "" : ", ") + v.name;
    throw SceneError("--variant", "'" + variant + "' is not a layout of the sweep (accepted: " + names + ")");
  }
  if (!variant.empty()) throw SceneError("--variant", "only with a sweep file (this is a scene)");
  std::vector<std::string> built;
  if (j.contains("structures") && j["structures"].is_array())
    for (const auto& s : j["structures"]) built.push_back(s.value("name", std::string()));
  return {fs::absolute(file), built};
}

}  // namespace

Sweep calibration_sweep(const fs::path& file, const std::string& variant, const std::string& pointer,
                        const std::vector<double>& values) {
  if (values.size() < 2 || values.size() > 64) throw SceneError("--values", "give 2 to 64 values");
  for (size_t k = 1; k < values.size(); ++k)
    if (!(values[k] > values[k - 1])) throw SceneError("--values", "must be strictly ascending");
  const auto [base, built] = calibrated_layout(file, variant);
  json scene = json::parse(std::ifstream(base));
  const std::string scene_name = scene.value("name", base.stem().string());
  const std::string layout = variant.empty() ? "cal" : variant;
  const json sweep = {{"name", "calibrate-" + scene_name + (variant.empty() ? "" : "-" + variant)},
                      {"base", base.string()},
                      {"variants", {{{"name", layout}, {"structures", built}}}},
                      {"ensemble", {{"parameters", {{{"pointer", pointer}, {"values", values}}}}}}};
  try {
    return parse_sweep(sweep.dump(), base.parent_path());
  } catch (const SceneError& e) {  // the ensemble's fields are this command's options
    if (e.field.rfind("ensemble.parameters[0].pointer", 0) == 0)
      throw SceneError("--parameter", std::string(e.what()).substr(e.field.size() + 2));
    throw;
  }
}

CalibrationFit fit_runout(const std::vector<std::pair<double, double>>& points, double target,
                          std::optional<double> tolerance) {
  CalibrationFit f;
  if (points.empty()) return f;
  const auto at = crossings(points, target);
  if (at.empty()) {
    const bool above = points.front().second > target;
    f.best_how = std::string("the runout stays ") + (above ? "above" : "below") + " " + num(target) +
                 " m over the range: widen it";
  } else {
    f.best = at.front();
    f.best_how = "runout crosses " + num(target) + " m (linear between the bracketing values)" +
                 (at.size() > 1 ? "; it crosses " + std::to_string(at.size()) + " times: not monotone over the range" : "");
  }
  if (!tolerance) return f;
  std::vector<double> ends = crossings(points, target - *tolerance);
  const auto hi = crossings(points, target + *tolerance);
  ends.insert(ends.end(), hi.begin(), hi.end());
  // Values whose runout is within the scatter; the band spans them and the crossings at its edges.
  for (const auto& [v, r] : points)
    if (std::abs(r - target) <= *tolerance) ends.push_back(v);
  if (ends.empty()) {
    f.band_how = "no value's runout lies within " + num(target) + " ± " + num(*tolerance) + " m";
    return f;
  }
  f.band_lo = *std::min_element(ends.begin(), ends.end());
  f.band_hi = *std::max_element(ends.begin(), ends.end());
  f.band_how = "runout within " + num(target) + " ± " + num(*tolerance) + " m";
  // Within the scatter at an end of the range: the band may go on beyond it.
  const bool open_lo = std::abs(points.front().second - target) <= *tolerance;
  const bool open_hi = std::abs(points.back().second - target) <= *tolerance;
  if (open_lo || open_hi) f.band_how += " (open at the range's " + std::string(open_lo ? "low" : "") +
                                        (open_lo && open_hi ? " and " : "") + (open_hi ? "high" : "") + " end)";
  return f;
}

CalibrationFit fit_area(const std::vector<std::pair<double, double>>& points, std::optional<double> min_csi) {
  CalibrationFit f;
  if (points.empty()) return f;
  const auto best = std::max_element(points.begin(), points.end(),
                                     [](const auto& a, const auto& b) { return a.second < b.second; });
  f.best = best->first;
  f.best_how = "highest CSI (" + num(best->second) + ")";
  if (!min_csi) return f;
  for (const auto& [v, csi] : points)
    if (csi >= *min_csi) {
      f.band_lo = f.band_lo ? std::min(*f.band_lo, v) : v;
      f.band_hi = f.band_hi ? std::max(*f.band_hi, v) : v;
    }
  f.band_how = f.band_lo ? "CSI >= " + num(*min_csi) : "no value's CSI reaches " + num(*min_csi);
  return f;
}

AreaScore critical_success_index(const terrain::Grid& g, double threshold, const terrain::Polyline& observed) {
  // The lattice of the raster, widened (whole cells) to hold the polygon's bounding box.
  double x0 = g.x0, x1 = g.x1(), y0 = g.y0, y1 = g.y1();
  for (const auto& p : observed) x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::max(y0, p[1]), y1 = std::min(y1, p[1]);
  const long i0 = static_cast<long>(std::floor((x0 - g.x0) / g.dx)), i1 = static_cast<long>(std::ceil((x1 - g.x0) / g.dx));
  const long j0 = static_cast<long>(std::floor((g.y0 - y0) / g.dy)), j1 = static_cast<long>(std::ceil((g.y0 - y1) / g.dy));
  AreaScore s;
  for (long j = j0; j < j1; ++j)
    for (long i = i0; i < i1; ++i) {
      const bool in_raster = i >= 0 && j >= 0 && i < g.nx && j < g.ny;
      const float v = in_raster ? g.at(static_cast<int>(i), static_cast<int>(j)) : terrain::Grid::nodata;
      const bool modelled = !std::isnan(v) && v >= threshold;
      const bool seen = terrain::inside_polygon(observed, g.x0 + (i + 0.5) * g.dx, g.y0 - (j + 0.5) * g.dy);
      s.hits += modelled && seen;
      s.misses += !modelled && seen;
      s.false_alarms += modelled && !seen;
    }
  const long all = s.hits + s.misses + s.false_alarms;
  s.csi = all > 0 ? static_cast<double>(s.hits) / static_cast<double>(all) : 0.0;
  return s;
}

CalibrationResult calibrate_material(RunStore& store, const Sweep& sweep, const CalibrationTarget& target,
                                     const SweepOptions& options) {
  CalibrationResult out;
  out.sweep = sweep.name;
  out.pointer = sweep.variants.front().parameters.front().pointer;
  const SweepResult ran = run_sweep(store, sweep, options);
  std::vector<std::pair<double, double>> runouts, scores;
  for (size_t k = 0; k < sweep.variants.size(); ++k) {
    const SweepVariant& v = sweep.variants[k];
    CalibrationPoint p;
    p.value = v.parameters.front().value;
    p.variant = v.name;
    p.status = ran.runs[k].status;
    p.error = ran.runs[k].error;
    p.run_id = ran.runs[k].run_id;
    if (p.status == "completed" && p.run_id > 0) {
      const auto m = store.metrics(p.run_id);
      if (const auto it = m.find("terrain.inundation.runout_m"); it != m.end()) p.runout_m = it->second;
      const fs::path raster = options.out_root / sweep.name / v.name / "rasters" / "max_depth.tif";
      if (!target.area.empty() && fs::is_regular_file(raster)) {
        const terrain::Grid g = terrain::load_dem(raster.string());
        const auto shape = terrain::read_vector_shape({target.area.string(), target.area_layer, "", ""},
                                                      terrain::ShapeKind::multipolygon, g.crs_wkt, "--area");
        const auto t = m.find("terrain.inundation.threshold_m");
        p.area = critical_success_index(g, t == m.end() ? 0.0 : t->second, shape.path);
      }
    }
    if (p.runout_m) runouts.emplace_back(p.value, *p.runout_m);
    if (p.area) scores.emplace_back(p.value, p.area->csi);
    out.points.push_back(std::move(p));
  }
  if (target.runout_m) out.runout_fit = fit_runout(runouts, *target.runout_m, target.runout_tolerance_m);
  if (!target.area.empty()) out.area_fit = fit_area(scores, target.min_csi);
  return out;
}

}  // namespace runout
