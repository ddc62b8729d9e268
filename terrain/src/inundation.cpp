// Inundation rasters: flow depth and speed binned onto the DEM's own cells.
#include <algorithm>
#include <cmath>

#include "runout/terrain/terrain.hpp"

namespace runout::terrain {

InundationGrid::InundationGrid(const TerrainModel& model)
    : origin_x_(model.origin_x), origin_y_(model.origin_y), dp_(model.dp) {
  const Grid& dem = *model.dem;
  const Grid& bed = model.bed;
  const int i0 = std::max(0, static_cast<int>(std::floor((bed.x0 - dem.x0) / dem.dx + 1e-9)));
  const int i1 = std::min(dem.nx, static_cast<int>(std::ceil((bed.x1() - dem.x0) / dem.dx - 1e-9)));
  const int j0 = std::max(0, static_cast<int>(std::floor((dem.y0 - bed.y0) / dem.dy + 1e-9)));
  const int j1 = std::min(dem.ny, static_cast<int>(std::ceil((dem.y0 - bed.y1()) / dem.dy - 1e-9)));
  terrain_ = Grid(i1 - i0, j1 - j0, dem.x0 + i0 * dem.dx, dem.y0 - j0 * dem.dy, dem.dx, dem.dy, dem.crs_wkt);
  for (int j = 0; j < terrain_.ny; ++j)
    for (int i = 0; i < terrain_.nx; ++i) terrain_.at(i, j) = dem.at(i0 + i, j0 + j);
  max_depth_ = terrain_.like(0.0f);
  max_speed_ = terrain_.like(0.0f);
  depth_ = terrain_.like(0.0f);
  arrival_ = terrain_.like(Grid::nodata);
  max_hv_ = terrain_.like(0.0f);
  max_pressure_ = terrain_.like(0.0f);
  const size_t cells = terrain_.values.size();
  vol_.assign(cells, 0.0);
  hv_.assign(cells, 0.0);
  rho_v2_.assign(cells, 0.0);
  touched_flag_.assign(cells, 0);
}

void InundationGrid::update(const std::vector<Vec<3>>& positions, const std::vector<real>& volumes,
                            const std::vector<real>& speeds, double time, double threshold,
                            const std::vector<real>& densities) {
  // Only the cells the last update reached hold anything: reset those (the work follows the flow's
  // footprint, not the corridor's window).
  for (size_t c : touched_) {
    depth_.values[c] = 0.0f;
    vol_[c] = hv_[c] = rho_v2_[c] = 0.0;
    touched_flag_[c] = 0;
  }
  touched_.clear();
  const bool with_rho = densities.size() == positions.size();
  const double h = 0.5 * dp_, inv_area = 1.0 / terrain_.cell_area();
  const Grid& g = terrain_;
  for (size_t p = 0; p < positions.size(); ++p) {
    const double x = positions[p][0] + origin_x_, y = positions[p][1] + origin_y_;
    // The particle's dp x dp square, split over the cells it overlaps.
    const double fx0 = (x - h - g.x0) / g.dx, fx1 = (x + h - g.x0) / g.dx;
    const double fy0 = (g.y0 - (y + h)) / g.dy, fy1 = (g.y0 - (y - h)) / g.dy;
    const double share = volumes[p] / ((fx1 - fx0) * (fy1 - fy0));
    for (int j = std::max(0, static_cast<int>(std::floor(fy0))); j < std::min(g.ny, static_cast<int>(std::ceil(fy1))); ++j) {
      const double oy = std::min<double>(fy1, j + 1) - std::max<double>(fy0, j);
      if (oy <= 0) continue;
      for (int i = std::max(0, static_cast<int>(std::floor(fx0))); i < std::min(g.nx, static_cast<int>(std::ceil(fx1))); ++i) {
        const double ox = std::min<double>(fx1, i + 1) - std::max<double>(fx0, i);
        if (ox <= 0) continue;
        const double v = share * ox * oy;  // volume of the particle's share on this cell
        const size_t c = static_cast<size_t>(j) * g.nx + i;
        if (!touched_flag_[c]) touched_flag_[c] = 1, touched_.push_back(c);
        depth_.values[c] += static_cast<float>(v * inv_area);
        vol_[c] += v;
        hv_[c] += v * speeds[p];
        if (with_rho) rho_v2_[c] += v * densities[p] * speeds[p] * speeds[p];
      }
    }
    int i, j;
    if (g.cell_of(x, y, i, j)) max_speed_.at(i, j) = std::max(max_speed_.at(i, j), static_cast<float>(speeds[p]));
  }
  for (size_t c : touched_) {
    max_depth_.values[c] = std::max(max_depth_.values[c], depth_.values[c]);
    max_hv_.values[c] = std::max(max_hv_.values[c], static_cast<float>(hv_[c] * inv_area));
    if (with_rho && vol_[c] > 0 && depth_.values[c] >= threshold)  // the volume-weighted mean of rho v^2
      max_pressure_.values[c] = std::max(max_pressure_.values[c], static_cast<float>(rho_v2_[c] / vol_[c]));
    if (threshold > 0 && std::isnan(arrival_.values[c]) && depth_.values[c] >= threshold)
      arrival_.values[c] = static_cast<float>(time);
  }
}

double InundationGrid::inundated_area(double threshold) const {
  size_t n = 0;
  for (float v : max_depth_.values) n += v >= threshold;
  return n * max_depth_.cell_area();
}

void InundationGrid::save_state(StateWriter& out) const {
  out.label("inundation");
  for (const Grid* g : {&max_depth_, &max_speed_, &depth_, &arrival_, &max_hv_, &max_pressure_}) out.values(g->values);
  out.values(vol_), out.values(hv_), out.values(rho_v2_), out.values(touched_), out.values(touched_flag_);
}

void InundationGrid::load_state(StateReader& in) {
  in.expect("inundation");
  for (Grid* g : {&max_depth_, &max_speed_, &depth_, &arrival_, &max_hv_, &max_pressure_}) {
    const size_t cells = g->values.size();
    in.values(g->values);
    if (g->values.size() != cells) in.fail("is of a grid of another size");
  }
  in.values(vol_), in.values(hv_), in.values(rho_v2_), in.values(touched_), in.values(touched_flag_);
}

}  // namespace runout::terrain
