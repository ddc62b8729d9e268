#include "dem_cache.hpp"

#include <list>
#include <map>
#include <mutex>
#include <utility>

namespace runout::terrain {
namespace detail {
namespace {

struct DemCache {
  std::mutex mutex;
  std::list<std::pair<std::string, std::shared_ptr<const Grid>>> grids;  // most recently used first
  std::map<std::string, std::list<std::pair<std::string, std::shared_ptr<const Grid>>>::iterator> by_key;
  size_t bytes = 0;
  DemCacheStats stats;
};

DemCache& cache() {
  static DemCache c;
  return c;
}

size_t bytes_of(const Grid& g) { return g.values.size() * sizeof(float) + g.crs_wkt.size(); }

}  // namespace

std::shared_ptr<const Grid> cached_dem(const std::string& key) {
  DemCache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  const auto it = c.by_key.find(key);
  if (it == c.by_key.end()) {
    ++c.stats.misses;
    return nullptr;
  }
  ++c.stats.hits;
  c.grids.splice(c.grids.begin(), c.grids, it->second);
  return it->second->second;
}

void keep_dem(const std::string& key, std::shared_ptr<const Grid> grid) {
  const size_t size = bytes_of(*grid);
  if (size > kDemCacheBytes) return;
  DemCache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  if (c.by_key.count(key)) return;  // another thread made it meanwhile
  c.grids.emplace_front(key, std::move(grid));
  c.by_key[key] = c.grids.begin();
  c.bytes += size;
  while (c.bytes > kDemCacheBytes) {
    c.bytes -= bytes_of(*c.grids.back().second);
    c.by_key.erase(c.grids.back().first);
    c.grids.pop_back();
  }
  c.stats.grids = c.grids.size();
  c.stats.bytes = c.bytes;
}

}  // namespace detail

DemCacheStats dem_cache_stats() {
  detail::DemCache& c = detail::cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.stats;
}

}  // namespace runout::terrain
