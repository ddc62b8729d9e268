// The corridor: the DEM cells the flow can reach, and the bed grid at dp over their bounding box.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <list>
#include <mutex>
#include <queue>

#include "build_steps.hpp"

namespace runout::terrain {

namespace detail {
namespace {

// Energy-line reach: the highest "energy head" any path from the release can carry to a cell, where the
// head starts at the release surface and falls by tan(travel angle) per metre travelled. A cell is reached
// when its head is at or above the ground. Dijkstra on a max-heap of heads (heads only decrease).
std::vector<char> energy_line_reach(const Grid& dem, const std::vector<std::pair<size_t, double>>& sources,
                                    double tan_angle, double& max_energy_height) {
  const size_t n = dem.values.size();
  std::vector<double> head(n, -std::numeric_limits<double>::infinity());
  using Item = std::pair<double, size_t>;
  std::priority_queue<Item> queue;
  for (const auto& [c, h] : sources) {
    if (h > head[c]) {
      head[c] = h;
      queue.push({h, c});
    }
  }
  const double diag = std::hypot(dem.dx, dem.dy);
  const int di[8] = {1, -1, 0, 0, 1, 1, -1, -1}, dj[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const double dist[8] = {dem.dx, dem.dx, dem.dy, dem.dy, diag, diag, diag, diag};
  while (!queue.empty()) {
    const auto [h, c] = queue.top();
    queue.pop();
    if (h < head[c]) continue;
    const int i = static_cast<int>(c % dem.nx), j = static_cast<int>(c / dem.nx);
    for (int k = 0; k < 8; ++k) {
      const int a = i + di[k], b = j + dj[k];
      if (a < 0 || b < 0 || a >= dem.nx || b >= dem.ny) continue;
      const float z = dem.at(a, b);
      if (std::isnan(z)) continue;
      const double nh = h - tan_angle * dist[k];
      const size_t nc = static_cast<size_t>(b) * dem.nx + a;
      if (nh >= z && nh > head[nc]) {
        head[nc] = nh;
        queue.push({nh, nc});
      }
    }
  }
  std::vector<char> reached(n, 0);
  max_energy_height = 0.0;
  for (size_t c = 0; c < n; ++c) {
    reached[c] = std::isfinite(head[c]) ? 1 : 0;
    if (reached[c]) max_energy_height = std::max(max_energy_height, head[c] - dem.values[c]);
  }
  return reached;
}

// Widens a mask by a distance (disc stamped at every edge cell).
void dilate(const Grid& g, std::vector<char>& mask, double radius) {
  const int rx = static_cast<int>(std::ceil(radius / g.dx)), ry = static_cast<int>(std::ceil(radius / g.dy));
  std::vector<std::pair<int, int>> disc;
  for (int b = -ry; b <= ry; ++b)
    for (int a = -rx; a <= rx; ++a)
      if (std::hypot(a * g.dx, b * g.dy) <= radius + 1e-9) disc.push_back({a, b});
  std::vector<char> out = mask;
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      if (!mask[static_cast<size_t>(j) * g.nx + i]) continue;
      bool edge = false;
      for (int k = 0; k < 4 && !edge; ++k) {
        const int a = i + (k == 0) - (k == 1), b = j + (k == 2) - (k == 3);
        edge = a < 0 || b < 0 || a >= g.nx || b >= g.ny || !mask[static_cast<size_t>(b) * g.nx + a];
      }
      if (!edge) continue;
      for (const auto& [a, b] : disc) {
        const int x = i + a, y = j + b;
        if (x >= 0 && y >= 0 && x < g.nx && y < g.ny) out[static_cast<size_t>(y) * g.nx + x] = 1;
      }
    }
  }
  mask.swap(out);
}

// The reach from every release cell, its head at the release surface.
std::vector<char> release_reach(const ReleaseSpec& release, const CorridorSpec& corridor, const Grid& dem,
                                double release_depth, double& max_energy_height) {
  std::vector<std::pair<size_t, double>> sources;
  auto add_source = [&](int i, int j) {
    const float z = dem.at(i, j);
    if (!std::isnan(z)) sources.push_back({static_cast<size_t>(j) * dem.nx + i, z + release_depth});
  };
  for (int j = 0; j < dem.ny; ++j)
    for (int i = 0; i < dem.nx; ++i)
      if (inside_polygon(release.polygon, dem.cx(i), dem.cy(j))) add_source(i, j);
  for (const auto& v : release.polygon) {  // a release smaller than a DEM cell still has a source
    int i, j;
    if (dem.cell_of(v[0], v[1], i, j)) add_source(i, j);
  }
  return energy_line_reach(dem, sources, std::tan(corridor.travel_angle_deg * kPi / 180.0), max_energy_height);
}

// A structure the user placed is modelled even where the reach does not go: visit(c) for each DEM cell c
// within its reach of a footprint.
template <class Visit>
void for_footprint_cells(const Grid& dem, const std::vector<Footprint>& feet, Visit&& visit) {
  for (const auto& f : feet) {
    const auto [x0, x1, y0, y1] = f.box;
    const double r = f.reach() + std::max(dem.dx, dem.dy);
    Polyline ring = f.s->line;  // the polygon's outline, closed
    ring.push_back(ring.front());
    for (int j = 0; j < dem.ny; ++j) {
      if (dem.cy(j) < y0 - r || dem.cy(j) > y1 + r) continue;
      for (int i = 0; i < dem.nx; ++i) {
        if (dem.cx(i) < x0 - r || dem.cx(i) > x1 + r) continue;
        const double d = !f.s->type->area ? distance_to_polyline(f.s->line, dem.cx(i), dem.cy(j))
                         : inside_polygon(f.s->line, dem.cx(i), dem.cy(j)) ? 0.0
                                                                          : distance_to_polyline(ring, dem.cx(i), dem.cy(j));
        if (d <= r) visit(static_cast<size_t>(j) * dem.nx + i);
      }
    }
  }
}

// corridor_box without the throw: the box of the cells with data (kept = 0: none), nodata dropped.
CorridorBox scan_box(const Grid& dem, std::vector<char>& corridor) {
  CorridorBox box{dem.nx, -1, dem.ny, -1};
  for (int j = 0; j < dem.ny; ++j) {
    for (int i = 0; i < dem.nx; ++i) {
      const size_t c = static_cast<size_t>(j) * dem.nx + i;
      if (std::isnan(dem.values[c])) {
        corridor[c] = 0;
        continue;
      }
      ++box.valid;
      if (!corridor[c]) continue;
      ++box.kept;
      box.i0 = std::min(box.i0, i), box.i1 = std::max(box.i1, i), box.j0 = std::min(box.j0, j), box.j1 = std::max(box.j1, j);
    }
  }
  return box;
}

// The reach (buffered) or the corridor polygon, before the structures' footprints: a function of the DEM, the
// release, the corridor settings and dp only. The Dijkstra over the whole DEM was two thirds of a catchment's
// build (docs/performance.md, "Estimates"), and every layout of a study, every estimate and every check of one
// catchment asks for the same one.
struct Reach {
  std::vector<char> cells;  // nodata dropped
  CorridorBox box;          // kept = 0: no cell with data
  double max_energy_height = 0.0;
};

Reach compute_reach(const TerrainSpec& spec, const Grid& dem, double release_depth, double dp) {
  Reach r;
  // The energy-line reach is computed even when a polygon sets the corridor: its energy height gives the
  // speed scale for the default speed of sound.
  r.cells = release_reach(spec.release, spec.corridor, dem, release_depth, r.max_energy_height);
  r.max_energy_height = std::max(r.max_energy_height, release_depth);
  if (spec.corridor.polygon.empty()) {
    dilate(dem, r.cells, spec.corridor.buffer_m > 0 ? spec.corridor.buffer_m : std::max(20.0, 10.0 * dp));
  } else {
    for (int j = 0; j < dem.ny; ++j)
      for (int i = 0; i < dem.nx; ++i)
        r.cells[static_cast<size_t>(j) * dem.nx + i] = inside_polygon(spec.corridor.polygon, dem.cx(i), dem.cy(j));
  }
  r.box = scan_box(dem, r.cells);
  return r;
}

// What a reach is computed from, besides the DEM: every number at full precision.
std::string reach_key(const TerrainSpec& spec, double release_depth, double dp) {
  std::string key;
  char buf[32];
  auto add = [&](double v) {
    std::snprintf(buf, sizeof buf, "%.17g,", v);
    key += buf;
  };
  for (const auto& p : spec.release.polygon) add(p[0]), add(p[1]);
  key += "|";
  for (const auto& p : spec.corridor.polygon) add(p[0]), add(p[1]);
  key += "|";
  for (double v : {release_depth, dp, spec.corridor.travel_angle_deg, spec.corridor.buffer_m}) add(v);
  return key;
}

// The last few reaches, most recently used first. An entry holds its DEM, so the grid's address it is found
// by cannot be another grid's while the entry lives; a DEM read again after load_dem's keep dropped it is a
// new grid and misses.
struct KeptReaches {
  static constexpr size_t kEntries = 8;
  static constexpr size_t kBytes = size_t{128} << 20;
  struct Entry {
    std::shared_ptr<const Grid> dem;
    std::string key;
    std::shared_ptr<const Reach> reach;
  };
  std::mutex mutex;
  std::list<Entry> entries;
  KeptReachStats stats;
};

KeptReaches& kept_reaches() {
  static KeptReaches k;
  return k;
}

std::shared_ptr<const Reach> reach_of(const TerrainSpec& spec, const std::shared_ptr<const Grid>& dem,
                                      double release_depth, double dp) {
  KeptReaches& k = kept_reaches();
  const std::string key = reach_key(spec, release_depth, dp);
  {
    std::lock_guard<std::mutex> lock(k.mutex);
    for (auto it = k.entries.begin(); it != k.entries.end(); ++it) {
      if (it->dem != dem || it->key != key) continue;
      ++k.stats.hits;
      k.entries.splice(k.entries.begin(), k.entries, it);
      return k.entries.front().reach;
    }
    ++k.stats.misses;
  }
  auto reach = std::make_shared<const Reach>(compute_reach(spec, *dem, release_depth, dp));
  if (reach->cells.size() > KeptReaches::kBytes) return reach;
  std::lock_guard<std::mutex> lock(k.mutex);
  k.entries.push_front({dem, key, reach});
  size_t bytes = 0, count = 0;  // the most recent first, until the bounds
  for (auto it = k.entries.begin(); it != k.entries.end();) {
    bytes += it->reach->cells.size();
    const bool over = bytes > KeptReaches::kBytes || ++count > KeptReaches::kEntries;
    it = over ? k.entries.erase(it) : std::next(it);
  }
  k.stats.kept = k.entries.size();
  return reach;
}

}  // namespace

Corridor corridor_cells(const TerrainSpec& spec, const std::shared_ptr<const Grid>& dem,
                        const std::vector<Footprint>& feet, double release_depth, double dp,
                        double& max_energy_height) {
  const std::shared_ptr<const Reach> reach = reach_of(spec, dem, release_depth, dp);
  max_energy_height = reach->max_energy_height;
  bool adds = false;  // a footprint cell with data off the reach
  for_footprint_cells(*dem, feet, [&](size_t c) { adds = adds || (!reach->cells[c] && !std::isnan(dem->values[c])); });
  if (!adds && reach->box.kept > 0)  // the reach as kept: no copy of a mask the size of the DEM, no scan
    return {std::shared_ptr<const std::vector<char>>(reach, &reach->cells), reach->box};
  auto cells = std::make_shared<std::vector<char>>(reach->cells);
  for_footprint_cells(*dem, feet, [&](size_t c) { (*cells)[c] = 1; });
  const CorridorBox box = corridor_box(*dem, *cells);
  return {std::move(cells), box};
}

CorridorBox corridor_box(const Grid& dem, std::vector<char>& corridor) {
  const CorridorBox box = scan_box(dem, corridor);
  if (box.kept == 0) throw TerrainError("release.polygon", "lies on DEM nodata: no cell of the corridor has data");
  return box;
}

void lay_bed(TerrainModel& m, const std::vector<char>& corridor, const CorridorBox& box, int layers,
             long max_particles) {
  const Grid& dem = *m.dem;
  const double dp = m.dp;
  const double bx0 = dem.x0 + box.i0 * dem.dx, bx1 = dem.x0 + (box.i1 + 1) * dem.dx;
  const double by0 = dem.y0 - box.j0 * dem.dy, by1 = dem.y0 - (box.j1 + 1) * dem.dy;  // north, south edges
  const int nx = static_cast<int>(std::ceil((bx1 - bx0) / dp - 1e-9));
  const int ny = static_cast<int>(std::ceil((by0 - by1) / dp - 1e-9));
  if (static_cast<double>(nx) * ny * layers > 4.0 * max_particles)
    throw TerrainError("dp", "dp = " + num(dp) + " m makes a " + std::to_string(nx) + " x " + std::to_string(ny) +
                                 " column grid over the corridor, more than limits.max_particles = " +
                                 std::to_string(max_particles) + " allows: raise dp or narrow the corridor");
  m.original = Grid(nx, ny, bx0, by0, dp, dp, dem.crs_wkt, Grid::nodata);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      int a, b;
      double x = m.original.cx(i), y = m.original.cy(j);
      // The dp grid rounds the corridor's box up to whole dp, so its last column or row may stick out of the
      // DEM by less than dp: that strip takes the edge cell's ground (without it the flow met a gap with no
      // ground at the DEM's edge instead of the outflow face).
      x = std::clamp(x, bx0 + 1e-9 * dem.dx, bx1 - 1e-9 * dem.dx);
      y = std::clamp(y, by1 + 1e-9 * dem.dy, by0 - 1e-9 * dem.dy);
      if (!dem.cell_of(x, y, a, b) || !corridor[static_cast<size_t>(b) * dem.nx + a]) continue;
      double z = dem.sample(x, y);
      if (std::isnan(z)) z = dem.at(a, b);  // next to nodata: the cell's own value
      m.original.at(i, j) = static_cast<float>(z);
    }
  }
  m.origin_x = bx0;
  m.origin_y = by1;
  m.open_faces[0][0] = box.i0 == 0;
  m.open_faces[0][1] = box.i1 == dem.nx - 1;
  m.open_faces[1][0] = box.j1 == dem.ny - 1;  // south
  m.open_faces[1][1] = box.j0 == 0;           // north
  m.bed = m.original;
}

}  // namespace detail

KeptReachStats kept_reach_stats() {
  detail::KeptReaches& k = detail::kept_reaches();
  std::lock_guard<std::mutex> lock(k.mutex);
  return k.stats;
}

}  // namespace runout::terrain
