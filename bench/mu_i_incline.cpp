// mu(I) on an incline: a uniform granular layer against Bagnold's velocity profile, as a measurement of what each
// numerical choice does to it (the test, tests/engine/mu_i_incline_test.cpp, runs the scene; docs/validation.md
// section 5).
//
//   build/bench/bench_mu_i_incline [--t-end 5] [--trace] [--viscosity implicit|explicit] [--walls scene|bare]
//                                  [--wall-pressure dbc|extrapolated] [--floor on|off] [--slope 25]
//                                  [--density-diffusion none|molteni|fourtakas] [--c0 15]
//                                  [--shifting none|fickian]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <CLI/CLI.hpp>

#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;

namespace {

// Glass beads (Jop et al. 2006, their Fig. 2): mu_s = tan 20.9 deg, mu_2 = tan 32.76 deg, I0 = 0.279.
constexpr double kMuS = 0.38, kMu2 = 0.64, kI0 = 0.279, kD = 0.5e-3, kPhi = 0.6, kRho = 1500.0;

MaterialParams beads(double regularisation) {
  MaterialParams m;
  m.name = "beads";
  m.rheology = "mu-i";
  m.density = kRho;
  m.set("mu_s", kMuS).set("mu_2", kMu2).set("inertial_number_scale", kI0).set("grain_diameter", kD);
  m.set("solid_fraction", kPhi).set("regularisation", regularisation);
  return m;
}

}  // namespace

// A uniform layer H deep on a rough incline of angle theta reaches the steady Bagnold profile
//   u(z) = (2/3) (I_t / d) sqrt(phi g cos theta) (H^1.5 - (H - z)^1.5),  I_t = I0 (tan theta - mu_s) / (mu_2 - tan theta)
// (GDR MiDi 2004; Jop et al. 2006): the stress ratio is tan theta at every depth, so I = I_t everywhere.
// 2D, periodic along the slope (gravity tilted), a no-slip DBC bed, dp = 1 mm, H = 20 dp.
// `extrapolated`, `floor` and `shifting`: the extrapolated wall pressure, the density floor and the particle shifting
// a scene with a granular material gets (GranularDefaults); DBC walls, no floor and no shifting, as this layer was
// first run, otherwise.
void run(double t_end, bool trace, bool implicit, bool extrapolated, bool floor, double slope_deg,
         const std::string& ddt, double c0, const std::string& shifting) {
  const double theta = slope_deg * kPi / 180.0, g = 9.81, dp = 1e-3, H = 20 * dp, period = 12 * dp;
  SceneSetup<2> s;
  s.config.dp = dp;
  s.config.smoothing_length = 1.5 * dp;
  s.config.speed_of_sound = c0;  // the scene's 15 m/s: >= 10 x the surface speed (1.2 m/s)
  s.config.gravity = {g * std::sin(theta), -g * std::cos(theta), 0};
  s.config.boundary_density = kRho;
  s.config.periodic = {true, false, false};
  // The product's default for a yield-stress material (scenes: numerics.viscosity) is the implicit step.
  s.config.viscous_step = implicit ? ViscousStep::implicit : ViscousStep::explicit_capped;
  if (extrapolated) s.config.boundary_pressure = boundary_pressure_from_name(GranularDefaults::boundary_pressure);
  if (floor) {
    s.config.density_floor = GranularDefaults::density_floor;
    s.config.max_dilatancy = GranularDefaults::max_dilatancy;
  }
  s.config.particle_shifting = particle_shifting_from_name(shifting);
  if (!ddt.empty()) s.config.density_diffusion = density_diffusion_from_name(ddt);
  s.config.domain_min = {0.0, -10 * dp, 0};
  s.config.domain_max = {period, 1.0, 0};
  s.materials.push_back(beads(100.0));
  const double B = s.config.speed_of_sound * s.config.speed_of_sound * kRho / 7.0;
  for (int a = 0; a < 12; ++a) {
    for (int l = 0; l < 3; ++l) s.boundary.add(Vec<2>((a + 0.5) * dp, -(l + 0.5) * dp), kRho, kRho * dp * dp, 0, 1);
    for (int b = 0; b < 20; ++b) {
      const double z = (b + 0.5) * dp;
      const double rho = kRho * std::pow(1.0 + kRho * g * std::cos(theta) * (H - z) / B, 1.0 / 7.0);
      s.fluid.add(Vec<2>((a + 0.5) * dp, z), rho, kRho * dp * dp, 0, 0);
    }
  }
  Solver<2> solver(std::move(s));
  // Steady after a few diffusion times H^2 / nu (nu ~ 6.5e-4 m^2/s at mid-depth: 0.6 s); the profile is averaged
  // over the last 0.2 s.
  const double t_avg = t_end - 0.2;
  std::vector<double> u_sum(20, 0.0);
  std::vector<long> u_n(20, 0);
  // The pressure the law sees, per row over the averaging window: its mean and spread against lithostatic.
  std::vector<double> p_sum(20, 0.0), p_sq(20, 0.0), p_pos(20, 0.0);
  double mean_at_avg_start = 0;
  while (solver.time() < t_end) {
    solver.step();
    if (trace && solver.steps() % 5000 == 0) {
      const auto& f = solver.fluid();
      double m = 0, rho = 0, top = 0;
      for (size_t i = 0; i < f.size(); ++i) {
        m += f.vel[0][i] / f.size();
        rho += f.rho[i] / (kRho * f.size());
        top = std::max(top, static_cast<double>(f.pos[1][i]));
      }
      // The layer's thickness (top row's centre + dp / 2) and mean density tell a dilating or compacting layer.
      std::printf("t %.3f mean %.4f dt %.2e thickness %.2f dp mean rho/rho0 %.4f\n", solver.time(), m,
                  solver.last_step().dt, (top + 0.5 * dp) / dp, rho);
    }
    if (solver.time() < t_avg) continue;
    const auto& f = solver.fluid();
    double mean = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      const int bin = std::clamp(static_cast<int>(f.pos[1][i] / dp), 0, 19);
      u_sum[bin] += f.vel[0][i];
      ++u_n[bin];
      const double p = solver.fluid_pressure()[i];
      p_sum[bin] += p;
      p_sq[bin] += p * p;
      p_pos[bin] += std::max(p, 0.0);
      mean += f.vel[0][i] / f.size();
    }
    if (mean_at_avg_start == 0) mean_at_avg_start = mean;
  }
  const double i_t = kI0 * (std::tan(theta) - kMuS) / (kMu2 - std::tan(theta));
  const double scale = 2.0 / 3.0 * i_t / kD * std::sqrt(kPhi * g * std::cos(theta));
  auto bagnold = [&](double z) { return scale * (std::pow(H, 1.5) - std::pow(std::max(H - z, 0.0), 1.5)); };
  const double u_top = bagnold(H);
  double mean_sph = 0, mean_bagnold = 0, shape_sq = 0, sph_top = 0;
  int bins = 0;
  for (int k = 0; k < 20; ++k) {
    if (u_n[k] == 0) continue;
    const double z = (k + 0.5) * dp, u = u_sum[k] / u_n[k];
    mean_sph += u;
    mean_bagnold += bagnold(z);
    ++bins;
    sph_top = std::max(sph_top, u);
  }
  mean_sph /= bins;
  mean_bagnold /= bins;
  for (int k = 0; k < 20; ++k) {
    if (u_n[k] == 0) continue;
    const double z = (k + 0.5) * dp, u = u_sum[k] / u_n[k];
    const double d = u / mean_sph - bagnold(z) / mean_bagnold;
    shape_sq += d * d;
  }
  const double shape_rms = std::sqrt(shape_sq / bins);
  std::printf("row  u/Bagnold  <P>/lithostatic  <max(P,0)>/lithostatic  rms(P - <P>)/lithostatic\n");
  for (int k : {0, 2, 5, 10, 15, 18}) {
    if (u_n[k] == 0) continue;
    const double z = (k + 0.5) * dp, n = static_cast<double>(u_n[k]);
    const double litho = kRho * g * std::cos(theta) * (H - z), pm = p_sum[k] / n;
    std::printf("%3d  %8.3f  %14.3f  %21.3f  %24.3f\n", k, u_sum[k] / n / bagnold(z), pm / litho, p_pos[k] / n / litho,
                std::sqrt(std::max(p_sq[k] / n - pm * pm, 0.0)) / litho);
  }
  std::printf("Bagnold: mean u SPH %.4f m/s, analytic %.4f m/s (%.1f %%); surface %.3f / %.3f m/s; shape rms %.3f\n",
              mean_sph, mean_bagnold, 100 * (mean_sph / mean_bagnold - 1), sph_top, u_top, shape_rms);
  std::printf("mean speed over the last 0.2 s changed by %.2f %% from its start\n", 100 * (mean_sph / mean_at_avg_start - 1));
}

int main(int argc, char** argv) {
  CLI::App app{"mu(I) layer on a 25 degree incline against Bagnold's profile. Example: bench_mu_i_incline --t-end 5"};
  double t_end = 5.0;
  bool trace = false;
  std::string viscosity = "implicit", walls = "scene", wall_pressure, floor, ddt, shifting;
  double slope_deg = 25.0, c0 = 15.0;
  app.add_option("--viscosity", viscosity, "the viscous step (a scene's default for mu(I): implicit)")
      ->check(CLI::IsMember({"explicit", "implicit"}));
  app.add_option("--walls", walls, "scene: the wall pressure and density floor a scene with mu(I) gets; bare: DBC, no floor")
      ->check(CLI::IsMember({"scene", "bare"}));
  app.add_option("--wall-pressure", wall_pressure, "overrides --walls for the wall pressure")
      ->check(CLI::IsMember({"dbc", "extrapolated"}));
  app.add_option("--floor", floor, "overrides --walls for the density floor")->check(CLI::IsMember({"on", "off"}));
  app.add_option("--slope", slope_deg, "incline [degrees]; below atan(mu_s) = 20.8 the layer rests (a check of the "
                                       "rows' pressure against lithostatic, no Bagnold profile)")
      ->check(CLI::Range(0.0, 30.0));
  app.add_option("--t-end", t_end, "simulated time [s]")->check(CLI::Range(0.3, 100.0));
  app.add_option("--density-diffusion", ddt, "overrides the default density diffusion term")
      ->check(CLI::IsMember(density_diffusion_names()));
  app.add_option("--shifting", shifting, "overrides --walls for the particle shifting (scene: fickian; bare: none)")
      ->check(CLI::IsMember(particle_shifting_names()));
  app.add_option("--c0", c0, "speed of sound [m/s]")->check(CLI::Range(5.0, 200.0));
  app.add_flag("--trace", trace, "print the mean speed every 5000 steps");
  CLI11_PARSE(app, argc, argv);
  const bool extrapolated = wall_pressure.empty() ? walls == "scene" : wall_pressure == "extrapolated";
  const bool with_floor = floor.empty() ? walls == "scene" : floor == "on";
  if (shifting.empty()) shifting = walls == "scene" ? GranularDefaults::particle_shifting : "none";
  run(t_end, trace, viscosity == "implicit", extrapolated, with_floor, slope_deg, ddt, c0, shifting);
  return 0;
}
