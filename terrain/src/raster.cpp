// Raster I/O: the GDAL side of the terrain library. Everything GDAL stays in this file.
#include "runout/terrain/raster.hpp"
#include "runout/terrain/vector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include "dem_cache.hpp"
#include "runout/common/sha256.hpp"

namespace runout::terrain {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------------------
// Grid::sample

bool Grid::stencil(double x, double y, Stencil& s) const {
  s.count = 0;
  if (nx <= 0 || ny <= 0 || !(dx > 0.0) || !(dy > 0.0)) return false;
  if (!(x >= x0 && x <= x1() && y <= y0 && y >= y1())) return false;
  // Continuous cell-centre coordinates, clamped so the outer half cell takes the edge cell's value.
  const double fi = std::clamp((x - x0) / dx - 0.5, 0.0, static_cast<double>(nx - 1));
  const double fj = std::clamp((y0 - y) / dy - 0.5, 0.0, static_cast<double>(ny - 1));
  const int i0 = std::clamp(static_cast<int>(std::floor(fi)), 0, std::max(0, nx - 2));
  const int j0 = std::clamp(static_cast<int>(std::floor(fj)), 0, std::max(0, ny - 2));
  const int i1 = std::min(i0 + 1, nx - 1), j1 = std::min(j0 + 1, ny - 1);
  const double tx = fi - i0, ty = fj - j0;
  const double w[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
  const int ci[4] = {i0, i1, i0, i1}, cj[4] = {j0, j0, j1, j1};
  // A cell with zero weight (exactly on a centre line, or a grid one cell wide) is not part of the stencil.
  for (int k = 0; k < 4; ++k)
    if (w[k] != 0.0) s.i[s.count] = ci[k], s.j[s.count] = cj[k], s.weight[s.count++] = w[k];
  return true;
}

double Grid::sample(double x, double y) const {
  Stencil s;
  if (!stencil(x, y, s)) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (int k = 0; k < s.count; ++k) {
    const float v = at(s.i[k], s.j[k]);
    if (std::isnan(v)) return std::numeric_limits<double>::quiet_NaN();  // a nodata cell poisons the sample
    sum += s.weight[k] * v;
  }
  return sum;
}

namespace {

// ---------------------------------------------------------------------------------------------------------
// GDAL plumbing

void ensure_gdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

struct DatasetCloser {
  void operator()(void* h) const {
    if (h) GDALClose(static_cast<GDALDatasetH>(h));
  }
};
using Dataset = std::unique_ptr<void, DatasetCloser>;

struct CslFree {
  void operator()(char** p) const { CSLDestroy(p); }
};
// A NULL-terminated argv for the gdal_utils option parsers.
struct Argv {
  std::unique_ptr<char*, CslFree> list;
  Argv(std::initializer_list<std::string> args = {}) {
    for (const auto& a : args) add(a);
  }
  void add(const std::string& a) { list.reset(CSLAddString(list.release(), a.c_str())); }
  char** get() const { return list.get(); }
};

// GDAL reports errors through a handler that prints to stderr; inside this scope they are only recorded, and
// the last one is read with CPLGetLastErrorMsg().
struct QuietErrors {
  QuietErrors() {
    CPLErrorReset();
    CPLPushErrorHandler(CPLQuietErrorHandler);
  }
  ~QuietErrors() { CPLPopErrorHandler(); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;
};

std::string last_gdal_error() {
  const char* msg = CPLGetLastErrorMsg();
  return (msg && *msg) ? std::string(msg) : std::string("no details from GDAL");
}

[[noreturn]] void dem_error(const std::string& message) { throw TerrainError("terrain.dem", message); }
// A target CRS the options ask for but that cannot be used is the CRS field's fault, not the DEM's.
[[noreturn]] void crs_error(const std::string& message) { throw TerrainError("terrain.crs", message); }

std::unique_ptr<OGRSpatialReference> srs_traditional(const OGRSpatialReference& s) {
  std::unique_ptr<OGRSpatialReference> c(s.Clone());
  c->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return c;
}

std::string srs_to_wkt(const OGRSpatialReference& s) {
  char* wkt = nullptr;
  std::string out;
  if (s.exportToWkt(&wkt) == OGRERR_NONE && wkt) out = wkt;
  CPLFree(wkt);
  return out;
}

std::string srs_label(const OGRSpatialReference& s) {
  const char* name = s.GetName();
  std::string label = name ? name : "unnamed CRS";
  const char* auth = s.GetAuthorityName(nullptr);
  const char* code = s.GetAuthorityCode(nullptr);
  if (auth && code) label += std::string(" (") + auth + ":" + code + ")";
  return label;
}

bool is_metre(double unit_in_m) { return std::abs(unit_in_m - 1.0) < 1e-9; }

// Removes a file if present; never throws (used on error paths).
void remove_quietly(const fs::path& p) {
  std::error_code ec;
  fs::remove(p, ec);
}

void ensure_parent_dir(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
}

// Reads band 1 of a dataset into a north-up Grid (flipping a south-up or east-to-west geotransform), nodata
// and masked pixels as NaN.
Grid read_band1(GDALDatasetH ds, const double gt[6], const std::string& crs_wkt, const std::string& path) {
  const int nx = GDALGetRasterXSize(ds), ny = GDALGetRasterYSize(ds);
  GDALRasterBandH band = GDALGetRasterBand(ds, 1);
  std::vector<float> buf(static_cast<size_t>(nx) * static_cast<size_t>(ny));
  if (GDALRasterIO(band, GF_Read, 0, 0, nx, ny, buf.data(), nx, ny, GDT_Float32, 0, 0) != CE_None)
    dem_error("cannot read band 1 of '" + path + "': " + last_gdal_error());

  int has_nodata = 0;
  const double nodata = GDALGetRasterNoDataValue(band, &has_nodata);
  if (has_nodata && !std::isnan(nodata)) {
    const float nd = static_cast<float>(nodata);
    for (auto& v : buf)
      if (v == nd) v = Grid::nodata;
  }
  const int flags = GDALGetMaskFlags(band);
  if (!(flags & GMF_ALL_VALID) && !(flags & GMF_NODATA)) {  // alpha band or explicit mask
    std::vector<unsigned char> mask(buf.size());
    if (GDALRasterIO(GDALGetMaskBand(band), GF_Read, 0, 0, nx, ny, mask.data(), nx, ny, GDT_Byte, 0, 0) !=
        CE_None)
      dem_error("cannot read the validity mask of '" + path + "': " + last_gdal_error());
    for (size_t k = 0; k < buf.size(); ++k)
      if (mask[k] == 0) buf[k] = Grid::nodata;
  }

  const bool flip_x = gt[1] < 0.0, flip_y = gt[5] > 0.0;
  Grid g;
  g.nx = nx;
  g.ny = ny;
  g.dx = std::abs(gt[1]);
  g.dy = std::abs(gt[5]);
  g.x0 = flip_x ? gt[0] + gt[1] * nx : gt[0];
  g.y0 = flip_y ? gt[3] + gt[5] * ny : gt[3];
  g.crs_wkt = crs_wkt;
  g.values.resize(buf.size());
  for (int j = 0; j < ny; ++j) {
    const int sj = flip_y ? ny - 1 - j : j;
    for (int i = 0; i < nx; ++i) {
      const int si = flip_x ? nx - 1 - i : i;
      g.values[static_cast<size_t>(j) * nx + i] = buf[static_cast<size_t>(sj) * nx + si];
    }
  }
  return g;
}


void check_grid(const Grid& g, const char* what) {
  if (g.nx <= 0 || g.ny <= 0 || !(g.dx > 0.0) || !(g.dy > 0.0) ||
      g.values.size() != static_cast<size_t>(g.nx) * static_cast<size_t>(g.ny))
    throw std::invalid_argument(std::string(what) + ": grid is empty or inconsistent (" + std::to_string(g.nx) +
                                " x " + std::to_string(g.ny) + ", " + std::to_string(g.values.size()) +
                                " values)");
}

// A Float32 single-band MEM dataset holding a grid (NaN replaced by `nan_as` if given).
Dataset mem_dataset(const Grid& g, bool with_crs, const float* nan_as = nullptr) {
  GDALDriverH mem = GDALGetDriverByName("MEM");
  if (!mem) throw std::runtime_error("GDAL has no MEM driver");
  Dataset ds(GDALCreate(mem, "", g.nx, g.ny, 1, GDT_Float32, nullptr));
  if (!ds) throw std::runtime_error("cannot create an in-memory raster: " + last_gdal_error());
  double gt[6] = {g.x0, g.dx, 0.0, g.y0, 0.0, -g.dy};
  if (GDALSetGeoTransform(ds.get(), gt) != CE_None)
    throw std::runtime_error("cannot set geotransform: " + last_gdal_error());
  if (with_crs && !g.crs_wkt.empty() && GDALSetProjection(ds.get(), g.crs_wkt.c_str()) != CE_None)
    throw std::runtime_error("cannot set CRS: " + last_gdal_error());
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  std::vector<float> buf;
  const float* src = g.values.data();
  if (nan_as) {
    buf = g.values;
    for (auto& v : buf)
      if (std::isnan(v)) v = *nan_as;
    src = buf.data();
    if (GDALSetRasterNoDataValue(band, *nan_as) != CE_None)
      throw std::runtime_error("cannot set nodata: " + last_gdal_error());
  }
  if (GDALRasterIO(band, GF_Write, 0, 0, g.nx, g.ny, const_cast<float*>(src), g.nx, g.ny, GDT_Float32, 0, 0) !=
      CE_None)
    throw std::runtime_error("cannot fill an in-memory raster: " + last_gdal_error());
  return ds;
}

// Closes a dataset being written, then moves tmp to path; throws (and removes tmp) if GDAL reported an error
// while flushing.
void close_and_commit(Dataset& ds, const std::string& tmp, const std::string& path, const char* what) {
  CPLErrorReset();
  ds.reset();  // GDALClose (void in GDAL 3.6): errors only show in the error state
  if (CPLGetLastErrorType() == CE_Failure || CPLGetLastErrorType() == CE_Fatal) {
    const std::string msg = last_gdal_error();
    remove_quietly(tmp);
    remove_quietly(tmp + ".aux.xml");
    throw std::runtime_error(std::string(what) + ": writing '" + path + "' failed: " + msg);
  }
  // Drivers may leave a PAM sidecar for things the format cannot hold; keep it with the final name.
  std::error_code ec;
  if (fs::exists(tmp + ".aux.xml", ec)) fs::rename(tmp + ".aux.xml", path + ".aux.xml", ec);
  fs::rename(tmp, path, ec);
  if (ec) {
    remove_quietly(tmp);
    throw std::runtime_error(std::string(what) + ": cannot rename '" + tmp + "' to '" + path +
                             "': " + ec.message());
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// CRS helpers

std::string utm_crs_for(double lon_deg, double lat_deg) {
  double lon = std::fmod(lon_deg + 180.0, 360.0);
  if (lon < 0) lon += 360.0;
  int zone = static_cast<int>(std::floor(lon / 6.0)) + 1;
  zone = std::clamp(zone, 1, 60);
  char buf[32];
  std::snprintf(buf, sizeof buf, "EPSG:%d%02d", lat_deg >= 0.0 ? 326 : 327, zone);
  return buf;
}

std::string crs_name(const std::string& crs_wkt) {
  if (crs_wkt.empty()) return "";
  ensure_gdal();
  QuietErrors quiet;
  OGRSpatialReference srs;
  if (srs.importFromWkt(crs_wkt.c_str()) != OGRERR_NONE) return "";
  const char* name = srs.GetName();
  return name ? name : "";
}

// ---------------------------------------------------------------------------------------------------------
// load_dem

namespace {

void check_geotransform(const double gt[6], const std::string& path) {
  if (gt[2] != 0.0 || gt[4] != 0.0)
    dem_error("'" + path + "' has a rotated geotransform, which is not supported; warp it north-up first");
  if (gt[1] == 0.0 || gt[5] == 0.0 || !std::isfinite(gt[1]) || !std::isfinite(gt[5]))
    dem_error("'" + path + "' has a degenerate geotransform (zero cell size)");
}

// The CRS the options name: it must be projected, in metres.
std::unique_ptr<OGRSpatialReference> named_crs(const std::string& target_crs) {
  auto target = std::make_unique<OGRSpatialReference>();
  if (target->SetFromUserInput(target_crs.c_str()) != OGRERR_NONE)
    crs_error("target CRS '" + target_crs + "' is not understood: " + last_gdal_error());
  target->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  if (!target->IsProjected()) crs_error("target CRS '" + target_crs + "' is not a projected CRS");
  const char* unit = nullptr;
  if (!is_metre(target->GetLinearUnits(&unit)))
    crs_error("target CRS '" + target_crs + "' has linear unit '" + (unit ? unit : "?") + "', not metres");
  return target;
}

// UTM zone of the raster centre, in WGS 84 longitude/latitude.
std::unique_ptr<OGRSpatialReference> utm_of_centre(const OGRSpatialReference& src_srs, const double gt[6], int nx,
                                                   int ny, const std::string& path) {
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&src_srs, &wgs84));
  double cx = gt[0] + gt[1] * nx / 2.0, cy = gt[3] + gt[5] * ny / 2.0;
  if (!ct || !ct->Transform(1, &cx, &cy))
    dem_error("cannot locate the centre of '" + path + "' in WGS 84: " + last_gdal_error());
  auto target = std::make_unique<OGRSpatialReference>();
  const std::string utm = utm_crs_for(cx, cy);
  if (target->SetFromUserInput(utm.c_str()) != OGRERR_NONE) dem_error("cannot build " + utm + ": " + last_gdal_error());
  target->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return target;
}

// Where the result must live: the named CRS, the source's own (nullptr) when it is projected in metres, or
// the UTM zone of a geographic DEM's centre.
std::unique_ptr<OGRSpatialReference> working_crs(const OGRSpatialReference& src_srs, const DemOptions& options,
                                                 const double gt[6], int nx, int ny, const std::string& path) {
  if (!options.target_crs.empty()) return named_crs(options.target_crs);
  if (src_srs.IsProjected()) {
    const char* unit = nullptr;
    const double to_m = src_srs.GetLinearUnits(&unit);
    if (!is_metre(to_m))
      dem_error("'" + path + "' is in a projected CRS (" + srs_label(src_srs) + ") whose linear unit is '" +
                (unit ? unit : "?") + "' (" + std::to_string(to_m) +
                " m), not metres; set a metre target CRS to reproject it");
    return nullptr;
  }
  if (src_srs.IsGeographic()) return utm_of_centre(src_srs, gt, nx, ny, path);
  dem_error("'" + path + "' has a CRS that is neither geographic nor projected (" + srs_label(src_srs) +
            "); set a target CRS");
}

// Warp (reprojection and/or resampling) into memory, Float32 so NaN can be the nodata value.
Grid warp_band1(GDALDatasetH src, const OGRSpatialReference& dst_srs, double resolution, const std::string& path) {
  Argv args{"-of", "MEM", "-ot", "Float32", "-r", "bilinear", "-t_srs", srs_to_wkt(dst_srs),
            "-dstnodata", "nan", "-et", "0"};
  if (resolution > 0.0) {
    char res[64];
    std::snprintf(res, sizeof res, "%.17g", resolution);
    args.add("-tr");
    args.add(res);
    args.add(res);
  }
  std::unique_ptr<GDALWarpAppOptions, decltype(&GDALWarpAppOptionsFree)> wopts(
      GDALWarpAppOptionsNew(args.get(), nullptr), &GDALWarpAppOptionsFree);
  if (!wopts) dem_error("internal error: GDAL rejected the warp options: " + last_gdal_error());
  GDALDatasetH srcs[1] = {src};
  int usage_error = 0;
  Dataset warped(GDALWarp("", nullptr, 1, srcs, wopts.get(), &usage_error));
  if (!warped)
    dem_error("cannot reproject '" + path + "' to " + srs_label(dst_srs) + ": " + last_gdal_error());
  double wgt[6];
  if (GDALGetGeoTransform(warped.get(), wgt) != CE_None)
    dem_error("internal error: warped raster has no geotransform");
  return read_band1(warped.get(), wgt, srs_to_wkt(dst_srs), path);
}

// What a DEM's grid is made from: the SHA-256 of each file GDAL reads for the dataset (a VRT and its sources,
// read through GDAL's virtual file system so a /vsizip/ member counts), with the options. "" when a file
// cannot be read back (nothing is kept then).
std::string dem_content_key(GDALDatasetH src, const DemOptions& options) {
  std::unique_ptr<char*, CslFree> files(GDALGetFileList(src));
  if (!files || !files.get()[0]) return "";
  Sha256 h;
  std::vector<char> buf(1 << 16);
  for (char** f = files.get(); *f; ++f) {
    h.update(*f, std::strlen(*f) + 1);
    VSILFILE* fp = VSIFOpenL(*f, "rb");
    if (!fp) return "";
    size_t got = 0;
    while ((got = VSIFReadL(buf.data(), 1, buf.size(), fp)) > 0) h.update(buf.data(), got);
    VSIFCloseL(fp);
  }
  char res[64];
  std::snprintf(res, sizeof res, "%.17g", options.resolution);
  return h.hex() + "|" + options.target_crs + "|" + res;
}

Grid require_data(Grid g, const std::string& path) {
  if (std::none_of(g.values.begin(), g.values.end(), [](float v) { return !std::isnan(v); }))
    dem_error("'" + path + "' contains only nodata");
  return g;
}

}  // namespace

Grid load_dem(const std::string& path, const DemOptions& options) { return *load_dem_shared(path, options); }

std::shared_ptr<const Grid> load_dem_shared(const std::string& path, const DemOptions& options) {
  ensure_gdal();
  QuietErrors quiet;

  // VERBOSE_ERROR: without it a failed open leaves no message ("No such file", "not recognized ...").
  Dataset src(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr,
                         nullptr, nullptr));
  if (!src) dem_error("cannot open '" + path + "' as a raster: " + last_gdal_error());
  if (GDALGetRasterCount(src.get()) < 1) dem_error("'" + path + "' has no raster bands");
  const int nx = GDALGetRasterXSize(src.get()), ny = GDALGetRasterYSize(src.get());
  if (nx < 1 || ny < 1) dem_error("'" + path + "' is empty");
  // A grid kept under this content and these options passed every check below when it was made; the CRS
  // checks ask PROJ's database, which was a tenth of an estimate on the Alr catchment.
  const std::string key = dem_content_key(src.get(), options);
  if (!key.empty())
    if (std::shared_ptr<const Grid> kept = detail::cached_dem(key)) return kept;

  OGRSpatialReferenceH src_srs_h = GDALGetSpatialRef(src.get());
  if (!src_srs_h || OGRSpatialReference::FromHandle(src_srs_h)->IsEmpty())
    dem_error("'" + path + "' has no coordinate reference system (CRS); georeference it first");
  const auto src_srs = srs_traditional(*OGRSpatialReference::FromHandle(src_srs_h));

  double gt[6];
  if (GDALGetGeoTransform(src.get(), gt) != CE_None)
    dem_error("'" + path + "' has no geotransform (cell size and position unknown)");
  check_geotransform(gt, path);

  const std::unique_ptr<OGRSpatialReference> target = working_crs(*src_srs, options, gt, nx, ny, path);
  const bool reproject = target && !src_srs->IsSame(target.get());
  const bool resample = !reproject && options.resolution > 0.0 &&
                        (std::abs(std::abs(gt[1]) - options.resolution) > 1e-9 * options.resolution ||
                         std::abs(std::abs(gt[5]) - options.resolution) > 1e-9 * options.resolution);
  if (options.resolution < 0.0 || !std::isfinite(options.resolution))
    dem_error("resolution must be a positive number of metres (or 0 for native), got " +
              std::to_string(options.resolution));

  auto g = std::make_shared<const Grid>(
      !reproject && !resample
          ? require_data(read_band1(src.get(), gt, srs_to_wkt(*src_srs), path), path)
          : require_data(warp_band1(src.get(), target ? *target : *src_srs, options.resolution, path), path));
  if (!key.empty()) detail::keep_dem(key, g);
  return g;
}

std::string band_description(const std::string& path) {
  ensure_gdal();
  QuietErrors quiet;
  Dataset src(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr,
                         nullptr, nullptr));
  if (!src) dem_error("cannot open '" + path + "' as a raster: " + last_gdal_error());
  if (GDALGetRasterCount(src.get()) < 1) return "";
  const char* d = GDALGetDescription(GDALGetRasterBand(src.get(), 1));
  return d ? d : "";
}

std::string working_crs_wkt(const std::string& path, const DemOptions& options) {
  ensure_gdal();
  QuietErrors quiet;
  Dataset src(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, nullptr,
                         nullptr, nullptr));
  if (!src) dem_error("cannot open '" + path + "' as a raster: " + last_gdal_error());
  OGRSpatialReferenceH src_srs_h = GDALGetSpatialRef(src.get());
  if (!src_srs_h || OGRSpatialReference::FromHandle(src_srs_h)->IsEmpty())
    dem_error("'" + path + "' has no coordinate reference system (CRS); georeference it first");
  const auto src_srs = srs_traditional(*OGRSpatialReference::FromHandle(src_srs_h));
  double gt[6];
  if (GDALGetGeoTransform(src.get(), gt) != CE_None)
    dem_error("'" + path + "' has no geotransform (cell size and position unknown)");
  const auto target = working_crs(*src_srs, options, gt, GDALGetRasterXSize(src.get()),
                                  GDALGetRasterYSize(src.get()), path);
  return srs_to_wkt(target ? *target : *src_srs);
}

// ---------------------------------------------------------------------------------------------------------
// write_geotiff

namespace {

// Description, unit and metadata onto a dataset being written; false if GDAL refused one.
bool describe(GDALDatasetH ds, GDALRasterBandH band, const RasterInfo& info) {
  if (!info.description.empty()) GDALSetDescription(band, info.description.c_str());
  if (!info.unit.empty() && GDALSetRasterUnitType(band, info.unit.c_str()) != CE_None) return false;
  for (const auto& [key, value] : info.metadata)
    if (GDALSetMetadataItem(ds, key.c_str(), value.c_str(), nullptr) != CE_None) return false;
  return true;
}

void write_band(const std::string& path, const Grid& grid, const RasterInfo& info, GDALDataType type,
                const char* what) {
  check_grid(grid, what);
  ensure_gdal();
  QuietErrors quiet;
  ensure_parent_dir(path);
  const std::string tmp = path + ".tmp";

  GDALDriverH gtiff = GDALGetDriverByName("GTiff");
  if (!gtiff) throw std::runtime_error(std::string(what) + ": GDAL has no GTiff driver");
  Argv co{"COMPRESS=DEFLATE", type == GDT_Float32 ? "PREDICTOR=3" : "PREDICTOR=1", "TILED=YES", "BIGTIFF=IF_SAFER"};
  Dataset ds(GDALCreate(gtiff, tmp.c_str(), grid.nx, grid.ny, 1, type, co.get()));
  if (!ds) throw std::runtime_error(std::string(what) + ": cannot create '" + tmp + "': " + last_gdal_error());
  auto fail = [&](const std::string& step) {
    const std::string msg = last_gdal_error();
    ds.reset();
    remove_quietly(tmp);
    remove_quietly(tmp + ".aux.xml");
    throw std::runtime_error(std::string(what) + ": " + step + " for '" + path + "': " + msg);
  };
  double gt[6] = {grid.x0, grid.dx, 0.0, grid.y0, 0.0, -grid.dy};
  if (GDALSetGeoTransform(ds.get(), gt) != CE_None) fail("cannot set the geotransform");
  if (!grid.crs_wkt.empty() && GDALSetProjection(ds.get(), grid.crs_wkt.c_str()) != CE_None)
    fail("cannot set the CRS");
  GDALRasterBandH band = GDALGetRasterBand(ds.get(), 1);
  const double nodata = type == GDT_Float32 ? std::numeric_limits<double>::quiet_NaN() : 0.0;
  if (GDALSetRasterNoDataValue(band, nodata) != CE_None) fail("cannot set nodata");
  if (!describe(ds.get(), band, info)) fail("cannot set the description, unit or metadata");
  if (GDALRasterIO(band, GF_Write, 0, 0, grid.nx, grid.ny, const_cast<float*>(grid.values.data()), grid.nx,
                   grid.ny, GDT_Float32, 0, 0) != CE_None)
    fail("cannot write the values");
  close_and_commit(ds, tmp, path, what);
}

}  // namespace

void write_geotiff(const std::string& path, const Grid& grid, const RasterInfo& info) {
  write_band(path, grid, info, GDT_Float32, "write_geotiff");
}

void write_class_geotiff(const std::string& path, const Grid& classes, const RasterInfo& info) {
  for (float v : classes.values)
    if (!(v >= 0.0f && v <= 255.0f && v == std::floor(v)))
      throw std::invalid_argument("write_class_geotiff: '" + path + "' has a value that is not a class 0-255");
  write_band(path, classes, info, GDT_Byte, "write_class_geotiff");
}

// ---------------------------------------------------------------------------------------------------------
// write_depth_map_png

int depth_map_png_scale(int nx, int ny) {
  const int longer = std::max(nx, ny);
  if (longer <= 0) return 1;
  const int k = static_cast<int>(std::lround(600.0 / longer));
  return std::clamp(k, 1, 32);
}

namespace {

struct Image {
  int w, h;
  std::vector<unsigned char> r, g, b;
  Image(int w_, int h_) : w(w_), h(h_), r(size_t(w_) * h_), g(size_t(w_) * h_), b(size_t(w_) * h_) {}
  void put(int x, int y, unsigned char rr, unsigned char gg, unsigned char bb) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    const size_t k = size_t(y) * w + x;
    r[k] = rr;
    g[k] = gg;
    b[k] = bb;
  }
};

// Clips the segment to [xmin,xmax]x[ymin,ymax] (Liang-Barsky); false if nothing is left.
bool clip_segment(double& xa, double& ya, double& xb, double& yb, double xmin, double ymin, double xmax,
                  double ymax) {
  double t0 = 0.0, t1 = 1.0;
  const double ddx = xb - xa, ddy = yb - ya;
  const double p[4] = {-ddx, ddx, -ddy, ddy};
  const double q[4] = {xa - xmin, xmax - xa, ya - ymin, ymax - ya};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0.0) {
      if (q[k] < 0.0) return false;
    } else {
      const double t = q[k] / p[k];
      if (p[k] < 0.0) {
        if (t > t1) return false;
        t0 = std::max(t0, t);
      } else {
        if (t < t0) return false;
        t1 = std::min(t1, t);
      }
    }
  }
  const double x0 = xa + t0 * ddx, y0 = ya + t0 * ddy;
  xb = xa + t1 * ddx;
  yb = ya + t1 * ddy;
  xa = x0;
  ya = y0;
  return true;
}

void draw_line(Image& img, double xa, double ya, double xb, double yb, int radius, const MapOverlay& o) {
  if (!std::isfinite(xa) || !std::isfinite(ya) || !std::isfinite(xb) || !std::isfinite(yb)) return;
  const double m = radius + 1.0;
  if (!clip_segment(xa, ya, xb, yb, -m, -m, img.w - 1 + m, img.h - 1 + m)) return;
  int x0 = static_cast<int>(std::lround(xa)), y0 = static_cast<int>(std::lround(ya));
  const int x1 = static_cast<int>(std::lround(xb)), y1 = static_cast<int>(std::lround(yb));
  const int dx = std::abs(x1 - x0), sx = x0 < x1 ? 1 : -1;
  const int dy = -std::abs(y1 - y0), sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (;;) {
    for (int oy = -radius; oy <= radius; ++oy)
      for (int ox = -radius; ox <= radius; ++ox) img.put(x0 + ox, y0 + oy, o.r, o.g, o.b);
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

// Hillshade by GDAL (Horn's method, sun from the north-west at 45 degrees), one byte per cell. NaN becomes a
// finite nodata value because the DEM processing compares nodata by equality.
std::vector<unsigned char> hillshade(const Grid& terrain) {
  const float sentinel = -1.0e30f;
  Dataset dem = mem_dataset(terrain, false, &sentinel);
  Argv hs_args{"-of", "MEM", "-compute_edges", "-z", "1", "-s", "1", "-az", "315", "-alt", "45"};
  std::unique_ptr<GDALDEMProcessingOptions, decltype(&GDALDEMProcessingOptionsFree)> hs_opts(
      GDALDEMProcessingOptionsNew(hs_args.get(), nullptr), &GDALDEMProcessingOptionsFree);
  if (!hs_opts) throw std::runtime_error("write_depth_map_png: bad hillshade options: " + last_gdal_error());
  int usage_error = 0;
  Dataset shade_ds(GDALDEMProcessing("", dem.get(), "hillshade", nullptr, hs_opts.get(), &usage_error));
  if (!shade_ds) throw std::runtime_error("write_depth_map_png: hillshade failed: " + last_gdal_error());
  const int nx = terrain.nx, ny = terrain.ny;
  std::vector<unsigned char> shade(size_t(nx) * ny);
  if (GDALRasterIO(GDALGetRasterBand(shade_ds.get(), 1), GF_Read, 0, 0, nx, ny, shade.data(), nx, ny, GDT_Byte,
                   0, 0) != CE_None)
    throw std::runtime_error("write_depth_map_png: cannot read the hillshade: " + last_gdal_error());
  return shade;
}

// Colour per cell: the hillshade in grey, the depth from min_depth to its maximum in a blue ramp over it.
std::vector<std::array<unsigned char, 3>> cell_colours(const Grid& terrain, const Grid& depth,
                                                       const std::vector<unsigned char>& shade, double min_depth) {
  double dmax = -std::numeric_limits<double>::infinity();
  for (float d : depth.values)
    if (std::isfinite(d) && d >= min_depth) dmax = std::max(dmax, static_cast<double>(d));
  const double light[3] = {198, 225, 255}, dark[3] = {8, 40, 150};
  const double alpha = 0.8;  // weight of the depth colour over the hillshade
  std::vector<std::array<unsigned char, 3>> cell(terrain.values.size());
  for (size_t k = 0; k < cell.size(); ++k) {
    const float z = terrain.values[k];
    if (std::isnan(z)) {
      cell[k] = {24, 24, 24};
      continue;
    }
    // Hillshade 1..255 (0 = nodata next to holes) to a grey that never goes fully black.
    const double s = shade[k] == 0 ? 0.5 : shade[k] / 255.0;
    const double grey = 50.0 + 205.0 * s;
    double rgb[3] = {grey, grey, grey};
    const float d = depth.values[k];
    if (std::isfinite(d) && d >= min_depth) {
      const double t = dmax > min_depth ? std::clamp((d - min_depth) / (dmax - min_depth), 0.0, 1.0) : 1.0;
      for (int c = 0; c < 3; ++c) {
        const double ramp = light[c] + t * (dark[c] - light[c]);
        // Keep a trace of the relief under the flow: modulate by the shade around its mid value.
        rgb[c] = alpha * ramp * (0.75 + 0.5 * (s - 0.5)) + (1 - alpha) * grey;
      }
    }
    for (int c = 0; c < 3; ++c) cell[k][c] = static_cast<unsigned char>(std::clamp(std::lround(rgb[c]), 0L, 255L));
  }
  return cell;
}

// The cells enlarged f times, with the overlays' lines drawn over them (f / 4 pixels wide each side).
Image map_image(const Grid& terrain, const std::vector<std::array<unsigned char, 3>>& cell, int f,
                const std::vector<MapOverlay>& overlays) {
  const int nx = terrain.nx;
  Image img(nx * f, terrain.ny * f);
  for (int y = 0; y < img.h; ++y)
    for (int x = 0; x < img.w; ++x) {
      const auto& c = cell[size_t(y / f) * nx + x / f];
      img.put(x, y, c[0], c[1], c[2]);
    }
  const int radius = f / 4;
  for (const auto& o : overlays)
    for (const auto& line : o.lines)
      for (size_t p = 1; p < line.size(); ++p) {
        auto px = [&](double x) { return (x - terrain.x0) / terrain.dx * f - 0.5; };
        auto py = [&](double y) { return (terrain.y0 - y) / terrain.dy * f - 0.5; };
        draw_line(img, px(line[p - 1].first), py(line[p - 1].second), px(line[p].first), py(line[p].second),
                  radius, o);
      }
  return img;
}

// RGB through MEM, then the PNG driver's CreateCopy (PNG has no Create). No georeferencing on the MEM
// dataset, so the PNG driver has nothing to put in a sidecar file.
void write_png(const std::string& path, Image& img) {
  GDALDriverH mem = GDALGetDriverByName("MEM");
  GDALDriverH png = GDALGetDriverByName("PNG");
  if (!mem || !png) throw std::runtime_error("write_depth_map_png: GDAL lacks the MEM or PNG driver");
  Dataset rgb(GDALCreate(mem, "", img.w, img.h, 3, GDT_Byte, nullptr));
  if (!rgb) throw std::runtime_error("write_depth_map_png: cannot create an image: " + last_gdal_error());
  std::vector<unsigned char>* planes[3] = {&img.r, &img.g, &img.b};
  for (int c = 0; c < 3; ++c) {
    GDALRasterBandH band = GDALGetRasterBand(rgb.get(), c + 1);
    if (GDALSetRasterColorInterpretation(band, static_cast<GDALColorInterp>(GCI_RedBand + c)) != CE_None ||
        GDALRasterIO(band, GF_Write, 0, 0, img.w, img.h, planes[c]->data(), img.w, img.h, GDT_Byte, 0, 0) !=
            CE_None)
      throw std::runtime_error("write_depth_map_png: cannot fill the image: " + last_gdal_error());
  }
  ensure_parent_dir(path);
  const std::string tmp = path + ".tmp";
  Argv co{"ZLEVEL=6"};
  Dataset out(GDALCreateCopy(png, tmp.c_str(), rgb.get(), FALSE, co.get(), nullptr, nullptr));
  if (!out) {
    const std::string msg = last_gdal_error();
    remove_quietly(tmp);
    remove_quietly(tmp + ".aux.xml");
    throw std::runtime_error("write_depth_map_png: cannot write '" + path + "': " + msg);
  }
  close_and_commit(out, tmp, path, "write_depth_map_png");
}

}  // namespace

void write_depth_map_png(const std::string& path, const Grid& terrain, const Grid& depth, double min_depth,
                         const std::vector<MapOverlay>& overlays) {
  check_grid(terrain, "write_depth_map_png (terrain)");
  check_grid(depth, "write_depth_map_png (depth)");
  if (depth.nx != terrain.nx || depth.ny != terrain.ny)
    throw std::invalid_argument("write_depth_map_png: depth grid is " + std::to_string(depth.nx) + " x " +
                                std::to_string(depth.ny) + " but terrain is " + std::to_string(terrain.nx) +
                                " x " + std::to_string(terrain.ny));
  ensure_gdal();
  QuietErrors quiet;
  const std::vector<unsigned char> shade = hillshade(terrain);
  Image img = map_image(terrain, cell_colours(terrain, depth, shade, min_depth),
                        depth_map_png_scale(terrain.nx, terrain.ny), overlays);
  write_png(path, img);
}

}  // namespace runout::terrain
