// Particles of a terrain scene: the boundary sheet under the bed with the walls on it, and the release.
#include <algorithm>
#include <cmath>

#include "build_steps.hpp"

namespace runout::terrain::detail {
namespace {

// Boundary particles each column gets under its surface: `layers`, more where a neighbour is lower (steep
// ground), so the sheet has no holes.
std::vector<int> column_depths(const Grid& bed, int layers, double dp) {
  std::vector<int> depth_count(bed.values.size(), 0);
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i) {
      const double b = bed.at(i, j);
      if (std::isnan(b)) continue;
      double lowest = b;
      for (int q = -1; q <= 1; ++q)
        for (int r = -1; r <= 1; ++r) {
          const int a = i + q, bb = j + r;
          if (a < 0 || bb < 0 || a >= bed.nx || bb >= bed.ny) continue;
          const double z = bed.at(a, bb);
          if (!std::isnan(z)) lowest = std::min(lowest, z);
        }
      depth_count[static_cast<size_t>(j) * bed.nx + i] =
          layers + static_cast<int>(std::ceil(std::max(0.0, b - lowest) / dp - 1e-9));
    }
  return depth_count;
}

}  // namespace

int wall_count(const TerrainModel& m, size_t c) {
  if (m.wall_top.values.empty() || std::isnan(m.wall_top.values[c])) return 0;
  const double b = m.bed.values[c];  // in double, as the particles are placed
  return static_cast<int>(std::round((m.wall_top.values[c] - b) / m.dp));
}

void lay_boundary_particles(TerrainModel& m, int layers, size_t release_columns, double release_depth,
                            long max_particles) {
  const Grid& bed = m.bed;
  const double dp = m.dp;
  const std::vector<int> depth_count = column_depths(bed, layers, dp);
  m.bed_layers.assign(depth_count.size(), 0);
  for (size_t c = 0; c < depth_count.size(); ++c) {
    if (depth_count[c] > 65535)
      throw TerrainError("dp", "a column needs " + std::to_string(depth_count[c]) +
                                   " bed particles (a cliff of more than 65 000 dp): raise dp");
    if (!std::isnan(bed.values[c])) m.bed_layers[c] = static_cast<uint16_t>(depth_count[c]);
  }
  // The bed's particles are laid near the flow as the run goes (bed_wall_source); the walls always exist.
  size_t estimate = 0;
  for (size_t c = 0; c < bed.values.size(); ++c)
    if (!std::isnan(bed.values[c])) estimate += std::max(0, wall_count(m, c));
  const double layers_est = std::ceil(release_depth / dp);
  estimate += static_cast<size_t>(release_columns * std::max(1.0, layers_est));
  if (estimate > static_cast<size_t>(max_particles))
    throw TerrainError("dp", "dp = " + num(dp) + " m gives about " + std::to_string(estimate) +
                                 " flow and wall particles, over limits.max_particles = " + std::to_string(max_particles));
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i) {
      const size_t c = static_cast<size_t>(j) * bed.nx + i;
      const double b = bed.values[c];
      if (std::isnan(b)) continue;
      const int n = wall_count(m, c);
      if (n == 0) continue;
      const double x = bed.cx(i) - m.origin_x, y = bed.cy(j) - m.origin_y;
      const uint32_t tag = m.structures[m.wall_owner[c]].tag;
      for (int q = 0; q < n; ++q) {
        m.boundary.push_back(Vec<3>(x, y, b + (q + 0.5) * dp));
        m.boundary_tag.push_back(tag);
      }
    }
}

std::vector<size_t> release_columns(const Polyline& polygon, const Grid& bed, double dp) {
  std::vector<size_t> columns;
  size_t nodata = 0;
  for (int j = 0; j < bed.ny; ++j)
    for (int i = 0; i < bed.nx; ++i)
      if (inside_polygon(polygon, bed.cx(i), bed.cy(j))) {
        if (std::isnan(bed.at(i, j))) ++nodata;
        else columns.push_back(static_cast<size_t>(j) * bed.nx + i);
      }
  if (nodata > 0)
    throw TerrainError("release.polygon", std::to_string(nodata) + " of " + std::to_string(nodata + columns.size()) +
                                              " dp x dp columns under the release have no DEM data (nodata)");
  if (columns.empty())
    throw TerrainError("release.polygon", "encloses no dp x dp column (dp = " + num(dp) + " m): enlarge it or lower dp");
  return columns;
}

void fill_release(TerrainModel& m, const ReleaseSpec& release, const std::vector<size_t>& columns) {
  const Grid& bed = m.bed;
  const double dp = m.dp, cell = dp * dp;
  const int nlayers = std::max(
      1, static_cast<int>(std::lround(release.depth > 0 ? release.depth / dp : release.volume / (columns.size() * cell * dp))));
  for (size_t c : columns) {
    if (m.wall_owner[c] >= 0)
      throw TerrainError("release.polygon", "overlaps the wall of '" + m.structures[m.wall_owner[c]].name +
                                                "': the release must start outside structures");
    const int i = static_cast<int>(c % bed.nx), j = static_cast<int>(c / bed.nx);
    const double b = bed.values[c];
    for (int q = 0; q < nlayers; ++q) {
      m.fluid.push_back(Vec<3>(bed.cx(i) - m.origin_x, bed.cy(j) - m.origin_y, b + (q + 0.5) * dp));
      m.fluid_depth.push_back((nlayers - q - 0.5) * dp);
    }
  }
  m.release_depth = nlayers * dp;
  m.release_volume = static_cast<double>(m.fluid.size()) * cell * dp;
}

}  // namespace runout::terrain::detail
