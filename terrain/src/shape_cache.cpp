// The kept vector shapes (shape_cache.hpp).
#include "shape_cache.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <list>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "runout/common/sha256.hpp"

namespace runout::terrain {
namespace detail {
namespace {

struct ShapeCache {
  std::mutex mutex;
  std::list<std::pair<std::string, VectorShape>> shapes;  // most recently used first
  std::map<std::string, std::list<std::pair<std::string, VectorShape>>::iterator> by_key;
  ShapeCacheStats stats;
};

ShapeCache& cache() {
  static ShapeCache c;
  return c;
}

// The layer's file and the files beside it that its driver reads with it: same stem and another extension
// (layouts.shp: layouts.dbf, layouts.prj), or the file's name and a suffix (layouts.gpkg-wal). Sorted.
std::vector<std::filesystem::path> layer_files(const std::filesystem::path& file) {
  namespace fs = std::filesystem;
  std::vector<fs::path> out;
  const std::string name = file.filename().string(), stem = file.stem().string();
  std::error_code ec;
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    const bool sidecar = n == name || n.rfind(stem + ".", 0) == 0 || n.rfind(name + "-", 0) == 0;
    if (sidecar && it->is_regular_file(ec)) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::string shape_key(const LayerRef& ref, ShapeKind kind, const std::string& working_crs_wkt) {
  namespace fs = std::filesystem;
  const fs::path file(ref.path);
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  if (ref.path.rfind("/vsi", 0) == 0 || ext == ".vrt") return "";
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return "";
  const std::string sep(1, '\0');
  std::string files;  // each file's name and digest
  try {
    for (const fs::path& f : layer_files(file)) files += f.filename().string() + sep + file_sha256(f.string()) + sep;
  } catch (const std::exception&) {
    return "";  // unreadable: read through OGR, which names the error
  }
  return sha256_hex(files) + sep + ref.name + sep + ref.where + sep + ref.crs + sep + working_crs_wkt + sep +
         std::to_string(static_cast<int>(kind));
}

std::optional<VectorShape> cached_shape(const std::string& key) {
  ShapeCache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  const auto it = c.by_key.find(key);
  if (it == c.by_key.end()) {
    ++c.stats.misses;
    return std::nullopt;
  }
  ++c.stats.hits;
  c.shapes.splice(c.shapes.begin(), c.shapes, it->second);
  return it->second->second;
}

void keep_shape(const std::string& key, const VectorShape& shape) {
  ShapeCache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  if (c.by_key.count(key)) return;  // another thread read it meanwhile
  c.shapes.emplace_front(key, shape);
  c.by_key[key] = c.shapes.begin();
  while (c.shapes.size() > kShapeCacheEntries) {
    c.by_key.erase(c.shapes.back().first);
    c.shapes.pop_back();
  }
  c.stats.shapes = c.shapes.size();
}

}  // namespace detail

ShapeCacheStats shape_cache_stats() {
  detail::ShapeCache& c = detail::cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.stats;
}

}  // namespace runout::terrain
