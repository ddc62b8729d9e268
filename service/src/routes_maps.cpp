// Routes: the web map of a job: its rasters coloured (PNG), the hillshade, map.png and map.json (the extent,
// colour scales and geometry; server_impl.hpp, docs/service.md).
#include "runout/scenarios/raster_map.hpp"
#include "runout/scenarios/scene_map.hpp"
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_maps() {
  // A raster of the job coloured for the web map (raster_map.hpp): RGBA, one pixel per cell, transparent where
  // there is nothing to show; map.json's `layers` give each one's colour scale.
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.png)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        const std::string name = m[2].str();
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
          picture = render_run_raster(out_dir_of(j), name);
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
    only_params(req, {});
    const Job j = require_job(m[1].str());
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
    json layers = json::array();
    try {
      for (const auto& sc : run_raster_scales(out_dir_of(j))) {
        json stops = json::array();
        for (const auto& st : sc.stops) stops.push_back({{"value", st.value}, {"colour", st.colour}, {"label", st.label}});
        layers.push_back({{"name", sc.layer},
                          {"title", sc.title},
                          {"unit", sc.unit},
                          {"image", self + "/rasters/" + sc.layer + ".png"},
                          {"download", self + "/rasters/" + sc.layer + ".tif"},
                          {"scale",
                           {{"classes", sc.classes}, {"min", sc.min}, {"max", sc.max},
                            {"zero_transparent", sc.zero_transparent}, {"stops", stops}}}});
      }
    } catch (const std::exception& e) {
      throw ApiError(500, "id", "cannot read the rasters of job " + m[1].str() + ": " + e.what());
    }
    const bool shaded = fs::is_regular_file(run_hillshade(out_dir_of(j)));
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"image", self + "/map.png"},
               {"hillshade", shaded ? json(self + "/hillshade.png") : json(nullptr)},
               {"layers", layers},
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
