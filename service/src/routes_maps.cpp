// Routes: the web map of a job: its rasters coloured (PNG), the hillshade, map.png and map.json (the extent,
// colour scales and geometry; server_impl.hpp, docs/service.md).
#include "runout/scenarios/raster_map.hpp"
#include "runout/scenarios/scene_map.hpp"
#include "server_impl.hpp"

namespace runout::service {

// A run's colour scales (run_raster_scales reads every raster), kept: a done run's rasters do not change, and a
// shared scale reads those of every job compared for each map.
std::vector<ColourScale> Server::Impl::raster_scales(const fs::path& out_dir) {
  {
    std::lock_guard lock(scales_mutex);
    if (auto it = scales_cache.find(out_dir.string()); it != scales_cache.end()) return it->second;
  }
  std::vector<ColourScale> scales = run_raster_scales(out_dir);
  std::lock_guard lock(scales_mutex);
  if (scales_cache.size() > 4096) scales_cache.clear();  // bounded; refilled on demand
  scales_cache[out_dir.string()] = scales;
  return scales;
}

// map.json's layers of job `j`: each raster with its picture, download, QGIS style and colour scale; with
// `shared` jobs (this one among them), each ramp spans the largest value among them (the picture's ?max=).
json Server::Impl::map_layers_json(const Job& j, const std::string& self, const std::vector<int64_t>& shared) {
  std::map<std::string, double> top;  // layer -> the shared scale's top
  try {
    if (!shared.empty()) {
      for (int64_t id : shared) {
        const Job other = require_job(std::to_string(id), "shared");
        (void)run_of(other, "shared");
        for (const auto& sc : raster_scales(out_dir_of(other)))
          top[sc.layer] = std::max(top.count(sc.layer) ? top[sc.layer] : 0.0, sc.data_max);
      }
    }
    json layers = json::array();
    const fs::path out = out_dir_of(j);
    for (ColourScale sc : raster_scales(out)) {
      const double own = sc.data_max;
      const bool widened = !sc.classes && top.count(sc.layer);
      if (widened) sc = hazard_colour_scale(sc.layer, top[sc.layer], run_inundation_threshold(out));
      json stops = json::array();
      for (const auto& st : sc.stops) stops.push_back({{"value", st.value}, {"colour", st.colour}, {"label", st.label}});
      const std::string image = self + "/rasters/" + sc.layer + ".png" + (widened ? "?max=" + json(sc.data_max).dump() : "");
      layers.push_back({{"name", sc.layer},
                        {"title", sc.title},
                        {"unit", sc.unit},
                        {"image", image},
                        {"download", self + "/rasters/" + sc.layer + ".tif"},
                        {"style", self + "/rasters/" + sc.layer + ".qml"},
                        {"scale",
                         {{"classes", sc.classes}, {"min", sc.min}, {"max", sc.max}, {"data_max", own},
                          {"shared", widened}, {"zero_transparent", sc.zero_transparent}, {"stops", stops}}}});
    }
    return layers;
  } catch (const ApiError&) {
    throw;
  } catch (const std::exception& e) {
    throw ApiError(500, "id", "cannot read the rasters of job " + std::to_string(j.id) + ": " + e.what());
  }
}

void Server::Impl::routes_maps() {
  // A raster of the job coloured for the web map (raster_map.hpp): RGBA, one pixel per cell, transparent where
  // there is nothing to show; map.json's `layers` give each one's colour scale.
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.png)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {"max"});
        const std::string name = m[2].str();
        // `max`: the ramp's top instead of the raster's own largest value (map.json?shared= gives it).
        std::optional<double> top;
        if (req.has_param("max")) top = number_param("max", req.get_param_value("max"), 1e-12, 1e15);
        const auto& layers = map_layers();
        if (std::find(layers.begin(), layers.end(), name) == layers.end()) {
          std::string list;
          for (const auto& n : layers) list += (list.empty() ? "" : ", ") + n;
          throw ApiError(404, "name", "no raster picture '" + name + "' (accepted: " + list + ")");
        }
        const Job j = require_job(m[1].str());
        (void)run_of(j);
        std::optional<RasterPicture> picture;
        try {
          picture = render_run_raster(out_dir_of(j), name, top);
        } catch (const std::exception& e) {
          throw ApiError(500, "name", "cannot render job " + m[1].str() + "'s " + name + ".tif: " + e.what());
        }
        if (!picture)
          throw ApiError(404, "name", "job " + m[1].str() + " has no raster '" + name + "' (rasters exist for terrain scenes)");
        res.status = 200;
        res.set_content(picture->png, "image/png");
      });
  // The terrain in grey (written by the run with its rasters), the web map's bottom layer.
  add(R"(/jobs/(\d{1,18})/hillshade\.png)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        send_run_file(m[1].str(), "hillshade.png", res, "image/png", false);
      });
  add(R"(/jobs/(\d{1,18})/map\.png)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        send_run_file(m[1].str(), "max_depth.png", res, "image/png", false);
      });
  // Where map.png lies on the ground, and what to draw over it: the rasters' extent and CRS, and the map geometry
  // of the job's structures, protected zones, release and cross-sections (working CRS, metres), both from
  // scenarios (scene_map.hpp).
  add(R"(/jobs/(\d{1,18})/map\.json)", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {"shared"});
    // ?shared=ids: every ramp spans the largest value among these jobs' rasters (and this one's), so that maps
    // of the jobs compared side by side mean the same colour for the same value.
    std::vector<int64_t> shared;
    if (req.has_param("shared")) shared = id_list("shared", req.get_param_value("shared"), 50);
    const Job j = require_job(m[1].str());
    if (!shared.empty() && std::find(shared.begin(), shared.end(), j.id) == shared.end()) shared.push_back(j.id);
    const int64_t run = run_of(j);
    std::optional<MapExtent> extent;
    try {
      extent = run_map_extent(out_dir_of(j));
    } catch (const std::exception& e) {
      throw ApiError(500, "id", "cannot read the extent of job " + m[1].str() + "'s max_depth.tif: " + e.what());
    }
    if (!extent) throw ApiError(404, "id", "job " + m[1].str() + " has no map (maps exist for terrain scenes)");
    const SceneMap map = scene_map(j.scene_json, opt.scene_dir);
    auto coordinates = [](const MapFeature& f) {
      json c = json::array();
      for (const auto& p : f.points) c.push_back({p[0], p[1]});
      return c;
    };
    auto geometry = [&](const MapFeature& f) {
      return f.polygon ? json{{"type", "Polygon"}, {"coordinates", json::array({coordinates(f)})}}
                       : json{{"type", "LineString"}, {"coordinates", coordinates(f)}};
    };
    json structures = json::array(), zones = json::array(), sections = json::array();
    for (const auto& st : map.structures)
      structures.push_back({{"name", st.name}, {"type", st.type}, {"geometry", geometry(st)}});
    for (const auto& z : map.protected_zones) zones.push_back({{"name", z.name}, {"geometry", geometry(z)}});
    for (const auto& sec : map.sections)
      sections.push_back({{"name", sec.name}, {"series", "section_" + sec.name}, {"geometry", geometry(sec)}});
    json release = nullptr;
    if (map.release) release = {{"geometry", geometry(*map.release)}};
    const MapExtent& g = *extent;
    const std::string self = kPrefix + "/jobs/" + m[1].str();
    json layers = map_layers_json(j, self, shared);
    const bool shaded = fs::is_regular_file(run_hillshade(out_dir_of(j)));
    // A sweep layout's difference rasters against the sweep's baseline (the job's own, write_sweep_differences).
    json differences = json::array();
    for (const std::string name : {"diff_max_depth", "diff_max_hv"})
      if (!j.out_dir.empty() && fs::is_regular_file(fs::path(j.out_dir) / "rasters" / (name + ".tif")))
        differences.push_back({{"name", name},
                               {"download", self + "/rasters/" + name + ".tif"},
                               {"style", self + "/rasters/" + name + ".qml"}});
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"image", self + "/map.png"},
               {"hillshade", shaded ? json(self + "/hillshade.png") : json(nullptr)},
               {"layers", layers},
               {"differences", differences},
               {"shared", shared.empty() ? json(nullptr) : json{{"jobs", shared}}},
               {"crs", g.crs},
               {"raster",
                {{"nx", g.nx}, {"ny", g.ny}, {"dx", g.dx}, {"dy", g.dy},
                 {"west", g.west}, {"north", g.north}, {"east", g.east}, {"south", g.south}}},
               {"structures", structures},
               {"protected_zones", zones},
               {"release", release},
               {"sections", sections}});
  });
}

}  // namespace runout::service
