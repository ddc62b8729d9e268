// Routes: a job's results: metrics, series, raster (GeoTIFF) and vector downloads (server_impl.hpp, docs/service.md);
// the web map's pictures and geometry are in routes_maps.cpp.
#include "server_impl.hpp"

namespace runout::service {

// A file of the job's rasters/ folder; `download`: sent as an attachment named after the job.
void Server::Impl::send_run_file(const std::string& id, const std::string& file, httplib::Response& res,
                                 const char* type, bool download) {
  const Job j = require_job(id);
  (void)run_of(j);
  // A sweep's difference rasters are the job's own (write_sweep_differences); the rest are its run's.
  const bool own = file.rfind("diff_", 0) == 0 && !j.out_dir.empty();
  const fs::path p = (own ? fs::path(j.out_dir) : out_dir_of(j)) / "rasters" / file;
  if (!fs::is_regular_file(p))
    throw ApiError(404, "name", "job " + id + " has no file '" + file +
                                    "' (terrain runs have the rasters max_depth, max_speed, deposit_depth, max_hv, "
                                    "arrival_time, max_pressure, intensity, the vectors hazard.gpkg and map.png)");
  res.status = 200;
  // GeoTIFFs and their styles keep the run's names: QGIS applies NAME.qml to NAME.tif beside it. Other
  // downloads are named after the job.
  const bool styled = p.extension() == ".tif" || p.extension() == ".qml";
  if (download) res.set_header("Content-Disposition", attachment(styled ? file : "job-" + id + "-" + file));
  res.set_content(read_file(p), type);
}

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
        res.set_header("Content-Disposition", attachment("job-" + m[1].str() + "-" + name + ".csv"));
        res.set_content(*csv, "text/csv; charset=utf-8; header=present");
      });
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.tif)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        if (!safe_file_name(m[2].str()))
          throw ApiError(400, "name", "raster name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        send_run_file(m[1].str(), m[2].str() + ".tif", res, "image/tiff; application=geotiff", true);
      });
  // A raster's QGIS style (the .qml the run wrote beside its GeoTIFF), so that a downloaded raster keeps its colours.
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.qml)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        if (!safe_file_name(m[2].str()))
          throw ApiError(400, "name", "raster name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        send_run_file(m[1].str(), m[2].str() + ".qml", res, "application/xml", true);
      });
  // The inundated area and the intensity classes as polygons (the run's rasters/hazard.gpkg).
  add(R"(/jobs/(\d{1,18})/vectors/hazard\.gpkg)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        send_run_file(m[1].str(), "hazard.gpkg", res, "application/geopackage+sqlite3", true);
      });
}

}  // namespace runout::service
