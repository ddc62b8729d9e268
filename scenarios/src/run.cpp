#include "runout/scenarios/run.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

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

template <int D>
void write_vtp(const fs::path& path, const Solver<D>& s) {
  const auto& f = s.fluid();
  const auto& b = s.boundary();
  std::ostringstream o;
  o << std::setprecision(7);
  const size_t n = f.size() + b.size();
  o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
    << "<PolyData>\n<Piece NumberOfPoints=\"" << n << "\" NumberOfVerts=\"" << n
    << "\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n<Points>\n"
    << "<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  auto write_pos = [&](const ParticleArrays<D>& p) {
    for (size_t i = 0; i < p.size(); ++i) {
      o << p.pos[0][i] << ' ' << (D == 3 ? p.pos[1][i] : 0.0) << ' ' << p.pos[D - 1][i] << '\n';
    }
  };
  write_pos(f);
  write_pos(b);
  o << "</DataArray>\n</Points>\n<PointData Scalars=\"pressure\" Vectors=\"velocity\">\n";
  o << "<DataArray type=\"Float32\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (size_t i = 0; i < f.size(); ++i)
    o << f.vel[0][i] << ' ' << (D == 3 ? f.vel[1][i] : 0.0) << ' ' << f.vel[D - 1][i] << '\n';
  for (size_t i = 0; i < b.size(); ++i) o << "0 0 0\n";
  o << "</DataArray>\n<DataArray type=\"Float32\" Name=\"density\" format=\"ascii\">\n";
  for (size_t i = 0; i < f.size(); ++i) o << f.rho[i] << '\n';
  for (size_t i = 0; i < b.size(); ++i) o << b.rho[i] << '\n';
  o << "</DataArray>\n<DataArray type=\"Float32\" Name=\"pressure\" format=\"ascii\">\n";
  const auto& p = s.fluid_pressure();
  for (size_t i = 0; i < f.size(); ++i) o << (i < p.size() ? p[i] : 0.0) << '\n';
  const auto& bp = s.boundary_pressure();
  for (size_t i = 0; i < b.size(); ++i) o << bp[i] << '\n';
  o << "</DataArray>\n<DataArray type=\"Float32\" Name=\"effective_viscosity\" format=\"ascii\">\n";
  const auto& mu = s.fluid_effective_viscosity();
  for (size_t i = 0; i < f.size(); ++i) o << (i < mu.size() ? mu[i] : 0.0) << '\n';
  for (size_t i = 0; i < b.size(); ++i) o << "0\n";
  o << "</DataArray>\n<DataArray type=\"Int32\" Name=\"type\" format=\"ascii\">\n";
  for (size_t i = 0; i < f.size(); ++i) o << "0\n";
  for (size_t i = 0; i < b.size(); ++i) o << "1\n";
  o << "</DataArray>\n<DataArray type=\"Int32\" Name=\"material_or_tag\" format=\"ascii\">\n";
  for (size_t i = 0; i < f.size(); ++i) o << f.material[i] << '\n';
  for (size_t i = 0; i < b.size(); ++i) o << b.tag[i] << '\n';
  o << "</DataArray>\n</PointData>\n<Verts>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (size_t i = 0; i < n; ++i) o << i << '\n';
  o << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (size_t i = 0; i < n; ++i) o << i + 1 << '\n';
  o << "</DataArray>\n</Verts>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  write_atomically(path, o.str());
}

template <int D>
RunSummary run_typed(const Scene& scene, const SceneSetup<D>& setup, const RunOptions& opt) {
  using clock = std::chrono::steady_clock;
  RunSummary sum;
  if (opt.threads > 0) omp_set_num_threads(opt.threads);
  fs::create_directories(opt.out_dir / "series");
  if (opt.snapshots) fs::create_directories(opt.out_dir / "snapshots");

  Solver<D> solver(setup);
  const size_t n_fluid0 = solver.fluid().size();
  const size_t n_bound = solver.boundary().size();
  std::ostringstream series;
  series << std::setprecision(9);
  series << "t,dt,kinetic_energy,potential_energy_released,max_speed,front_x,fluid_mass,outflow_mass,fluid_particles,"
            "active_boundary\n";
  auto sample = [&](const StepStats& st) {
    const auto e = solver.energy();
    const auto m = solver.mass_balance();
    series << solver.time() << ',' << st.dt << ',' << e.kinetic << ',' << e.potential_released << ','
           << st.max_speed << ',' << front_position(solver.fluid()) << ',' << static_cast<double>(m.total_current())
           << ',' << static_cast<double>(m.total_outflow()) << ',' << solver.fluid().size() << ','
           << st.active_boundary << '\n';
  };

  const real snap_dt = opt.snapshots ? (scene.output.snapshot_interval > 0 ? scene.output.snapshot_interval
                                                                           : scene.duration / 20.0)
                                     : 0.0;
  int snap_index = 0;
  real next_snap = 0, next_sample = 0;
  real max_ke_excess = -1e300;  // max over samples of KE - PE released (must stay <= 0 up to noise)
  const auto t0 = clock::now();
  auto last_progress = t0;
  long particle_steps = 0;
  try {
    if (opt.snapshots) {
      write_vtp(opt.out_dir / "snapshots" / "snapshot_0000.vtp", solver);
      ++snap_index;
      next_snap = snap_dt;
    }
    sample(solver.last_step());
    next_sample = scene.output.series_interval;
    while (solver.time() < scene.duration) {
      if (opt.stop && opt.stop->load()) {
        sum.status = "stopped";
        break;
      }
      particle_steps += static_cast<long>(solver.fluid().size());
      const StepStats& st = solver.step();
      if (solver.time() >= next_sample - 1e-12) {
        sample(st);
        const auto e = solver.energy();
        max_ke_excess = std::max(max_ke_excess, e.kinetic - e.potential_released);
        next_sample += scene.output.series_interval;
      }
      if (opt.snapshots && solver.time() >= next_snap - 1e-12) {
        std::ostringstream name;
        name << "snapshot_" << std::setw(4) << std::setfill('0') << snap_index++ << ".vtp";
        write_vtp(opt.out_dir / "snapshots" / name.str(), solver);
        next_snap += snap_dt;
      }
      const auto now = clock::now();
      if (opt.on_progress && now - last_progress > std::chrono::milliseconds(250)) {
        last_progress = now;
        opt.on_progress({solver.time(), scene.duration, solver.steps(),
                         std::chrono::duration<double>(now - t0).count(), solver.fluid().size()});
      }
    }
    if (sum.status.empty()) sum.status = "completed";
  } catch (const SimulationError& e) {
    sum.status = "failed";
    sum.error = e.what();
  }
  sum.wall_seconds = std::chrono::duration<double>(clock::now() - t0).count();
  sum.steps = solver.steps();
  sum.simulated_time = solver.time();
  sum.particle_steps_per_second = sum.wall_seconds > 0 ? particle_steps / sum.wall_seconds : 0;
  if (opt.on_progress)
    opt.on_progress({solver.time(), scene.duration, solver.steps(), sum.wall_seconds, solver.fluid().size()});

  // Final surface profile.
  {
    std::ostringstream prof;
    prof << std::setprecision(9) << "x,surface_height\n";
    for (const auto& [x, z] : surface_profile<D>(solver.fluid(), scene.dp)) prof << x << ',' << z << '\n';
    write_atomically(opt.out_dir / "series" / "final_surface.csv", prof.str());
  }
  write_atomically(opt.out_dir / "series" / "run.csv", series.str());

  const auto mb = solver.mass_balance();
  const auto e = solver.energy();
  const auto& cfg = solver.config();
  json m;
  m["scene"] = scene.name;
  m["status"] = sum.status;
  if (!sum.error.empty()) m["error"] = sum.error;
  m["dimensions"] = D;
  m["particles"] = {{"fluid_initial", n_fluid0}, {"fluid_final", solver.fluid().size()}, {"boundary", n_bound}};
  m["steps"] = sum.steps;
  m["simulated_time_s"] = sum.simulated_time;
  m["wall_time_s"] = sum.wall_seconds;
  m["particle_steps_per_s"] = sum.particle_steps_per_second;
  m["threads"] = omp_get_max_threads();
  m["dt"] = {{"min_s", solver.min_dt_seen() < 1e299 ? solver.min_dt_seen() : 0.0}, {"last_s", solver.last_step().dt}};
  m["max_mach"] = solver.max_mach();
  if (solver.max_mach() > 0.1)
    m["warnings"].push_back("max Mach number " + std::to_string(solver.max_mach()) +
                            " exceeds 0.1: raise numerics.speed_of_sound");
  const long double m0 = mb.total_initial(), m1 = mb.total_current(), mo = mb.total_outflow();
  m["mass"] = {{"initial_kg", static_cast<double>(m0)},
               {"final_kg", static_cast<double>(m1)},
               {"outflow_kg", static_cast<double>(mo)},
               {"relative_error", m0 > 0 ? static_cast<double>((m1 + mo - m0) / m0) : 0.0}};
  m["leaks"] = sum.status == "failed" && sum.error.find("leaked") != std::string::npos ? 1 : 0;
  m["energy"] = {{"kinetic_final_j", e.kinetic},
                 {"potential_released_j", e.potential_released},
                 {"max_kinetic_minus_released_j", max_ke_excess}};
  m["front_x_m"] = front_position(solver.fluid());
  m["settings"] = {{"dp_m", cfg.dp},
                   {"smoothing_length_m", cfg.smoothing_length},
                   {"kernel", std::string(kernel_name(cfg.kernel))},
                   {"integrator", cfg.integrator == Integrator::symplectic ? "symplectic" : "verlet"},
                   {"speed_of_sound_m_s", cfg.speed_of_sound},
                   {"cfl", cfg.cfl},
                   {"artificial_viscosity", cfg.artificial_viscosity},
                   {"density_diffusion_delta", cfg.density_diffusion_delta},
                   {"viscosity_cap_pa_s", solver.max_viscosity()},
                   {"shear_rate_floor_1_s", cfg.shear_rate_floor}};
  json tags = json::object();
  for (size_t k = 1; k < scene.boundary_tags.size(); ++k) tags[std::to_string(k)] = scene.boundary_tags[k];
  m["boundary_tags"] = tags;
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

RunSummary run_scene(const Scene& scene, const RunOptions& options) {
  return std::visit([&](const auto& setup) {
    constexpr int D = std::decay_t<decltype(setup)>::kDim;
    return run_typed<D>(scene, setup, options);
  }, scene.setup);
}

}  // namespace runout
