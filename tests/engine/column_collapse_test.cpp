// Validation: granular column collapse of Bui et al. (2008), thesis section 4.3.1, in 2D at dp = 5 mm
// (the thesis used 2.5 mm in 3D). Both scenes run through run_scene, which writes series/final_surface.csv, the
// deposit profile compared with the experiment in docs/validation.md.
//   scenarios/validation/column_collapse_2d.json      friction-HBP, phi = 19.8 deg, c = 0, m = 100, n = 1
//   scenarios/validation/column_collapse_hbp_2d.json  plain HBP, tau_y = 0.36 kPa (the thesis' equivalent)
//
// Physical facts checked:
//  * the frictional column comes to rest by itself: the kinetic energy at the end is under 1 % of its peak, the
//    front moved less than one particle spacing over the last 0.2 s, and the deposit stops short of the tank's
//    far wall (1 m; the experiment's deposit ends at 0.44 m), i.e. basal friction, not the wall, stopped it;
//  * the plain HBP column comes to rest the same way, and its deposit is at least as long as the shortest
//    deposit a yield-stress material can rest in: in the shallow-layer limit a static layer needs
//    rho g h |dh/dx| <= tau_y, so against the wall the static profile is h^2 = 2 tau_y (x_f - x) / (rho g), and
//    holding the column's area (0.02 m^2) it ends at x_f = (3 A / (2 sqrt(2 tau_y / (rho g))))^(2/3) = 0.319 m;
//    5 % below that is allowed for the shallow-layer approximation at the steep toe;
//  * no leak, mass exact, Mach number under 0.1;
//  * the frictional deposit's bulk is the experiment's, at the product's default numerics (the implicit viscous
//    step, no cap): where it thins to 1 cm and its height at the wall each within 10 % of the experiment's
//    (0.368 m, 0.099 m; the aim issue 43 declared before the implicit step was built), and its height profile
//    within 1 cm rms of the experiment's (10 % of the column's height). Not its front particle: a one-particle sheet
//    (5 mm) runs on ahead of the bulk (0.52 m against the experiment's last 1.5 mm of deposit at 0.44 m),
//    reported in docs/validation.md.
// Not asserted: the thesis' statement that the plain HBP material "runs farther and flatter". With the yield
// stress convention of this engine (simple shear gives tau_xy = tau_y; tests/engine/rheology_test.cpp) a
// 0.36 kPa deposit can rest at 0.32 m, shorter than the experiment's 0.44 m, so the claim is not a physical
// fact here; at tau_y = sin(phi) x the friction run's own mean pressure (0.26 kPa) plain HBP ends where the
// friction deposit does, and only under ~0.2 kPa does it run farther and flatter (docs/validation.md, "Status
// now", where the tau_y sweep is).
//
// Experimental final surface: Bui et al. (2008), Int. J. Numer. Anal. Meth. Geomech. 32:1537-1570,
// doi:10.1002/nag.688, as digitised in github.com/ewyser/ep2-3De, ep23De_v1.0/ep3De_v1.0/scripts/setting_Exp1a/
// Data_Buietal_2008_experimental_surface.txt (x, height in m; the left wall at x = 0, the column 0.2 m long).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;
namespace fs = std::filesystem;

namespace {

// Bui et al. (2008) final surface (x, h) [m].
const std::vector<std::pair<double, double>> kBuiSurface = {
    {0.00012288, 0.099231753}, {0.019603788, 0.099281704}, {0.03983696, 0.095872045}, {0.060043158, 0.089000779},
    {0.080267338, 0.084437251}, {0.100083918, 0.077564986}, {0.120302104, 0.072232212}, {0.140127675, 0.066513816},
    {0.160348858, 0.061565666}, {0.180159444, 0.053924154}, {0.199979021, 0.047436512}, {0.220200204, 0.042488361},
    {0.240790026, 0.034848848}, {0.262186058, 0.030672941}, {0.282023617, 0.026493037}, {0.3022448, 0.021544886},
    {0.322094348, 0.018903475}, {0.342312534, 0.013570701}, {0.362162081, 0.010929289}, {0.38239825, 0.007904254},
    {0.402235809, 0.00372435},  {0.422094348, 0.002236808}, {0.442348498, 0.001519511}};

std::vector<std::vector<double>> read_csv(const fs::path& p, std::vector<std::string>& header) {
  std::ifstream in(p);
  std::string line;
  std::vector<std::vector<double>> rows;
  if (!std::getline(in, line)) return rows;
  header.clear();
  {
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) header.push_back(c);
  }
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) v.push_back(std::stod(c));
    rows.push_back(v);
  }
  return rows;
}

size_t column(const std::vector<std::string>& header, const std::string& name) {
  return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
}

struct Deposit {
  double ke_peak = 0, ke_end = 0, front_end = 0, front_before = 0, runout = 0, wall_height = 0;
  double max_mach = 0, mass_error = 0, wall_seconds = 0;
  long steps = 0, leaks = 0;
  std::vector<std::pair<double, double>> surface;  // x, h
  std::string status, error;
};

Deposit run(const std::string& scene_file, const std::string& out_name) {
  Deposit d;
  const Scene scene = load_scene(fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "validation" / scene_file);
  const real dp = scene.dp;
  RunOptions opt;
  opt.out_dir = fs::path(RUNOUT_BINARY_DIR) / "validation" / out_name;
  const RunSummary sum = run_scene(scene, opt);
  d.status = sum.status;
  d.error = sum.error;
  d.steps = sum.steps;
  d.wall_seconds = sum.wall_seconds;
  const auto m = nlohmann::json::parse(sum.metrics_json);
  d.max_mach = m["max_mach"].get<double>();
  d.mass_error = m["mass"]["relative_error"].get<double>();
  d.leaks = m["leaks"].get<long>();

  std::vector<std::string> h;
  const auto rows = read_csv(opt.out_dir / "series" / "run.csv", h);
  const size_t ct = column(h, "t"), ck = column(h, "kinetic_energy"), cf = column(h, "front_x");
  if (rows.empty() || std::max({ct, ck, cf}) >= h.size()) return d;
  const double t_end = rows.back()[ct];
  for (const auto& r : rows) {
    d.ke_peak = std::max(d.ke_peak, r[ck]);
    if (r[ct] <= t_end - 0.2 + 1e-9) d.front_before = r[cf] + 0.5 * dp;
  }
  d.ke_end = rows.back()[ck];
  d.front_end = rows.back()[cf] + 0.5 * dp;
  d.runout = d.front_end;  // the deposit's toe: front particle (k-th largest x) plus half a spacing

  const auto surf = read_csv(opt.out_dir / "series" / "final_surface.csv", h);
  for (const auto& r : surf) d.surface.push_back({r[0], r[1]});
  if (!d.surface.empty()) d.wall_height = d.surface.front().second;  // the bin against the left wall
  return d;
}

// Height of a piecewise-linear profile at x (0 beyond its ends).
double height_at(const std::vector<std::pair<double, double>>& s, double x) {
  if (s.empty() || x < s.front().first || x > s.back().first) return 0.0;
  for (size_t i = 1; i < s.size(); ++i)
    if (s[i].first >= x) {
      const double w = (x - s[i - 1].first) / (s[i].first - s[i - 1].first);
      return s[i - 1].second + w * (s[i].second - s[i - 1].second);
    }
  return s.back().second;
}

// Where a profile last falls to `depth` (linear between the points; 0 if it never reaches it).
double extent_at_depth(const std::vector<std::pair<double, double>>& s, double depth) {
  for (size_t i = s.size(); i-- > 1;)
    if (s[i - 1].second >= depth && s[i].second < depth)
      return s[i - 1].first + (s[i - 1].second - depth) / (s[i - 1].second - s[i].second) * (s[i].first - s[i - 1].first);
  return !s.empty() && s.back().second >= depth ? s.back().first : 0.0;
}

// Rms height difference to the experiment every 2 cm from 0.01 m to 0.69 m, where either profile has material.
double rms_against_experiment(const std::vector<std::pair<double, double>>& s);

void print(const char* name, const Deposit& d) {
  // Profile against the experiment, every 2 cm.
  std::printf("  %s: status %s, %ld steps, %.1f s wall, max Mach %.3f\n", name, d.status.c_str(), d.steps,
              d.wall_seconds, d.max_mach);
  std::printf("    x [m]   h sim [m]   h Bui et al. 2008 [m]\n");
  for (double x = 0.01; x <= 0.7; x += 0.02) {
    const double hs = height_at(d.surface, x), he = height_at(kBuiSurface, x);
    if (hs == 0 && he == 0) continue;
    std::printf("    %.2f    %.4f      %.4f\n", x, hs, he);
  }
  std::printf("    extent at 1 cm depth %.3f m (experiment %.3f m)\n", extent_at_depth(d.surface, 0.01),
              extent_at_depth(kBuiSurface, 0.01));
  std::printf(
      "    run-out %.3f m (experiment %.3f m), height at the wall %.4f m (experiment %.4f m), rms height "
      "difference %.4f m; kinetic energy end/peak %.2e (peak %.3f J/m), front moved %.4f m over the last 0.2 s\n",
      d.runout, kBuiSurface.back().first, d.wall_height, kBuiSurface.front().second, rms_against_experiment(d.surface),
      d.ke_end / d.ke_peak, d.ke_peak, d.front_end - d.front_before);
}

double rms_against_experiment(const std::vector<std::pair<double, double>>& s) {
  double sq = 0;
  int n = 0;
  for (double x = 0.01; x <= 0.7; x += 0.02) {
    const double hs = height_at(s, x), he = height_at(kBuiSurface, x);
    if (hs == 0 && he == 0) continue;
    sq += (hs - he) * (hs - he);
    ++n;
  }
  return std::sqrt(sq / std::max(n, 1));
}

}  // namespace

namespace {
const double kTankLength = 1.0;  // the scenes' tank inner length [m]
const double kColumnArea = 0.2 * 0.1;

void expect_run_ok_and_at_rest(const Deposit& d, double dp) {
  ASSERT_EQ(d.status, "completed") << d.error;
  EXPECT_EQ(d.leaks, 0);
  EXPECT_LT(std::abs(d.mass_error), 1e-12);
  EXPECT_LT(d.max_mach, 0.1);
  EXPECT_GT(d.runout, 0.2);  // it did collapse
  EXPECT_LT(d.ke_end, 0.01 * d.ke_peak) << "still moving at the end of the run";
  EXPECT_LT(std::abs(d.front_end - d.front_before), dp) << "the front still advances";
  EXPECT_LT(d.runout, kTankLength - 2 * dp) << "the deposit reached the far wall";
}
}  // namespace

TEST(ColumnCollapseValidation, FrictionColumnComesToRestOnItsOwn) {
  const Scene probe = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/column_collapse_2d.json");
  const Deposit fr = run("column_collapse_2d.json", "column_collapse_2d");
  print("friction-HBP (phi = 19.8 deg)", fr);
  expect_run_ok_and_at_rest(fr, probe.dp);
  const double extent = extent_at_depth(kBuiSurface, 0.01), wall = kBuiSurface.front().second;
  EXPECT_NEAR(extent_at_depth(fr.surface, 0.01), extent, 0.1 * extent) << "where the deposit thins to 1 cm";
  EXPECT_NEAR(fr.wall_height, wall, 0.1 * wall) << "the deposit's height at the wall";
  EXPECT_LT(rms_against_experiment(fr.surface), 0.01) << "rms height difference to the experiment";
}

// The deposit thinning to 1 cm within 2 dp of the experiment's 0.368 m (the surface resolved to a particle). At the
// explicit step with cap factor 3 it passed (0.371 m); at the implicit step the deposit thinned 18 mm short (0.350 m,
// 2026-12-05) and this was a known failure until particle shifting became a granular default (2026-12-07).
TEST(ColumnCollapseValidation, FrictionDepositThinsWithinTwoSpacingsOfTheExperiment) {
  const Scene probe = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/column_collapse_2d.json");
  const Deposit fr = run("column_collapse_2d.json", "column_collapse_2d_two_spacings");
  ASSERT_EQ(fr.status, "completed") << fr.error;
  std::printf("deposit thins to 1 cm at %.4f m (experiment %.4f m, 2 dp = %.3f m)\n", extent_at_depth(fr.surface, 0.01),
              extent_at_depth(kBuiSurface, 0.01), 2 * probe.dp);
  EXPECT_NEAR(extent_at_depth(fr.surface, 0.01), extent_at_depth(kBuiSurface, 0.01), 2 * probe.dp);
}

TEST(ColumnCollapseValidation, PlainHbpComesToRestNoShorterThanItsStaticDeposit) {
  const Scene probe = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/column_collapse_hbp_2d.json");
  const auto& setup = std::get<SceneSetup<2>>(probe.setup);
  const double rho = setup.materials.at(0).density, tau_y = setup.materials.at(0).value("yield_stress");
  const double g = -setup.config.gravity[1];
  const double x_static = std::pow(3 * kColumnArea / (2 * std::sqrt(2 * tau_y / (rho * g))), 2.0 / 3.0);
  const Deposit hb = run("column_collapse_hbp_2d.json", "column_collapse_hbp_2d");
  print("plain HBP (tau_y = 0.36 kPa)", hb);
  std::printf("    static yield-stress deposit (shallow-layer limit) ends at %.3f m\n", x_static);
  expect_run_ok_and_at_rest(hb, probe.dp);
  EXPECT_GE(hb.runout, 0.95 * x_static);
}
