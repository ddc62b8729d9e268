// The screening rung's run (screening_run.hpp): the terrain's bed with the structures' walls raised into it, the
// release as particles at the screening spacing, the thickness-integrated model stepped to the scene's end or
// to rest, and the terrain outputs written by run.cpp's own code (run_outputs.hpp).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/engine/kernels.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/terrain/terrain.hpp"
#include "run_outputs.hpp"
#include "run_threads.hpp"
#include "screening_gauges.hpp"
#include "screening_run.hpp"

namespace runout {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;
namespace da = depth_averaged;

// The bed the flow runs on: the terrain's bed grid after structures (regraded deposition areas, excavated
// basins), each walled column (a check dam's footprint, the axis buffered by half its thickness, its slit
// lower; a basin's wall) raised to its wall's top, so flow is held below a crest and overtops above it. Off
// the corridor the DEM itself (the corridor's edge is where the 3D run's model ends; the particles that
// cross it are counted out, as there). Bed::grid's rows run south to north, the terrain grids' north to south.
da::Bed terrain_bed(const terrain::TerrainModel& tm, real curvature_scale) {
  const terrain::Grid& bed = tm.bed;
  const int nx = bed.nx, ny = bed.ny;
  std::vector<real> z(static_cast<size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      double v = bed.at(i, j);
      if (!tm.wall_top.values.empty() && !std::isnan(tm.wall_top.at(i, j))) v = std::max<double>(v, tm.wall_top.at(i, j));
      if (std::isnan(v)) v = tm.dem->sample(bed.cx(i), bed.cy(j));
      z[static_cast<size_t>(ny - 1 - j) * nx + i] = static_cast<real>(v);
    }
  // Nodes with no DEM either (nodata, past the DEM's edge) take their neighbours' mean, pass by pass.
  for (bool missing = true; missing;) {
    missing = false;
    std::vector<real> next = z;
    bool filled = false;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!std::isnan(z[static_cast<size_t>(j) * nx + i])) continue;
        real sum = 0;
        int n = 0;
        for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int a = i + di, b = j + dj;
          if (a < 0 || b < 0 || a >= nx || b >= ny || std::isnan(z[static_cast<size_t>(b) * nx + a])) continue;
          sum += z[static_cast<size_t>(b) * nx + a], ++n;
        }
        if (n) next[static_cast<size_t>(j) * nx + i] = sum / n, filled = true;
        else missing = true;
      }
    z.swap(next);
    if (missing && !filled) throw SceneError("terrain.dem", "no elevation anywhere over the corridor");
  }
  return da::Bed::grid(bed.cx(0) - tm.origin_x, bed.cy(ny - 1) - tm.origin_y, bed.dx, bed.dy, nx, ny, std::move(z),
                       curvature_scale);
}

// The block release at the screening spacing: lattice points inside release.polygon, each carrying an equal
// share of the release's volume (depth times the polygon's area, or the volume given), so the volume is exact
// whatever the lattice catches of the polygon's edge.
da::Particles release_particles(const json& scene_json, const terrain::TerrainModel& tm, real spacing,
                                double& volume) {
  const json& r = scene_json.at("release");
  const double depth = r.value("depth", 0.0);
  volume = depth > 0 ? std::abs(terrain::polygon_area(tm.release_polygon)) * depth : r.value("volume", 0.0);
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const auto& p : tm.release_polygon)
    x0 = std::min(x0, p[0]), y0 = std::min(y0, p[1]), x1 = std::max(x1, p[0]), y1 = std::max(y1, p[1]);
  std::vector<std::array<double, 2>> at;
  for (double y = std::floor(y0 / spacing) * spacing + 0.5 * spacing; y < y1; y += spacing)
    for (double x = std::floor(x0 / spacing) * spacing + 0.5 * spacing; x < x1; x += spacing)
      if (terrain::inside_polygon(tm.release_polygon, x, y)) at.push_back({x, y});
  if (at.empty())
    throw SceneError("screening.spacing", "no particle at " + std::to_string(spacing) +
                                              " m spacing falls inside release.polygon: lower it");
  da::Particles p;
  for (const auto& q : at) p.add(q[0] - tm.origin_x, q[1] - tm.origin_y, volume / at.size());
  return p;
}

// The flow on the bed grid's dp lattice: per node, sum_j V_j W(r, h_k,j) (the flow's volume per plan area:
// thickness_at / cos(theta), the depth the 3D run's rasters hold) and sum_j V_j |u_j| W. Scattered from the
// particles, each over its own support: the same sum thickness_at gathers, once per node. The buffers live as
// long as the run and only the window the particles reached is read and cleared: a grid-sized allocation per
// sample cost the run most of its time in page faults (docs/performance.md, "The screening rung on a catchment").
struct FlowOnGrid {
  std::vector<double> depth, depth_speed;  // row-major, nx nodes a row
  int nx = 0;
  int i0 = 0, i1 = -1, j0 = 0, j1 = -1;  // the nodes written since the last clear (inclusive; empty when i1 < i0)
  void clear() {
    for (int j = j0; j <= j1; ++j)
      for (size_t c = static_cast<size_t>(j) * nx + i0; c <= static_cast<size_t>(j) * nx + i1; ++c)
        depth[c] = depth_speed[c] = 0;
    i0 = j0 = 0, i1 = j1 = -1;
  }
};

void flow_on_grid(const da::Model& model, const terrain::TerrainModel& tm, const std::vector<char>& out,
                  FlowOnGrid& f) {
  const terrain::Grid& g = tm.bed;
  if (f.depth.size() != g.values.size())
    f.depth.assign(g.values.size(), 0.0), f.depth_speed.assign(g.values.size(), 0.0), f.nx = g.nx;
  f.clear();
  f.i0 = g.nx, f.j0 = g.ny;
  const da::Particles& p = model.particles();
  const double x_first = g.cx(0) - tm.origin_x, y_north = g.cy(0) - tm.origin_y;
  for (size_t k = 0; k < p.size(); ++k) {
    if (out[p.id[k]]) continue;
    const real hk = p.smoothing[k], support = 2 * hk;
    const real speed = std::sqrt(p.ux[k] * p.ux[k] + p.uy[k] * p.uy[k] + p.uz[k] * p.uz[k]);
    const int i0 = std::max(0, static_cast<int>(std::ceil((p.x[k] - support - x_first) / g.dx)));
    const int i1 = std::min(g.nx - 1, static_cast<int>(std::floor((p.x[k] + support - x_first) / g.dx)));
    const int j0 = std::max(0, static_cast<int>(std::ceil((y_north - p.y[k] - support) / g.dy)));
    const int j1 = std::min(g.ny - 1, static_cast<int>(std::floor((y_north - p.y[k] + support) / g.dy)));
    if (i0 > i1 || j0 > j1) continue;
    f.i0 = std::min(f.i0, i0), f.i1 = std::max(f.i1, i1), f.j0 = std::min(f.j0, j0), f.j1 = std::max(f.j1, j1);
    with_kernel<2>(model.config().kernel, hk, [&](const auto& kernel) {
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const real dx = x_first + i * g.dx - p.x[k], dy = y_north - j * g.dy - p.y[k];
          const real r = std::sqrt(dx * dx + dy * dy);
          if (r >= support) continue;
          const double w = p.volume[k] * kernel.W(r);
          f.depth[static_cast<size_t>(j) * g.nx + i] += w;
          f.depth_speed[static_cast<size_t>(j) * g.nx + i] += w * speed;
        }
      return 0;
    });
  }
  if (f.i1 < f.i0 || f.j1 < f.j0) f.i0 = f.j0 = 0, f.i1 = f.j1 = -1;
}

// What the run records as it goes: the inundation grid (fed the flow on the dp lattice as one dp x dp column a
// node, which it spreads onto the DEM's cells as it spreads the 3D run's particles), the particles gone past the
// corridor's edge, run.csv.
class ScreeningWatch {
 public:
  ScreeningWatch(const terrain::TerrainModel& tm, const ScreeningSettings& s, const OutputSettings& out, size_t n)
      : tm_(tm), settings_(s), out_(out), grid_(tm), gone_(n, 0) {
    csv_ << std::setprecision(9)
         << "t,kinetic_energy_per_mass,max_speed,fluid_volume,outflow_volume,fluid_particles,speed_p50,speed_p95\n";
  }
  // Counts the particles now off the corridor (once: they stay out of every output, as the 3D run removes
  // them) and updates the grid and the table.
  void sample(const da::Model& m) {
    const da::Particles& p = m.particles();
    if (gone_.size() < p.size()) gone_.resize(p.size(), 0);  // a hydrograph's new particles (ids 0..n-1)
    for (size_t k = 0; k < p.size(); ++k)
      if (!gone_[p.id[k]] && std::isnan(tm_.bed_at(p.x[k], p.y[k]))) {
        gone_[p.id[k]] = 1, gone_volume_ += p.volume[k], ++gone_count_;
        // Over the corridor's edge, as the 3D run counts it (TerrainModel::off_corridor): not through a face of
        // the corridor's box on the DEM's edge, where the model ends whatever the corridor.
        if (!tm_.off_corridor(Vec<3>(p.x[k], p.y[k], 0.0))) continue;
        corridor_volume_ += p.volume[k], ++corridor_count_;
        if (corridor_count_ == 1) first_gone_ = {m.time(), p.x[k] + tm_.origin_x, p.y[k] + tm_.origin_y};
      }
    update_grid(m);
    std::vector<real> speed = speeds(m);  // the particles still in, in their order
    double ke = 0, vol = 0;
    for (size_t k = 0, n = 0; k < p.size(); ++k)
      if (!gone_[p.id[k]]) ke += 0.5 * p.volume[k] * speed[n] * speed[n], vol += p.volume[k], ++n;
    std::sort(speed.begin(), speed.end());
    auto pct = [&](double q) { return speed.empty() ? 0.0 : speed[static_cast<size_t>(q * (speed.size() - 1))]; };
    csv_ << m.time() << ',' << (vol > 0 ? ke / vol : 0.0) << ',' << pct(1.0) << ',' << vol << ',' << gone_volume_
         << ',' << p.size() - gone_count_ << ',' << pct(0.5) << ',' << pct(0.95) << '\n';
  }
  // The flow's speeds, the particles off the corridor left out.
  std::vector<real> speeds(const da::Model& m) const {
    const da::Particles& p = m.particles();
    std::vector<real> s;
    for (size_t k = 0; k < p.size(); ++k)
      if (!gone_[p.id[k]]) s.push_back(std::sqrt(p.ux[k] * p.ux[k] + p.uy[k] * p.uy[k] + p.uz[k] * p.uz[k]));
    return s;
  }
  bool gone(uint32_t id) const { return id < gone_.size() && gone_[id]; }
  double gone_volume() const { return gone_volume_; }
  size_t gone_count() const { return gone_count_; }
  const terrain::InundationGrid& grid() const { return grid_; }
  std::string csv() const { return csv_.str(); }
  // What left over the corridor's edge (terrain.corridor.max_outflow bounds it); the DEM's edge not counted.
  double corridor_volume() const { return corridor_volume_; }
  json corridor_outflow(double released) const {
    json j = {{"particles", corridor_count_},
              {"mass_kg", corridor_volume_ * settings_.density},
              {"fraction", released > 0 ? corridor_volume_ / released : 0.0},
              {"max_fraction", tm_.max_corridor_outflow}};
    if (corridor_count_) j["first_time_s"] = first_gone_[0], j["first_point"] = {first_gone_[1], first_gone_[2]};
    return j;
  }

 private:
  void update_grid(const da::Model& m) {
    flow_on_grid(m, tm_, gone_, flow_);
    const FlowOnGrid& f = flow_;
    const terrain::Grid& g = tm_.bed;
    std::vector<Vec<3>> pos;
    std::vector<real> vol, speed, rho;
    for (int j = f.j0; j <= f.j1; ++j)  // raster order, as over the whole grid: the same sums in the same order
      for (int i = f.i0; i <= f.i1; ++i) {
        const size_t c = static_cast<size_t>(j) * g.nx + i;
        if (f.depth[c] <= 0 || std::isnan(g.values[c])) continue;
        const double x = g.cx(i) - tm_.origin_x, y = g.cy(j) - tm_.origin_y;
        pos.push_back(Vec<3>(x, y, m.bed().sample(x, y).z + 0.5 * f.depth[c]));
        vol.push_back(f.depth[c] * g.cell_area());
        speed.push_back(f.depth_speed[c] / f.depth[c]);
        rho.push_back(settings_.density);
      }
    grid_.update(pos, vol, speed, m.time(), out_.inundation_threshold, rho);
  }

  const terrain::TerrainModel& tm_;
  const ScreeningSettings& settings_;
  const OutputSettings& out_;
  terrain::InundationGrid grid_;
  FlowOnGrid flow_;
  std::vector<char> gone_;  // by particle id
  double gone_volume_ = 0, corridor_volume_ = 0;  // off the model; of it, over the corridor's edge
  size_t gone_count_ = 0, corridor_count_ = 0;
  std::array<double, 3> first_gone_{};
  std::ostringstream csv_;
};

// The flow's centre (volume-weighted; one density), local frame, z at mid-thickness; the particles off the
// corridor left out.
std::array<double, 3> flow_centre(const da::Model& m, const ScreeningWatch& w) {
  const da::Particles& p = m.particles();
  std::array<double, 3> c{0, 0, 0};
  double v = 0;
  for (size_t k = 0; k < p.size(); ++k) {
    if (w.gone(p.id[k])) continue;
    c[0] += p.volume[k] * p.x[k], c[1] += p.volume[k] * p.y[k];
    c[2] += p.volume[k] * (m.bed().sample(p.x[k], p.y[k]).z + 0.5 * p.h[k]);
    v += p.volume[k];
  }
  for (auto& x : c) x = v > 0 ? x / v : std::nan("");
  return c;
}

// metrics.json's centre_of_mass, as run.cpp writes it (map coordinates added).
json centre_metrics(const std::array<double, 3>& s, const std::array<double, 3>& e, const terrain::TerrainModel& tm) {
  if (std::isnan(s[0]) || std::isnan(e[0])) return nullptr;
  const double travel = std::hypot(e[0] - s[0], e[1] - s[1]), drop = s[2] - e[2];
  return {{"start_m", {s[0], s[1], s[2]}},
          {"end_m", {e[0], e[1], e[2]}},
          {"start_map", {s[0] + tm.origin_x, s[1] + tm.origin_y, s[2]}},
          {"end_map", {e[0] + tm.origin_x, e[1] + tm.origin_y, e[2]}},
          {"horizontal_travel_m", travel},
          {"drop_m", drop},
          {"travel_angle_deg", travel > 0 ? std::atan2(drop, travel) * 180 / M_PI : 0.0}};
}

// The lanes a hydrograph's line holds at the screening spacing (spread over its whole length).
size_t inflow_lanes(double length, real spacing) {
  return std::max<size_t>(1, static_cast<size_t>(std::floor(length / spacing + 1e-6)));
}

double inflow_line_length(const terrain::TerrainModel& tm) {
  const auto& line = tm.inflow_line;
  return std::hypot(line[1][0] - line[0][0], line[1][1] - line[0][1]);
}

// A hydrograph release (release.hydrograph): the discharge Q(t) of the 3D run's inlet (its speed table times its
// opening's area), entering across the line as rows of particles at the screening spacing, each particle
// depth x spacing^2, one row whenever the volume due since the last reaches a row's, moving downstream at
// Q / (depth x width). The volume that entered trails the hydrograph's integral by less than a row.
class Inflow {
 public:
  Inflow(const terrain::TerrainModel& tm, const InletSpec<3>& inlet, real dp, real spacing)
      : inlet_(inlet), area_(inlet.opening_area(dp)), spacing_(spacing), depth_(tm.release_depth) {
    const auto& line = tm.inflow_line;
    const double length = inflow_line_length(tm);
    length_ = length;
    lanes_ = inflow_lanes(length, spacing);
    for (size_t k = 0; k < lanes_; ++k) {
      const double a = (k + 0.5) * length / lanes_ / length;  // lanes spread over the whole line
      at_.push_back({line[0][0] + a * (line[1][0] - line[0][0]) - tm.origin_x + 0.5 * spacing * tm.inflow_normal[0],
                     line[0][1] + a * (line[1][1] - line[0][1]) - tm.origin_y + 0.5 * spacing * tm.inflow_normal[1]});
    }
    normal_ = tm.inflow_normal;
    particle_volume_ = depth_ * spacing * length / lanes_;
  }
  real discharge(real t) const { return inlet_.speed_at(t) * area_; }
  // Whether everything the hydrograph brings has entered (its table ended at zero, less than a row owed).
  bool ended(real t) const {
    return t >= inlet_.speed.back()[0] && inlet_.speed.back()[1] <= 0;
  }
  // The next time to stop at: a quarter of a spacing's travel at the inflow speed, at most `limit`.
  real next(real t, real limit) const {
    const real u = discharge(t) / (depth_ * length_);
    return std::min(limit, t + std::max<real>(1e-3, 0.25 * spacing_ / std::max<real>(u, 0.05)));
  }
  // Adds the rows due by the model's time (the hydrograph integrated by the trapezoid rule since the last call).
  void feed(da::Model& m) {
    const real t = m.time();
    due_ += 0.5 * (discharge(last_t_) + discharge(t)) * (t - last_t_);
    last_t_ = t;
    const real row = particle_volume_ * lanes_;
    const real u = discharge(t) / (depth_ * length_);
    while (due_ - entered_ >= row) {
      da::Particles p;
      for (const auto& q : at_) {
        p.add(q[0], q[1], particle_volume_);
        const da::BedSample b = m.bed().sample(q[0], q[1]);
        const real ux = u * normal_[0], uy = u * normal_[1];
        p.ux.back() = ux, p.uy.back() = uy, p.uz.back() = b.grad[0] * ux + b.grad[1] * uy;
      }
      m.add_particles(p);
      entered_ += row;
    }
  }
  real entered() const { return entered_; }
  real due() const { return due_; }

 private:
  const InletSpec<3>& inlet_;
  real area_, spacing_, depth_, length_ = 0, particle_volume_ = 0;
  size_t lanes_ = 0;
  std::vector<std::array<real, 2>> at_;
  std::array<double, 2> normal_{};
  real due_ = 0, entered_ = 0, last_t_ = 0;
};

// The run's loop: samples every output_interval; ends at the scene's duration, when opt.stop is set, or at rest
// (output.rest_speed: a share rest_quantile of the flow under it for rest_time, tested at each sample).
std::string step_to_end(const Scene& scene, const ScreeningSettings& s, const RunOptions& opt, da::Model& model,
                        ScreeningWatch& watch, ScreeningGauges& gauges, Inflow* inflow, double& released,
                        RunSummary& sum, RunThreads& team) {
  const auto t0 = std::chrono::steady_clock::now();
  auto last = t0;
  real rest_since = -1;
  while (model.time() < scene.duration) {
    if (opt.stop && opt.stop->load()) return "stopped";
    const real until = std::min<real>(scene.duration, model.time() + s.output_interval);
    while (model.time() < until) {
      model.advance_to(inflow ? inflow->next(model.time(), until) : until);
      if (inflow) inflow->feed(model), released = inflow->entered();
    }
    watch.sample(model);
    gauges.sample(model);
    if (watch.corridor_volume() > 0 && watch.corridor_volume() > scene.terrain->max_corridor_outflow * released) {
      std::ostringstream m;
      m.precision(3);
      m << "flow left the modelled corridor: " << 100.0 * watch.corridor_volume() / released
        << " % of the released volume by t = " << model.time() << " s (terrain.corridor.max_outflow = "
        << scene.terrain->max_corridor_outflow
        << ", accepted range [0, 1]): widen terrain.corridor (buffer, travel_angle or polygon)";
      throw SimulationError(m.str());
    }
    if (scene.output.rest_speed > 0 && (!inflow || inflow->ended(model.time()))) {
      std::vector<real> speed = watch.speeds(model);
      const size_t k = std::clamp<size_t>(static_cast<size_t>(std::ceil(scene.output.rest_quantile * speed.size())), 1,
                                          std::max<size_t>(1, speed.size()));
      real q = 0;
      if (!speed.empty()) std::nth_element(speed.begin(), speed.begin() + (k - 1), speed.end()), q = speed[k - 1];
      rest_since = q < scene.output.rest_speed ? (rest_since < 0 ? model.time() : rest_since) : -1;
      if (rest_since >= 0 && model.time() - rest_since >= scene.output.rest_time) {
        sum.ended_at_rest = model.time();
        break;
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - last > std::chrono::milliseconds(250)) {
      last = now;
      team.follow(opt);
      if (opt.on_progress)
        opt.on_progress({model.time(), scene.duration, static_cast<long>(model.steps()),
                         std::chrono::duration<double>(now - t0).count(), model.particles().size()});
    }
  }
  return "completed";
}

// metrics.json's keys the 3D run writes too (status, steps, times, mass, rest, final speed), and the screening
// model's own settings under "screening".
json run_metrics(const Scene& scene, const ScreeningSettings& s, const da::Model& m, const ScreeningWatch& w,
                 const RunSummary& sum, double released, size_t particles, const Inflow* inflow) {
  json j;
  j["scene"] = scene.name;
  j["model"] = "screening";
  j["status"] = sum.status;
  if (!sum.error.empty()) j["error"] = sum.error;
  j["dimensions"] = 3;
  j["particles"] = {{"fluid_initial", particles}, {"fluid_final", m.particles().size() - w.gone_count()}};
  j["steps"] = sum.steps;
  j["cost_features"] = cost_features_json(cost_features(scene));  // what `runout calibrate` fits the screening term on
  j["simulated_time_s"] = sum.simulated_time;
  j["wall_time_s"] = sum.wall_seconds;
  j["particle_steps_per_s"] = sum.particle_steps_per_second;
  if (scene.output.rest_speed > 0)
    j["rest"] = {{"speed_m_s", scene.output.rest_speed},
                 {"time_s", scene.output.rest_time},
                 {"quantile", scene.output.rest_quantile},
                 {"ended_at_s", sum.ended_at_rest >= 0 ? json(sum.ended_at_rest) : json(nullptr)}};
  const double now = m.total_volume() - w.gone_volume();
  j["mass"] = {{"initial_kg", inflow ? 0.0 : released * s.density},
               {"final_kg", now * s.density},
               {"outflow_kg", w.gone_volume() * s.density},
               {"inflow_kg", inflow ? released * s.density : 0.0},
               {"relative_error", released > 0 ? (m.total_volume() - released) / released : 0.0}};
  std::vector<real> speed = w.speeds(m);
  std::sort(speed.begin(), speed.end());
  auto pct = [&](double q) { return speed.empty() ? 0.0 : speed[static_cast<size_t>(q * (speed.size() - 1))]; };
  const size_t moving = speed.end() - std::upper_bound(speed.begin(), speed.end(), 0.05);
  j["final_speed"] = {{"p50_m_s", pct(0.5)}, {"p95_m_s", pct(0.95)}, {"max_m_s", pct(1.0)},
                      {"moving_fraction", speed.empty() ? 0.0 : static_cast<double>(moving) / speed.size()}};
  j["screening"] = {{"spacing_m", s.spacing},
                    {"kernel_rule", s.kernel_rule},
                    {"reference_spacing_m", s.reference_spacing},
                    {"smoothing_length_m", m.smoothing_length()},
                    {"earth_pressure", s.earth_pressure},
                    {"cfl", s.cfl},
                    {"dt_max_s", s.dt_max},
                    {"output_interval_s", s.output_interval},
                    {"friction", s.friction},
                    {"friction_parameters", s.friction_parameters},
                    {"friction_source", s.friction_source},
                    {"density_kg_m3", s.density},
                    {"particles", particles},
                    {"release_volume_m3", released}};
  if (s.earth_pressure_rule == "savage_hutter") {
    const auto& c = m.config();
    const auto e = da::savage_hutter_coefficients(c.internal_friction_angle, c.bed_friction_angle);
    j["screening"]["earth_pressure_rule"] = s.earth_pressure_rule;
    j["screening"]["internal_friction_angle_deg"] = c.internal_friction_angle;
    j["screening"]["bed_friction_angle_deg"] = c.bed_friction_angle;
    j["screening"]["k_x"] = {{"active", e.kx[0]}, {"passive", e.kx[1]}};
  }
  if (inflow)  // the hydrograph's integral over the run, and what entered of it (less than a row behind)
    j["screening"]["inflow"] = {{"volume_due_m3", inflow->due()}, {"volume_entered_m3", inflow->entered()}};
  return j;
}

}  // namespace

ScreeningParticles screening_particles(const json& scene_json, const terrain::TerrainModel& tm, real spacing) {
  ScreeningParticles n;
  if (!tm.inflow_line.empty()) {
    const double length = inflow_line_length(tm);
    n.inflow_particle_volume = tm.release_depth * spacing * length / inflow_lanes(length, spacing);
    return n;
  }
  double volume = 0;
  n.release = release_particles(scene_json, tm, spacing, volume).size();
  return n;
}

RunSummary run_screening(const Scene& scene, const RunOptions& opt) {
  RunThreads team;
  team.follow(opt);
  const json& scene_json = *scene.document;
  const ScreeningSettings s = screening_settings(scene_json, scene);
  const terrain::TerrainModel& tm = *scene.terrain;
  fs::remove_all(opt.out_dir / "series");
  fs::create_directories(opt.out_dir / "series");

  double released = 0;
  const auto& setup = std::get<SceneSetup<3>>(scene.setup);
  const bool hydrograph = !tm.inflow_line.empty();
  da::Particles start = hydrograph ? da::Particles{} : release_particles(scene_json, tm, s.spacing, released);
  const size_t n = start.size();
  const auto& g = setup.config.gravity;
  da::Model model(s.config(std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])), terrain_bed(tm, s.kernel_ratio() * s.spacing), std::move(start));
  ScreeningWatch watch(tm, s, scene.output, n);
  watch.sample(model);
  ScreeningGauges gauges(scene, s, model);
  std::unique_ptr<Inflow> inflow;
  if (hydrograph) inflow = std::make_unique<Inflow>(tm, setup.inlets.at(0), scene.dp, s.spacing);
  const auto com_start = flow_centre(model, watch);

  RunSummary sum;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    sum.status = step_to_end(scene, s, opt, model, watch, gauges, inflow.get(), released, sum, team);
  } catch (const SimulationError& e) {
    sum.status = "failed";
    sum.error = e.what();
  }
  sum.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  sum.steps = static_cast<long>(model.steps());
  sum.simulated_time = model.time();
  sum.particle_steps_per_second =
      sum.wall_seconds > 0 ? static_cast<double>(model.particles().size()) * sum.steps / sum.wall_seconds : 0;

  run_outputs::write_file_atomically(opt.out_dir / "series" / "run.csv", watch.csv());
  gauges.write(opt.out_dir / "series");
  json m = run_metrics(scene, s, model, watch, sum, released, n, inflow.get());
  add_thread_metrics(m, team);
  m["monitors"] = gauges.sections();
  for (const auto& what : gauges.skipped())
    m["warnings"].push_back(what + ": not sampled by the screening model (section monitors are; a check dam's load "
                                   "is under terrain.structures[k].screening_load)");
  m["centre_of_mass"] = centre_metrics(com_start, flow_centre(model, watch), tm);
  std::vector<Vec<3>> pos;
  std::vector<real> vol;
  const da::Particles& p = model.particles();
  for (size_t k = 0; k < p.size(); ++k)
    if (!watch.gone(p.id[k]))
      pos.push_back(Vec<3>(p.x[k], p.y[k], model.bed().sample(p.x[k], p.y[k]).z + 0.5 * p.h[k])), vol.push_back(p.volume[k]);
  const RunLabel label{scene.name, s.spacing, sum.simulated_time, sum.status};
  m["terrain"] = run_outputs::terrain_outputs(tm, watch.grid(), scene.output, opt.out_dir, pos, vol, label);
  for (size_t k = 0; k < tm.structures.size(); ++k)
    if (json load = gauges.dam_load(k); !load.is_null()) m["terrain"]["structures"][k]["screening_load"] = load;
  m["terrain"]["release_volume_m3"] = released;  // the screening particles' (the 3D lattice's differs)
  m["terrain"]["corridor_outflow"] = watch.corridor_outflow(released);
  if (opt.snapshots || opt.checkpoint_interval > 0)  // runs of seconds: neither is written yet
    m["warnings"].push_back("the screening model writes no snapshots or checkpoints (asked for)");
  if (watch.gone_count() > 0 && sum.status != "failed")
    m["warnings"].push_back(std::to_string(watch.gone_count()) +
                            " particle(s) left the model (over the corridor's edge or the DEM's) and were left out "
                            "of the outputs");
  sum.metrics_json = m.dump(2);
  run_outputs::write_file_atomically(opt.out_dir / "metrics.json", sum.metrics_json + "\n");
  return sum;
}

}  // namespace runout
