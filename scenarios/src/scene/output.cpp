// The output section (docs/scene-format.md, "Output"): its keys declared once (output_fields()), read by the
// parser, `runout schema` and the docs' generated table.
#include <algorithm>

#include "readers.hpp"
#include "runout/terrain/hazard.hpp"

namespace runout::scene_reader {
namespace {

// output.intensity: the intensity classes' thresholds (terrain::intensity_parameters()), medium below high.
terrain::IntensityThresholds read_intensity(const Fields& out) {
  terrain::IntensityThresholds t;
  if (!out.has("intensity")) return t;
  const auto& specs = terrain::intensity_parameters();
  std::set<std::string> keys;
  for (const auto& p : specs) keys.insert(p.key);
  Fields f(out.raw("intensity"), out.at("intensity"), keys);
  t.high_depth = read_parameter(f, parameter_spec(specs, "high_depth"));
  t.high_hv = read_parameter(f, parameter_spec(specs, "high_hv"));
  t.medium_depth = read_parameter(f, parameter_spec(specs, "medium_depth"));
  t.medium_hv = read_parameter(f, parameter_spec(specs, "medium_hv"));
  if (!(t.medium_depth < t.high_depth))
    throw SceneError(f.at("medium_depth"), "must be below high_depth (" + fmt(t.high_depth) + " m)");
  if (!(t.medium_hv < t.high_hv))
    throw SceneError(f.at("medium_hv"), "must be below high_hv (" + fmt(t.high_hv) + " m2/s)");
  return t;
}

const ParameterSpec& spec(const std::string& key) { return field_spec(output_fields(), key).parameters.front(); }

}  // namespace

const std::vector<FieldSpec>& output_fields() {
  static const std::vector<FieldSpec> fields = [] {
    FieldSpec intensity = shaped_field(
        "intensity", "object",
        "terrain scenes: thresholds of the debris-flow intensity classes of rasters/intensity.tif (medium below high)",
        false);
    intensity.parameters = terrain::intensity_parameters();
    return std::vector<FieldSpec>{
        number_field({"series_interval", "s", 0.01, 0.0, 1e4, true, false, false,
                      "simulated time between rows of series/run.csv"},
                     0, "min(0.01, duration / 100)"),
        number_field({"snapshot_interval", "s", 0.0, 0.0, 1e4, false, false, false,
                      "between snapshots with --snapshots; 0 means 20 over the run"}),
        number_field({"inundation_threshold", "m", 0.1, 0.0, 100.0, true, false, false,
                      "terrain scenes: a raster cell whose max depth reaches this counts as inundated"}),
        number_field({"rest_speed", "m/s", 0.0, 0.0, 100.0, false, false, false,
                      "the run ends before duration once the flow (the share rest_quantile of its particles) has "
                      "stayed slower than this for rest_time; 0 runs the whole duration"}),
        number_field({"rest_time", "s", 1.0, 0.0, 1e4, true, false, false, "how long the flow must stay under rest_speed"}),
        number_field({"rest_quantile", "", 1.0, 0.0, 1.0, true, false, false,
                      "the share of the flow particles that must be slower than rest_speed; 1 waits for every one"}),
        intensity};
  }();
  return fields;
}

OutputSettings read_output(const json& j, real duration) {
  std::set<std::string> keys;
  for (const auto& f : output_fields()) keys.insert(f.key);
  Fields out(j.contains("output") ? j["output"] : json::object(), "output", keys);
  OutputSettings o;
  const ParameterSpec& series = spec("series_interval");
  o.series_interval = out.number_or(series.key, std::min(0.01, duration / 100.0), series.lo, series.hi, series.lo_open,
                                    series.hi_open);
  o.snapshot_interval = read_parameter(out, spec("snapshot_interval"));
  o.inundation_threshold = read_parameter(out, spec("inundation_threshold"));
  o.rest_speed = read_parameter(out, spec("rest_speed"));
  o.rest_time = read_parameter(out, spec("rest_time"));
  o.rest_quantile = read_parameter(out, spec("rest_quantile"));
  o.intensity = read_intensity(out);
  return o;
}

}  // namespace runout::scene_reader
