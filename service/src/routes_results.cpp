// Routes: a job's results: metrics, series, rasters, map.png and map.json (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_results() {
  // Results.
  add(R"(/jobs/(\d{1,18})/metrics)", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const Job j = require_job(m[1].str());
    const int64_t run = run_of(j);
    json flat = json::object();
    for (const auto& [k, v] : store->metrics(run)) flat[k] = v;
    const auto row = store->get_run(run);
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"run_status", row ? row->status : ""},
               {"manifest_hash", row ? row->manifest_hash : ""},
               {"metrics", flat},
               {"metrics_json", json::parse(store->metrics_json(run), nullptr, false)},
               {"series", store->series_names(run)}});
  });
  add(R"(/jobs/(\d{1,18})/series/(.+)\.csv)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        const std::string name = m[2].str();
        if (!safe_file_name(name))
          throw ApiError(400, "name", "series name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        const Job j = require_job(m[1].str());
        const int64_t run = run_of(j);
        auto csv = store->series_csv(run, name);
        if (!csv) {
          std::string list;
          for (const auto& n : store->series_names(run)) list += (list.empty() ? "" : ", ") + n;
          throw ApiError(404, "name", "job " + m[1].str() + " has no series '" + name + "' (available: " + list + ")");
        }
        res.status = 200;
        res.set_content(*csv, "text/csv");
      });
  auto raster = [this](const std::string& id, const std::string& file, httplib::Response& res, const char* type) {
    const Job j = require_job(id);
    (void)run_of(j);
    const fs::path p = out_dir_of(j) / "rasters" / file;
    if (!fs::is_regular_file(p))
      throw ApiError(404, "name", "job " + id + " has no raster '" + file +
                                      "' (rasters exist for terrain scenes: max_depth, max_speed, deposit_depth; map.png)");
    res.status = 200;
    res.set_content(read_file(p), type);
  };
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.tif)", "GET",
      [this, raster](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        if (!safe_file_name(m[2].str()))
          throw ApiError(400, "name", "raster name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        raster(m[1].str(), m[2].str() + ".tif", res, "image/tiff");
      });
  add(R"(/jobs/(\d{1,18})/map\.png)", "GET",
      [this, raster](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        raster(m[1].str(), "max_depth.png", res, "image/png");
      });
  // Where map.png lies on the ground, and what to draw over it: the raster's extent and CRS (read from
  // max_depth.tif, whose cells the PNG enlarges by a whole factor), and the map geometry of the job's
  // structures, protected zones, release and cross-sections from its resolved scene (working CRS, metres).
  add(R"(/jobs/(\d{1,18})/map\.json)", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const Job j = require_job(m[1].str());
    const int64_t run = run_of(j);
    const fs::path tif = out_dir_of(j) / "rasters" / "max_depth.tif";
    if (!fs::is_regular_file(tif))
      throw ApiError(404, "id", "job " + m[1].str() + " has no map (maps exist for terrain scenes)");
    terrain::Grid g;
    try {
      g = terrain::load_dem(tif.string());
    } catch (const std::exception& e) {
      throw ApiError(500, "id", "cannot read the extent of job " + m[1].str() + "'s max_depth.tif: " + e.what());
    }
    const json scene = json::parse(j.scene_json, nullptr, false);
    auto ring = [](const json& pts, bool close) {
      json c = json::array();
      if (!pts.is_array()) return c;
      for (const auto& p : pts)
        if (p.is_array() && p.size() >= 2 && p[0].is_number() && p[1].is_number()) c.push_back({p[0], p[1]});
      if (close && c.size() > 2 && c.front() != c.back()) c.push_back(c.front());
      return c;
    };
    auto polygon = [&](const json& pts) { return json{{"type", "Polygon"}, {"coordinates", json::array({ring(pts, true)})}}; };
    auto line = [&](const json& pts) { return json{{"type", "LineString"}, {"coordinates", ring(pts, false)}}; };
    auto list = [&](const char* key) { return scene.is_object() && scene.contains(key) && scene[key].is_array() ? scene[key] : json::array(); };
    json structures = json::array(), zones = json::array(), sections = json::array();
    for (const auto& st : list("structures")) {
      json geom = st.contains("polygon") ? polygon(st["polygon"]) : line(st.value("axis", json::array()));
      structures.push_back({{"name", st.value("name", "")}, {"type", st.value("type", "")}, {"geometry", geom}});
    }
    for (const auto& z : list("protected_zones"))
      zones.push_back({{"name", z.value("name", "")}, {"geometry", polygon(z.value("polygon", json::array()))}});
    for (const auto& mon : list("monitors"))
      if (mon.value("type", "") == "section" && mon.contains("line"))
        sections.push_back({{"name", mon.value("name", "")}, {"series", "section_" + mon.value("name", "")},
                            {"geometry", line(mon["line"])}});
    json release = nullptr;
    if (scene.is_object() && scene.contains("release") && scene["release"].is_object() && scene["release"].contains("polygon"))
      release = {{"geometry", polygon(scene["release"]["polygon"])}};
    const std::string self = kPrefix + "/jobs/" + m[1].str();
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"image", self + "/map.png"},
               {"crs", terrain::crs_name(g.crs_wkt)},
               {"raster",
                {{"nx", g.nx}, {"ny", g.ny}, {"dx", g.dx}, {"dy", g.dy},
                 {"west", g.x0}, {"north", g.y0}, {"east", g.x1()}, {"south", g.y1()}}},
               {"structures", structures},
               {"protected_zones", zones},
               {"release", release},
               {"sections", sections}});
  });
}

}  // namespace runout::service
