#include "runout/scenarios/run.hpp"

#include <fcntl.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/engine/geometry.hpp"
#include "runout/engine/state_io.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/vtk_output.hpp"
#include "runout/terrain/terrain.hpp"
#include "runout/terrain/vector.hpp"
#include "hazard_outputs.hpp"
#include "run_outputs.hpp"
#include "run_threads.hpp"
#include "screening_run.hpp"

namespace runout {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// Writes to a temporary name and renames, so a killed run never leaves a half-written file.
void write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write '" + tmp.string() + "'");
    out << text;
    if (!out) throw std::runtime_error("write failed for '" + tmp.string() + "'");
  }
  fs::rename(tmp, path);
}

// The front: the k-th largest x over fluid particles (k = max(3, N/1000)), so a few drops of spray do not
// count as the front.
template <int D>
real front_position(const ParticleArrays<D>& f) {
  if (f.size() == 0) return 0;
  std::vector<real> x = f.pos[0];
  const size_t k = std::min(x.size(), std::max<size_t>(3, x.size() / 1000));
  std::nth_element(x.begin(), x.begin() + (k - 1), x.end(), std::greater<real>());
  return x[k - 1];
}

// The flow's centre of mass (mass-weighted, the scene's frame), inlet buffers left out; NaN when there is no flow.
template <int D>
std::array<double, D> centre_of_mass(const ParticleArrays<D>& f) {
  std::array<double, D> c;
  c.fill(0.0);
  double mass = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    if (Solver<D>::is_inlet_buffer(f.tag[i])) continue;
    for (int d = 0; d < D; ++d) c[d] += static_cast<double>(f.mass[i]) * f.pos[d][i];
    mass += f.mass[i];
  }
  for (auto& v : c) v = mass > 0 ? v / mass : std::nan("");
  return c;
}

template <int D>
std::vector<real> flow_speeds(const ParticleArrays<D>& f) {
  std::vector<real> speed(f.size());
  for (size_t i = 0; i < f.size(); ++i) {
    real v2 = 0;
    for (int d = 0; d < D; ++d) v2 += f.vel[d][i] * f.vel[d][i];
    speed[i] = std::sqrt(v2);
  }
  return speed;
}

// The speed below which a share q of the flow particles lie: the k-th smallest, k = ceil(q N) (q = 1: the
// fastest).
template <int D>
real speed_quantile(const ParticleArrays<D>& f, real q) {
  if (f.size() == 0) return 0;
  std::vector<real> speed = flow_speeds(f);
  const size_t k = std::clamp<size_t>(static_cast<size_t>(std::ceil(q * speed.size())), 1, speed.size());
  std::nth_element(speed.begin(), speed.begin() + (k - 1), speed.end());
  return speed[k - 1];
}

// Has every inlet brought in all it will? Its table has ended on a speed of zero. Before that a flow at rest
// is only waiting for more, so the rest test does not count.
template <int D>
bool inflow_has_ended(const Solver<D>& solver) {
  for (const auto& in : solver.inlets())
    if (!in.speed.empty() && (solver.time() < in.speed.back()[0] || in.speed.back()[1] > 0)) return false;
  return true;
}

// series/<type>_<name>.csv, with characters outside [A-Za-z0-9._-] in the name replaced by '_'.
std::string series_file_name(const MonitorSpec& m) {
  std::string name = m.name;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' && c != '_') c = '_';
  return m.type + "_" + name + ".csv";
}

// Terrain runs: inundation rasters and the check that no flow particle is under the ground, inside a wall or
// off the corridor (the engine knows nothing of the DEM, so this lives here).
template <int D>
class TerrainWatch {
 public:
  TerrainWatch(const terrain::TerrainModel* model, double threshold) : model_(model), threshold_(threshold) {
    if (model_) grid_ = terrain::InundationGrid(*model_);
  }
  bool active() const { return model_ != nullptr; }
  // Volumes are m/rho0, debris at its bulk density (see the section gauge in engine/src/monitors/section.cpp).
  void update(const ParticleArrays<D>& f, const std::vector<MaterialParams>& materials, real t) {
    if constexpr (D == 3) {
      pos_.resize(f.size());
      vol_.resize(f.size());
      speed_.resize(f.size());
      rho_.resize(f.size());
      for (size_t i = 0; i < f.size(); ++i) {
        pos_[i] = Vec<3>(f.pos[0][i], f.pos[1][i], f.pos[2][i]);
        rho_[i] = materials[f.material[i]].density;
        vol_[i] = f.mass[i] / rho_[i];
        speed_[i] = std::sqrt(f.vel[0][i] * f.vel[0][i] + f.vel[1][i] * f.vel[1][i] + f.vel[2][i] * f.vel[2][i]);
      }
      grid_.update(pos_, vol_, speed_, t, threshold_, rho_);
    }
  }
  // Particles over the ground past the corridor's edge leave the model: removed as outflow and counted; the run fails once more than terrain.corridor.max_outflow of the released mass has gone so
  // (the corridor is too narrow for this flow). Anything under the ground or inside a wall is a leak: throws
  // SimulationError naming the first misplaced particle and how many there are.
  void check(Solver<D>& solver, real t) {
    if constexpr (D == 3) {
      // What has been released so far: a hydrograph's inflow as it enters (with the initial mass alone, a
      // hydrograph release would never reach max_outflow).
      released_mass_ = static_cast<double>(solver.mass_balance().total_initial() + solver.mass_balance().total_inflow());
      const ParticleArrays<D>& f = solver.fluid();
      size_t count = 0, first = 0;
      std::string why;
      std::vector<size_t> leaving;
      for (size_t i = 0; i < f.size(); ++i) {
        const Vec<3> p(f.pos[0][i], f.pos[1][i], f.pos[2][i]);
        if (model_->off_corridor(p)) {
          leaving.push_back(i);
          continue;
        }
        std::string w = model_->misplaced(p);
        if (w.empty()) continue;
        if (count++ == 0) first = i, why = std::move(w);
      }
      if (count) {
        std::ostringstream s;
        s << count << " fluid particle(s) leaked at t = " << t << " s: particle " << f.id[first] << ' ' << why;
        throw SimulationError(s.str(), SimulationError::Cause::leak, count);
      }
      if (leaving.empty()) return;
      if (outflow_particles_ == 0) {
        outflow_first_time_ = t;
        outflow_first_point_ = {f.pos[0][leaving[0]] + model_->origin_x, f.pos[1][leaving[0]] + model_->origin_y};
      }
      for (size_t i : leaving) outflow_mass_ += f.mass[i];
      outflow_particles_ += leaving.size();
      solver.remove_as_outflow(leaving);
      const double fraction = outflow_fraction();
      if (fraction > model_->max_corridor_outflow) {
        std::ostringstream s;
        s.precision(3);
        s << "flow left the modelled corridor: " << 100.0 * fraction << " % of the released mass by t = " << t
          << " s (terrain.corridor.max_outflow = " << model_->max_corridor_outflow
          << ", accepted range [0, 1]): widen terrain.corridor (buffer, travel_angle or polygon)";
        throw SimulationError(s.str());
      }
    }
  }
  double outflow_fraction() const { return released_mass_ > 0 ? outflow_mass_ / released_mass_ : 0.0; }
  // metrics.json's terrain.corridor_outflow.
  json corridor_outflow() const {
    json j = {{"particles", outflow_particles_},
              {"mass_kg", outflow_mass_},
              {"fraction", outflow_fraction()},
              {"max_fraction", model_->max_corridor_outflow}};
    if (outflow_particles_ > 0) {
      j["first_time_s"] = outflow_first_time_;
      j["first_point"] = {outflow_first_point_[0], outflow_first_point_[1]};
    }
    return j;
  }
  size_t outflow_particles() const { return outflow_particles_; }
  const terrain::InundationGrid& grid() const { return grid_; }
  void save_state(StateWriter& out) const {
    out.label("terrain watch");
    out.value(released_mass_), out.value(outflow_mass_), out.value(outflow_first_time_);
    out.value(outflow_particles_), out.value(outflow_first_point_);
    if (model_) grid_.save_state(out);
  }
  void load_state(StateReader& in) {
    in.expect("terrain watch");
    in.value(released_mass_), in.value(outflow_mass_), in.value(outflow_first_time_);
    in.value(outflow_particles_), in.value(outflow_first_point_);
    if (model_) grid_.load_state(in);
  }
  // Fluid positions (local) and volumes at the last update.
  const std::vector<Vec<3>>& positions() const { return pos_; }
  const std::vector<real>& volumes() const { return vol_; }

 private:
  const terrain::TerrainModel* model_;
  double threshold_;
  terrain::InundationGrid grid_;
  std::vector<Vec<3>> pos_;
  std::vector<real> vol_, speed_, rho_;
  double released_mass_ = 0.0, outflow_mass_ = 0.0, outflow_first_time_ = 0.0;
  size_t outflow_particles_ = 0;
  std::array<double, 2> outflow_first_point_{};
};

// Per protected zone: inundated area (cells whose centre is inside and whose max depth reaches the threshold),
// the largest max depth inside, and the first arrival (the earliest time a cell inside reached the threshold;
// -1 if none did).
json zone_exposure(const terrain::TerrainModel& tm, const terrain::InundationGrid& g, double threshold) {
  json zones = json::array();
  const terrain::Grid& md = g.max_depth();
  for (const auto& z : tm.protected_zones) {
    double area = 0, depth = 0, arrival = -1;
    for (int j = 0; j < md.ny; ++j)
      for (int i = 0; i < md.nx; ++i) {
        if (!terrain::inside_polygon(z.polygon, md.cx(i), md.cy(j))) continue;
        const float d = md.at(i, j);
        depth = std::max<double>(depth, d);
        if (d >= threshold) area += md.cell_area();
        const float a = g.arrival_time().at(i, j);
        if (!std::isnan(a) && (arrival < 0 || a < arrival)) arrival = a;
      }
    zones.push_back({{"name", z.name}, {"inundated_area_m2", area}, {"max_depth_m", depth}, {"arrival_time_s", arrival}});
  }
  return zones;
}

// Runout: the largest horizontal distance from the release polygon's centroid to a cell whose max depth
// reaches the threshold.
double runout_distance(const terrain::TerrainModel& tm, const terrain::InundationGrid& g, double threshold) {
  // The mean of the vertices (of every ring when the release has several parts or holes).
  double cx = 0, cy = 0;
  size_t n = 0;
  for (const auto& ring : terrain::split_rings(tm.release_polygon))
    for (const auto& p : ring) cx += p[0], cy += p[1], ++n;
  cx /= std::max<size_t>(1, n);
  cy /= std::max<size_t>(1, n);
  const terrain::Grid& md = g.max_depth();
  double best = 0;
  for (int j = 0; j < md.ny; ++j)
    for (int i = 0; i < md.nx; ++i)
      if (md.at(i, j) >= threshold) best = std::max(best, std::hypot(md.cx(i) - cx, md.cy(j) - cy));
  return best;
}

// Flow volume a structure holds at the end, by its type's rule (StructureType::holds); below_rim = false: what
// it held back at any height (a check dam's upstream volume).
double retained_volume(const terrain::TerrainModel& tm, const terrain::StructureInfo& st,
                       const std::vector<Vec<3>>& pos, const std::vector<real>& vol, bool below_rim = true) {
  double v = 0;
  for (size_t k = 0; k < pos.size(); ++k) {
    const double x = pos[k][0] + tm.origin_x, y = pos[k][1] + tm.origin_y, z = pos[k][2];
    const bool held = st.type->holds(st, x, y, z, below_rim);
    if (held) v += vol[k];
  }
  return v;
}

// The map's outlines: structures in black, protected zones in red, the release in orange.
std::vector<terrain::MapOverlay> map_overlays(const terrain::TerrainModel& tm) {
  std::vector<terrain::MapOverlay> overlays(3);
  overlays[0].r = 20, overlays[0].g = 20, overlays[0].b = 20;  // structures
  overlays[1].r = 220, overlays[1].g = 40, overlays[1].b = 40;  // protected zones
  overlays[2].r = 240, overlays[2].g = 160, overlays[2].b = 0;  // release
  auto line = [](const terrain::Polyline& p, bool close) {
    std::vector<std::pair<double, double>> out;
    for (const auto& q : p) out.push_back({q[0], q[1]});
    if (close && !out.empty()) out.push_back(out.front());
    return out;
  };
  auto closed = [&](const terrain::Polyline& p) { return line(p, true); };
  for (const auto& st : tm.structures)
    overlays[0].lines.push_back(line(st.outline, st.type->area));
  for (const auto& z : tm.protected_zones)
    for (const auto& ring : terrain::split_rings(z.polygon)) overlays[1].lines.push_back(closed(ring));
  for (const auto& ring : terrain::split_rings(tm.release_polygon)) overlays[2].lines.push_back(closed(ring));
  return overlays;
}

// metrics.json's terrain.structures: what each one built, and the flow it holds at the end.
json structure_metrics(const terrain::TerrainModel& tm, const std::vector<Vec<3>>& final_pos,
                       const std::vector<real>& final_vol) {
  json ss = json::array();
  for (const auto& st : tm.structures)
    ss.push_back({{"name", st.name},
                  {"type", st.type->name},
                  {"tag", st.tag},
                  {"cut_volume_m3", st.cut_volume},
                  {"fill_volume_m3", st.fill_volume},
                  {"crest_elevation_m", st.crest_elevation},
                  {"storage_capacity_m3", st.storage_capacity},
                  {"retained_volume_m3", retained_volume(tm, st, final_pos, final_vol)}});
  for (size_t k = 0; k < tm.structures.size(); ++k)
    if (tm.structures[k].type->reports_upstream)
      ss[k]["upstream_volume_m3"] = retained_volume(tm, tm.structures[k], final_pos, final_vol, false);
  return ss;
}

// metrics.json's terrain.inundation: the rasters' maxima, the inundated area and the deposit (the flow's depth
// at the end of the run; the study compares its thickness and extent).
json inundation_metrics(const terrain::TerrainModel& tm, const terrain::InundationGrid& g, const OutputSettings& out) {
  float max_depth = 0, max_speed = 0;
  for (float v : g.max_depth().values) max_depth = std::max(max_depth, v);
  for (float v : g.max_speed().values) max_speed = std::max(max_speed, v);
  float deposit_max = 0;
  size_t deposit_cells = 0;
  for (float v : g.depth().values)
    if (!std::isnan(v)) deposit_max = std::max(deposit_max, v), deposit_cells += v >= out.inundation_threshold;
  return {{"threshold_m", out.inundation_threshold},
          {"inundated_area_m2", g.inundated_area(out.inundation_threshold)},
          {"max_depth_m", max_depth},
          {"max_speed_m_s", max_speed},
          {"cell_size_m", g.max_depth().dx},
          {"runout_m", runout_distance(tm, g, out.inundation_threshold)},
          {"deposit_max_depth_m", deposit_max},
          {"deposit_area_m2", deposit_cells * g.depth().cell_area()}};
}

// OUT/rasters (GeoTIFF in the DEM's CRS, aligned with its cells, and the map PNG), and the terrain metrics.
json write_terrain_outputs(const terrain::TerrainModel& tm, const terrain::InundationGrid& g,
                           const OutputSettings& out, const fs::path& dir, const std::vector<Vec<3>>& final_pos,
                           const std::vector<real>& final_vol, const RunLabel& label) {
  const json hazard = write_hazard_outputs(g, out, dir / "rasters", label);
  terrain::write_depth_map_png((dir / "rasters" / "max_depth.png").string(), g.terrain(), g.max_depth(),
                               out.inundation_threshold, map_overlays(tm));
  json t;
  t["crs"] = terrain::crs_name(tm.dem->crs_wkt);
  t["local_origin_m"] = {tm.origin_x, tm.origin_y};
  t["corridor_area_m2"] = tm.corridor_area;
  t["modelled_fraction"] = tm.modelled_fraction;
  t["release_volume_m3"] = tm.release_volume;
  t["release_depth_m"] = tm.release_depth;
  t["structures"] = structure_metrics(tm, final_pos, final_vol);
  {  // the structures as built, beside the hazard polygons: a map of the run shows what was simulated
    std::vector<double> retained, upstream;
    for (const auto& st : t["structures"]) {
      retained.push_back(st.value("retained_volume_m3", std::nan("")));
      upstream.push_back(st.value("upstream_volume_m3", std::nan("")));
    }
    terrain::write_structure_layers((dir / "rasters" / "hazard.gpkg").string(), tm.structures, tm.dem->crs_wkt, retained,
                                    upstream);
  }
  t["inundation"] = inundation_metrics(tm, g, out);
  for (auto it = hazard.begin(); it != hazard.end(); ++it) t["inundation"][it.key()] = it.value();
  t["inundation"]["rasters"].push_back("rasters/max_depth.png");
  t["protected_zones"] = zone_exposure(tm, g, out.inundation_threshold);
  return t;
}

// What a run records as it goes, written to OUT/series at the end: run.csv (energy, speed, front and mass at
// every sample), one table per monitor, the final surface; and the largest excess of kinetic energy over the
// energy released and brought in (<= 0 up to noise).
template <int D>
class RunSeries {
 public:
  // Throws SceneError("monitors") for a monitor the solver cannot place.
  RunSeries(const Scene& scene, const Solver<D>& solver) : scene_(scene), solver_(solver), rows_(scene.monitors.size()) {
    run_ << std::setprecision(9);
    run_ << "t,dt,kinetic_energy,potential_energy_released,max_speed,front_x,fluid_mass,outflow_mass,fluid_particles,"
            "active_boundary,speed_p50,speed_p95,speed_p99\n";
    for (size_t k = 0; k < scene.monitors.size(); ++k) {
      try {
        monitors_.push_back(make_monitor<D>(scene.monitors[k], solver));
      } catch (const std::invalid_argument& e) {
        throw SceneError("monitors", e.what());
      }
      rows_[k] << std::setprecision(9) << "t";
      for (const auto& c : monitors_[k]->columns()) rows_[k] << ',' << c;
      rows_[k] << '\n';
    }
  }
  void after_step() {
    for (auto& mon : monitors_) mon->after_step(solver_);
  }
  void sample(const StepStats& st) {
    const auto e = solver_.energy();
    const auto m = solver_.mass_balance();
    run_ << solver_.time() << ',' << st.dt << ',' << e.kinetic << ',' << e.potential_released << ',' << st.max_speed
         << ',' << front_position(solver_.fluid()) << ',' << static_cast<double>(m.total_current()) << ','
         << static_cast<double>(m.total_outflow()) << ',' << solver_.fluid().size() << ',' << st.active_boundary;
    for (real q : {0.5, 0.95, 0.99}) run_ << ',' << speed_quantile(solver_.fluid(), q);
    run_ << '\n';
  }
  void sample_monitors() {
    for (size_t k = 0; k < monitors_.size(); ++k) {
      rows_[k] << solver_.time();
      for (real v : monitors_[k]->sample(solver_)) rows_[k] << ',' << v;
      rows_[k] << '\n';
    }
  }
  void track_energy() {
    const auto e = solver_.energy();
    max_ke_excess_ = std::max(max_ke_excess_, e.kinetic - e.potential_released - e.inflow_kinetic);
  }
  real max_ke_excess() const { return max_ke_excess_; }
  // The tables so far and each monitor's state.
  void save_state(StateWriter& out) const {
    out.label("series");
    out.text(run_.str());
    for (const auto& r : rows_) out.text(r.str());
    out.value(max_ke_excess_);
    for (const auto& mon : monitors_) mon->save_state(out);
  }
  void load_state(StateReader& in) {
    in.expect("series");
    run_.str(in.text());
    run_.seekp(0, std::ios::end);
    for (auto& r : rows_) r.str(in.text()), r.seekp(0, std::ios::end);
    in.value(max_ke_excess_);
    for (auto& mon : monitors_) mon->load_state(in);
  }
  void write(const fs::path& dir) const {
    std::ostringstream prof;
    prof << std::setprecision(9) << "x,surface_height\n";
    for (const auto& [x, z] : surface_profile<D>(solver_.fluid(), scene_.dp)) prof << x << ',' << z << '\n';
    write_atomically(dir / "final_surface.csv", prof.str());
    write_atomically(dir / "run.csv", run_.str());
    for (size_t k = 0; k < monitors_.size(); ++k)
      write_atomically(dir / series_file_name(scene_.monitors[k]), rows_[k].str());
  }
  // metrics.json's monitors: each one's summary.
  json summaries() const {
    json mons = json::array();
    for (size_t k = 0; k < monitors_.size(); ++k) {
      json one = {{"name", scene_.monitors[k].name}, {"type", scene_.monitors[k].type}};
      for (const auto& [key, value] : monitors_[k]->summary()) one[key] = value;
      mons.push_back(one);
    }
    return mons;
  }

 private:
  const Scene& scene_;
  const Solver<D>& solver_;
  std::ostringstream run_;
  std::vector<std::unique_ptr<Monitor<D>>> monitors_;
  std::vector<std::ostringstream> rows_;
  real max_ke_excess_ = -1e300;
};

// OUT/snapshots/ (vtk_output.hpp) at the start and every output.snapshot_interval (default: duration / 20),
// when the run was asked for snapshots.
template <int D>
class Snapshots {
 public:
  Snapshots(const Scene& scene, const RunOptions& opt)
      : interval_(scene.output.snapshot_interval > 0 ? scene.output.snapshot_interval : scene.duration / 20.0) {
    if (opt.snapshots) writer_.emplace(scene, opt.out_dir / "snapshots");
  }
  void first(const Solver<D>& s) {
    if (!writer_) return;
    writer_->write_frame(s);
    next_ = interval_;
  }
  void after_step(const Solver<D>& s) {
    if (!writer_ || s.time() < next_ - 1e-12) return;
    writer_->write_frame(s);
    next_ += interval_;
  }
  // The next frame's time and the frames written: a resumed run with snapshots adds to them (one without
  // keeps its files and writes none).
  void save_state(StateWriter& out) const {
    out.label("snapshots");
    out.value(next_);
    out.values(writer_ ? writer_->times() : std::vector<double>{});
  }
  void load_state(StateReader& in) {
    in.expect("snapshots");
    in.value(next_);
    std::vector<double> times;
    in.values(times);
    if (writer_) writer_->resume_after(std::move(times));
  }

 private:
  std::optional<SnapshotWriter<D>> writer_;
  real interval_;
  real next_ = 0;
};

// The run's wall clock, opt.on_progress and the OpenMP team's size (opt.threads_now) about every 0.25 s of it.
class Progress {
 public:
  using clock = std::chrono::steady_clock;
  Progress(const RunOptions& opt, RunThreads& team) : opt_(opt), t0_(clock::now()), last_(t0_), team_(team) {}
  double elapsed() const { return std::chrono::duration<double>(clock::now() - t0_).count(); }
  template <int D>
  void during(const Solver<D>& s, real duration) {
    const auto now = clock::now();
    if (now - last_ > std::chrono::milliseconds(250)) {
      last_ = now;
      team_.follow(opt_);
      if (opt_.on_progress)
        opt_.on_progress({s.time(), duration, s.steps(), std::chrono::duration<double>(now - t0_).count(), s.fluid().size()});
    }
  }
  template <int D>
  void at_end(const Solver<D>& s, real duration, double wall_seconds) const {
    if (opt_.on_progress) opt_.on_progress({s.time(), duration, s.steps(), wall_seconds, s.fluid().size()});
  }

 private:
  const RunOptions& opt_;
  clock::time_point t0_, last_;
  RunThreads& team_;
};

// The scene a checkpoint belongs to: its canonical JSON without the prose description (as the manifest hash).
std::string checkpoint_identity(const Scene& scene) {
  json j = *scene.document;
  j.erase("description");
  return j.dump();
}

// What the stepping loop carries from one step to the next besides the solver and the recorders.
struct LoopState {
  real next_sample = 0;
  real rest_since = -1;       // simulated time since which every flow particle is slower than output.rest_speed
  long particle_steps = 0;
  double wall_before = 0;     // [s] wall time of the sessions before the checkpoint the run resumed from
  size_t fluid_initial = 0;   // flow particles at the start
  real resumed_from = -1;     // [s] simulated time of that checkpoint; -1: a fresh run
  int sessions = 1;           // this one and those before it
  std::array<double, 3> com_start{};  // the flow's centre of mass at the start (x, y, z; 2D: x, z, 0)
};

// OUT/checkpoint.bin (RunOptions::checkpoint_interval): the scene it belongs to, then the solver's, the
// recorders' and the loop's state. Written to a temporary name and renamed, so a kill while writing leaves the
// previous checkpoint whole.
template <int D>
class Checkpoint {
 public:
  Checkpoint(const Scene& scene, const RunOptions& opt)
      : scene_(scene), path_(opt.out_dir / "checkpoint.bin"), interval_(opt.checkpoint_interval), last_(0) {}
  bool enabled() const { return interval_ > 0; }
  bool due(double elapsed) const { return enabled() && elapsed - last_ >= interval_; }

  struct Parts {
    Solver<D>& solver;
    RunSeries<D>& series;
    TerrainWatch<D>& watch;
    Snapshots<D>& snapshots;
    LoopState& loop;
  };

  // A checkpoint that cannot be written (a full disk) costs the run only that checkpoint: the previous one stays
  // whole, the run goes on, and metrics.json warns (failures()).
  void save(const Parts& p, double elapsed) {
    last_ = elapsed;
    try {
      write(p, elapsed);
    } catch (const std::exception& e) {
      ++failures_;
      last_error_ = e.what();
    }
  }
  // "" when every checkpoint was written; else how many were not and why the last one was not.
  std::string failures() const {
    return failures_ ? std::to_string(failures_) + " checkpoint(s) could not be written (last: " + last_error_ + ")" : "";
  }

  // Restores the run from OUT/checkpoint.bin when it holds this scene; false when there is none. Throws
  // std::runtime_error for a checkpoint of another scene or one this build cannot read.
  bool load(const Parts& p) {
    if (!enabled() || !fs::exists(path_)) return false;
    std::ifstream file(path_, std::ios::binary);
    StateReader in(file);
    try {
      in.expect("runout checkpoint");
      if (in.text() != checkpoint_identity(scene_))
        throw std::runtime_error("it is of another scene (remove it, or run with another output directory)");
      p.solver.load_state(in);
      p.series.load_state(in);
      p.watch.load_state(in);
      p.snapshots.load_state(in);
      load_loop(in, p.loop);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error("cannot resume from '" + path_.string() + "': " + e.what());
    }
    return true;
  }
  void remove() const {
    std::error_code ec;
    fs::remove(path_, ec);
  }

 private:
  // Written to a temporary name, flushed to the disk and renamed: a kill or a power cut leaves one whole file.
  void write(const Parts& p, double elapsed) const {
    const fs::path tmp = path_.string() + ".tmp";
    {
      std::ofstream file(tmp, std::ios::binary);
      if (!file) throw std::runtime_error("cannot open '" + tmp.string() + "'");
      StateWriter out(file);
      out.label("runout checkpoint");
      out.text(checkpoint_identity(scene_));
      p.solver.save_state(out);
      p.series.save_state(out);
      p.watch.save_state(out);
      p.snapshots.save_state(out);
      save_loop(out, p.loop, elapsed);
      file.close();
      if (!file) throw std::runtime_error("cannot write '" + tmp.string() + "'");
    }
    sync_to_disk(tmp);
    fs::rename(tmp, path_);
    sync_to_disk(path_.parent_path().empty() ? fs::path(".") : path_.parent_path());
  }
  static void sync_to_disk(const fs::path& p) {
    const int fd = ::open(p.c_str(), O_RDONLY);
    if (fd < 0) throw std::runtime_error("cannot open '" + p.string() + "' to sync it");
    const int rc = ::fsync(fd);
    ::close(fd);
    if (rc != 0) throw std::runtime_error("cannot sync '" + p.string() + "' to disk");
  }

  static void save_loop(StateWriter& out, const LoopState& l, double elapsed) {
    out.label("loop");
    out.value(l.next_sample), out.value(l.rest_since), out.value(l.particle_steps);
    out.value(l.wall_before + elapsed), out.value<uint64_t>(l.fluid_initial), out.value(l.sessions);
    out.label("start centre of mass");
    for (double v : l.com_start) out.value(v);
  }
  static void load_loop(StateReader& in, LoopState& l) {
    in.expect("loop");
    in.value(l.next_sample), in.value(l.rest_since), in.value(l.particle_steps), in.value(l.wall_before);
    l.fluid_initial = in.value<uint64_t>();
    l.sessions = in.value<int>() + 1;
    in.expect("start centre of mass");
    for (double& v : l.com_start) in.value(v);
  }

  const Scene& scene_;
  fs::path path_;
  double interval_, last_;
  int failures_ = 0;
  std::string last_error_;
};

// The recorders' first samples, at the start of a fresh run.
template <int D>
void record_start(const Scene& scene, Solver<D>& solver, RunSeries<D>& series, TerrainWatch<D>& watch,
                  Snapshots<D>& snapshots, LoopState& loop) {
  if (watch.active()) {
    watch.check(solver, 0.0);
    watch.update(solver.fluid(), solver.materials(), solver.time());
  }
  const auto c = centre_of_mass(solver.fluid());
  for (int d = 0; d < D; ++d) loop.com_start[d] = c[d];
  snapshots.first(solver);
  series.sample(solver.last_step());
  series.sample_monitors();
  loop.next_sample = scene.output.series_interval;
}

// Steps the solver to the scene's end: "completed", or "stopped" when opt.stop is set (a checkpoint is written
// then, when the run keeps them). Terrain runs check for misplaced particles every 10 steps; monitors, run.csv
// and the inundation grid are sampled every series_interval. Throws SimulationError when the run fails.
template <int D>
std::string step_to_end(const Scene& scene, const RunOptions& opt, typename Checkpoint<D>::Parts p,
                        Checkpoint<D>& checkpoint, Progress& progress, real& ended_at_rest) {
  Solver<D>& solver = p.solver;
  LoopState& loop = p.loop;
  while (solver.time() < scene.duration) {
    if (opt.stop && opt.stop->load()) {
      if (checkpoint.enabled()) checkpoint.save(p, progress.elapsed());
      return "stopped";
    }
    loop.particle_steps += static_cast<long>(solver.fluid().size());
    const StepStats& st = solver.step();
    if (scene.output.rest_speed > 0 && inflow_has_ended(solver)) {
      const real q = scene.output.rest_quantile;
      const real speed = q < 1 ? speed_quantile(solver.fluid(), q) : st.max_speed;
      loop.rest_since = speed < scene.output.rest_speed ? (loop.rest_since < 0 ? solver.time() : loop.rest_since) : -1;
      if (loop.rest_since >= 0 && solver.time() - loop.rest_since >= scene.output.rest_time) {
        ended_at_rest = solver.time();
        p.series.sample_monitors();
        p.series.sample(st);
        break;
      }
    }
    // A particle moves well under dp in 10 steps (CFL), so it cannot cross a wall between two checks.
    if (p.watch.active() && solver.steps() % 10 == 0) p.watch.check(solver, solver.time());
    p.series.after_step();
    if (solver.time() >= loop.next_sample - 1e-12) {
      p.series.sample_monitors();
      if (p.watch.active()) p.watch.update(solver.fluid(), solver.materials(), solver.time());
      p.series.sample(st);
      p.series.track_energy();
      loop.next_sample += scene.output.series_interval;
    }
    p.snapshots.after_step(solver);
    progress.during(solver, scene.duration);
    if (checkpoint.due(progress.elapsed())) checkpoint.save(p, progress.elapsed());
  }
  return "completed";
}

// The failed run's error: the engine's message, and for a blow-up of a cohesionless flow without the density
// floor what fixed the known case.
template <int D>
std::string failure_message(const SimulationError& e, const Solver<D>& solver) {
  std::string error = e.what();
  if (!solver.config().density_floor &&
      (e.cause == SimulationError::Cause::non_finite || e.cause == SimulationError::Cause::dt_floor)) {
    bool floored_material = false;
    for (const auto& mat : solver.materials())
      floored_material = floored_material || rheology_model(mat.rheology).traits.granular;
    if (floored_material)
      error += " (a granular material's density can drift far under rho0 without numerics.density_floor = true; "
               "see docs/tradeoff.md, \"density floor\")";
  }
  return error;
}

// metrics.json's mass balance: initial, final, out and in, and the relative error of their sum.
json mass_metrics(const MassBalance& mb) {
  const long double m0 = mb.total_initial(), m1 = mb.total_current(), mo = mb.total_outflow(),
                    mi = mb.total_inflow();
  return {{"initial_kg", static_cast<double>(m0)},
          {"final_kg", static_cast<double>(m1)},
          {"outflow_kg", static_cast<double>(mo)},
          {"inflow_kg", static_cast<double>(mi)},
          {"relative_error", m0 + mi > 0 ? static_cast<double>((m1 + mo - m0 - mi) / (m0 + mi)) : 0.0}};
}

// Is the flow at rest? Percentiles of particle speed at the end: a few particles running away (isolated ones
// carry no pressure, so no friction) should not hide a bulk that has stopped, nor the reverse.
template <int D>
json final_speed_metrics(const ParticleArrays<D>& f) {
  std::vector<real> speed = flow_speeds(f);
  std::sort(speed.begin(), speed.end());
  auto pct = [&](double q) { return speed.empty() ? 0.0 : speed[static_cast<size_t>(q * (speed.size() - 1))]; };
  const size_t moving = speed.end() - std::upper_bound(speed.begin(), speed.end(), 0.05);
  return {{"p50_m_s", pct(0.5)},
          {"p95_m_s", pct(0.95)},
          {"max_m_s", pct(1.0)},
          {"moving_fraction", speed.empty() ? 0.0 : static_cast<double>(moving) / speed.size()}};
}

// Has the flow kept its bulk density? Percentiles of rho/rho0 at the end: a cohesionless material carries no
// tension, so a continuity density that drifts low is never pushed back (docs/tradeoff.md, "Density floor").
template <int D>
json final_density_metrics(const Solver<D>& solver) {
  const auto& f = solver.fluid();
  std::vector<real> ratio(f.size());
  for (size_t i = 0; i < f.size(); ++i) ratio[i] = f.rho[i] / solver.materials()[f.material[i]].density;
  std::sort(ratio.begin(), ratio.end());
  auto pct = [&](double q) { return ratio.empty() ? 0.0 : ratio[static_cast<size_t>(q * (ratio.size() - 1))]; };
  return {{"p5", pct(0.05)}, {"p50", pct(0.5)}, {"p95", pct(0.95)}, {"min", pct(0.0)}};
}

// metrics.json's settings: the numerics the run resolved to.
template <int D>
json settings_metrics(const Solver<D>& solver) {
  const auto& cfg = solver.config();
  return {{"dp_m", cfg.dp},
          {"smoothing_length_m", cfg.smoothing_length},
          {"kernel", std::string(kernel_name(cfg.kernel))},
          {"integrator", cfg.integrator == Integrator::symplectic ? "symplectic" : "verlet"},
          {"speed_of_sound_m_s", cfg.speed_of_sound},
          {"cfl", cfg.cfl},
          {"artificial_viscosity", cfg.artificial_viscosity},
          {"density_diffusion_delta", cfg.density_diffusion_delta},
          {"viscosity", viscous_step_names()[static_cast<size_t>(cfg.viscous_step)]},
          {"viscosity_cap_pa_s", std::isfinite(solver.max_viscosity()) ? json(solver.max_viscosity()) : json(nullptr)},
          {"shear_rate_floor_1_s", cfg.shear_rate_floor},
          {"density_floor", cfg.density_floor},
          {"max_dilatancy", cfg.max_dilatancy},
          {"neighbour_skin", cfg.neighbour_skin},
          {"particle_shifting", particle_shifting_names()[static_cast<size_t>(cfg.particle_shifting)]},
          {"shifting_coefficient", cfg.shifting_coefficient},
          {"boundary_pressure", boundary_pressure_names()[static_cast<size_t>(cfg.boundary_pressure)]}};
}

// Particle counts a run reports: at the start, and the leaked ones when it failed on a leak.
// c0 against the fastest flow: weak compressibility needs Mach <= 0.1, and the acoustic step limit scales as 1/c0,
// so a run whose Mach stays far under 0.1 could take fewer steps with the c0 that keeps it at 0.1.
template <int D>
json speed_of_sound_metrics(const Solver<D>& solver) {
  const real c0 = solver.config().speed_of_sound, top = solver.max_mach() * c0;
  json s = {{"c0_m_s", c0}, {"max_flow_speed_m_s", top}, {"c0_for_mach_0_1_m_s", 10.0 * top}};
  s["acoustic_steps_factor"] = top > 0 ? 10.0 * top / c0 : 0.0;  // steps with that c0, where acoustics set dt
  return s;
}

// The centre of mass's path from the start to the end: its horizontal travel, its drop and their ratio, the
// travel angle an energy line (a Coulomb block: tan = mu) predicts. null where the start or the end had no flow
// (an inlet's run starts empty).
template <int D>
json centre_of_mass_metrics(const ParticleArrays<D>& f, const std::array<double, 3>& start) {
  const auto end = centre_of_mass(f);
  if (std::isnan(start[0]) || std::isnan(end[0])) return nullptr;
  double travel2 = 0;
  for (int d = 0; d + 1 < D; ++d) travel2 += (end[d] - start[d]) * (end[d] - start[d]);
  const double travel = std::sqrt(travel2), drop = start[D - 1] - end[D - 1];
  json s = json::array(), e = json::array();
  for (int d = 0; d < D; ++d) s.push_back(start[d]), e.push_back(end[d]);
  return {{"start_m", s}, {"end_m", e}, {"horizontal_travel_m", travel}, {"drop_m", drop},
          {"travel_angle_deg", travel > 0 ? std::atan2(drop, travel) * 180 / M_PI : 0.0}};
}

struct ParticleCounts {
  size_t fluid_initial = 0, boundary = 0, leaked = 0;
};

// metrics.json without the monitors and the terrain.
template <int D>
json run_metrics(const Scene& scene, const Solver<D>& solver, const RunSummary& sum, const ParticleCounts& counts,
                 real max_ke_excess) {
  const auto e = solver.energy();
  json m;
  m["scene"] = scene.name;
  m["status"] = sum.status;
  if (!sum.error.empty()) m["error"] = sum.error;
  m["dimensions"] = D;
  // boundary: every wall particle the scene describes; boundary_peak: the most alive at once (a terrain's
  // bed is laid near the flow only), wall_rebuilds: how often the tiles alive changed.
  m["particles"] = {{"fluid_initial", counts.fluid_initial}, {"fluid_final", solver.fluid().size()},
                    {"boundary", counts.boundary}, {"boundary_peak", solver.boundary_peak()},
                    {"wall_rebuilds", solver.boundary_generation()}};
  m["steps"] = sum.steps;
  // How often the cells were scanned for neighbour pairs (with a neighbour skin, only after a sort).
  m["neighbour_list_builds"] = solver.neighbour_list_builds();
  m["simulated_time_s"] = sum.simulated_time;
  m["wall_time_s"] = sum.wall_seconds;
  m["particle_steps_per_s"] = sum.particle_steps_per_second;
  m["cost_features"] = cost_features_json(cost_features(scene));  // so `runout calibrate` can refit (docs/tradeoff.md)
  m["dt"] = {{"min_s", solver.min_dt_seen() < 1e299 ? solver.min_dt_seen() : 0.0}, {"last_s", solver.last_step().dt}};
  m["max_mach"] = solver.max_mach();
  if (solver.max_mach() > 0.1)
    m["warnings"].push_back("max Mach number " + std::to_string(solver.max_mach()) +
                            " exceeds 0.1: raise numerics.speed_of_sound");
  m["speed_of_sound"] = speed_of_sound_metrics(solver);
  if (scene.output.rest_speed > 0)
    m["rest"] = {{"speed_m_s", scene.output.rest_speed},
                 {"time_s", scene.output.rest_time},
                 {"quantile", scene.output.rest_quantile},
                 {"ended_at_s", sum.ended_at_rest >= 0 ? json(sum.ended_at_rest) : json(nullptr)}};
  m["mass"] = mass_metrics(solver.mass_balance());
  m["leaks"] = counts.leaked;
  m["energy"] = {{"kinetic_final_j", e.kinetic},
                 {"potential_released_j", e.potential_released},
                 {"max_kinetic_minus_released_j", max_ke_excess}};
  m["front_x_m"] = front_position(solver.fluid());
  m["final_speed"] = final_speed_metrics(solver.fluid());
  m["final_density_ratio"] = final_density_metrics(solver);
  m["settings"] = settings_metrics(solver);
  if (const ViscousSolveSummary& v = solver.viscous_solves(); v.solves > 0)
    m["viscous_solves"] = {{"solves", v.solves},
                           {"iterations_mean", static_cast<double>(v.iterations) / v.solves},
                           {"iterations_max", v.max_iterations},
                           {"unconverged_steps", v.unconverged},
                           {"residual_max", v.max_residual}};
  json tags = json::object();
  for (size_t k = 1; k < scene.boundary_tags.size(); ++k) tags[std::to_string(k)] = scene.boundary_tags[k];
  m["boundary_tags"] = tags;
  return m;
}

// metrics.json's terrain (rasters written to OUT/rasters), with a warning when flow left the corridor in a run
// that did not fail for it.
template <int D>
void add_terrain_metrics(json& m, const Scene& scene, const TerrainWatch<D>& watch, const fs::path& out_dir,
                         const std::string& status) {
  const RunLabel label{scene.name, scene.dp, m.value("simulated_time_s", 0.0), status};
  m["terrain"] = write_terrain_outputs(*scene.terrain, watch.grid(), scene.output, out_dir, watch.positions(),
                                       watch.volumes(), label);
  m["terrain"]["corridor_outflow"] = watch.corridor_outflow();
  if (json& com = m["centre_of_mass"]; !com.is_null())  // in map coordinates too, as the DEM's
    for (const std::string k : {"start", "end"}) {
      json p = com[k + "_m"];
      p[0] = p[0].get<double>() + scene.terrain->origin_x;
      p[1] = p[1].get<double>() + scene.terrain->origin_y;
      com[k + "_map"] = p;
    }
  if (watch.outflow_particles() > 0 && status != "failed") {
    std::ostringstream w;
    w.precision(3);
    w << watch.outflow_particles() << " particle(s) (" << 100.0 * watch.outflow_fraction()
      << " % of the released mass) left the modelled corridor and were removed: its edge cut the flow there";
    m["warnings"].push_back(w.str());
  }
}

template <int D>
RunSummary run_typed(const Scene& scene, const SceneSetup<D>& setup, const RunOptions& opt) {
  // The series are written whole at the end (a resumed run's from its checkpoint's state), so nothing in the folder
  // is this run's yet: clear it, or a monitor of an earlier run into this folder would outlive it.
  fs::remove_all(opt.out_dir / "series");
  fs::create_directories(opt.out_dir / "series");

  RunThreads team;
  team.follow(opt);
  Solver<D> solver(setup);
  Progress progress(opt, team);
  TerrainWatch<D> watch(scene.terrain.get(), scene.output.inundation_threshold);
  RunSeries<D> series(scene, solver);
  Snapshots<D> snapshots(scene, opt);
  LoopState loop;
  loop.fluid_initial = solver.fluid().size();
  Checkpoint<D> checkpoint(scene, opt);
  const typename Checkpoint<D>::Parts parts{solver, series, watch, snapshots, loop};
  if (checkpoint.load(parts))
    loop.resumed_from = solver.time();
  else
    record_start(scene, solver, series, watch, snapshots, loop);
  ParticleCounts counts{loop.fluid_initial, static_cast<size_t>(solver.boundary_described())};
  RunSummary sum;
  sum.resumed_from = loop.resumed_from;
  try {
    sum.status = step_to_end(scene, opt, parts, checkpoint, progress, sum.ended_at_rest);
  } catch (const SimulationError& e) {
    sum.status = "failed";
    sum.error = failure_message(e, solver);
    if (e.cause == SimulationError::Cause::leak) counts.leaked = e.leaked_particles;
  }
  if (sum.status != "stopped") checkpoint.remove();
  if (watch.active()) watch.update(solver.fluid(), solver.materials(), solver.time());
  sum.wall_seconds = loop.wall_before + progress.elapsed();
  sum.steps = solver.steps();
  sum.simulated_time = solver.time();
  sum.particle_steps_per_second = sum.wall_seconds > 0 ? loop.particle_steps / sum.wall_seconds : 0;
  progress.at_end(solver, scene.duration, sum.wall_seconds);

  series.write(opt.out_dir / "series");
  json m = run_metrics(scene, solver, sum, counts, series.max_ke_excess());
  m["centre_of_mass"] = centre_of_mass_metrics(solver.fluid(), loop.com_start);
  add_thread_metrics(m, team);
  if (loop.resumed_from >= 0) m["resumed"] = {{"from_s", loop.resumed_from}, {"sessions", loop.sessions}};
  if (!checkpoint.failures().empty()) m["warnings"].push_back(checkpoint.failures());
  m["monitors"] = series.summaries();
  if (watch.active()) add_terrain_metrics(m, scene, watch, opt.out_dir, sum.status);
  sum.metrics_json = m.dump(2);
  write_atomically(opt.out_dir / "metrics.json", sum.metrics_json + "\n");
  return sum;
}

}  // namespace

template <int D>
std::vector<std::pair<real, real>> surface_profile(const ParticleArrays<D>& fluid, real dp) {
  std::map<long, real> top;
  for (size_t i = 0; i < fluid.size(); ++i) {
    const long bin = static_cast<long>(std::floor(fluid.pos[0][i] / dp));
    const real z = fluid.pos[D - 1][i] + 0.5 * dp;
    auto it = top.find(bin);
    if (it == top.end())
      top[bin] = z;
    else
      it->second = std::max(it->second, z);
  }
  std::vector<std::pair<real, real>> out;
  for (const auto& [bin, z] : top) out.push_back({(bin + 0.5) * dp, z});
  return out;
}

template std::vector<std::pair<real, real>> surface_profile<2>(const ParticleArrays<2>&, real);
template std::vector<std::pair<real, real>> surface_profile<3>(const ParticleArrays<3>&, real);

bool has_checkpoint_of(const Scene& scene, const fs::path& out_dir) {
  std::ifstream file(out_dir / "checkpoint.bin", std::ios::binary);
  if (!file) return false;
  try {
    StateReader in(file);
    in.expect("runout checkpoint");
    return in.text() == checkpoint_identity(scene);
  } catch (const std::runtime_error&) {
    return false;
  }
}

namespace run_outputs {

void write_file_atomically(const fs::path& path, const std::string& text) { write_atomically(path, text); }

json terrain_outputs(const terrain::TerrainModel& tm, const terrain::InundationGrid& g, const OutputSettings& out,
                     const fs::path& dir, const std::vector<Vec<3>>& final_pos, const std::vector<real>& final_vol,
                     const RunLabel& label) {
  return write_terrain_outputs(tm, g, out, dir, final_pos, final_vol, label);
}

}  // namespace run_outputs

RunSummary run_scene(const Scene& scene, const RunOptions& options) {
  if (is_screening(scene)) return run_screening(scene, options);  // the screening rung (screening_run.hpp)
  return std::visit([&](const auto& setup) {
    constexpr int D = std::decay_t<decltype(setup)>::kDim;
    return run_typed<D>(scene, setup, options);
  }, scene.setup);
}

}  // namespace runout
