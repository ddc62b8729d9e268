// Validation: 2D dam break on a dry bed (scenarios/validation/dam_break_mm_2d.json), run through run_scene so the
// product's own front metric (series/run.csv: front_x, the k-th largest particle x) is what gets checked.
//
// Column: width a = 0.3 m, height 2a (n^2 = 2 in Martin & Moyce's notation), against the left wall; the front
// is Z = (front_x + dp/2) / a (a particle's volume reaches half a spacing beyond its centre, so Z = 1 at t = 0)
// and the time T = t sqrt(2 g / a) = n t sqrt(g / a), Martin & Moyce's scaling for n^2 = 2. The simulated
// clock is compared with the experiment's as it is: no time shift is fitted or applied anywhere.
//
// 1. Ritter bound: on a dry frictionless bed no part of the surge can outrun 2 sqrt(g H) (H = 2a, the initial
//    depth). Checked on the front speed over every 0.1 s window: no tolerance, it is a bound.
// 2. Mean front speed over T in [2, 6] against the experiment's over the same interval (0.771 of the Ritter
//    speed in the a = 2.25 in data): within 10 %, the spread between Martin & Moyce's two column sizes. A speed
//    does not depend on where either clock starts.
// 3. Front position against Martin & Moyce (1952), n^2 = 2, a = 2.25 in, for T in [1, 6.35] (the front reaches
//    the far wall at Z = 10.7), at the same T: the mean relative error. Its limit is built from two independent
//    numbers, both computed below from the tables, none from this code:
//    - the release: the experiment's column was not released at an instant. Lethe's Navier-Stokes VOF run of the
//      same experiment (same data) adds 0.175 to its T (examples/multiphysics/dam-break/dam-break-2d.py,
//      `time_correction`, chaos-polymtl/lethe 129b71aa); an exact instant-release solution that differs
//      from the experiment only by that delay has a mean relative error of 8.0 % over the points used here;
//    - the experiment's scatter: Martin & Moyce's a = 1.125 in column against the a = 2.25 in one at the same T
//      differ by 3.4 % on average (up to 9 %).
//    Their sum, 11.4 %, was composed after the 9.1 % it would judge had been measured, and every converged run
//    (7.7-10.3 %) is inside it, so it is printed, not asserted (issue 42, item 4.1). What is asserted is the
//    aim its issue set before any run, 6 %, as a known failure (DISABLED_FrontWithinSixPercentOfMartinMoyce,
//    WILL_FAIL): the converged front leads by 8-11 %, docs/validation.md, section 2.
//    The same error against Koshizuka & Oka's curve (T in [1, 3.1]) is printed, not asserted: the stored copy of
//    that curve does not say whether it is measured or computed (docs/validation-data.md, 3.2).
// 4. Mach number under 0.1 (c0 = 50 m/s), no leak, mass exact.
//
// Experimental points (T, Z), digitised from Martin & Moyce (1952), Phil. Trans. R. Soc. A 244, 312-324,
// doi:10.1098/rsta.1952.0006, as published in:
//   - PySPH, pysph/examples/db_exp_data.py, mm_data_2 ("n^2 = 2 and a = 2.25 from Figure 3");
//   - Lethe, examples/multiphysics/dam-break/dam-break-2d.py (x_exp, y_exp: fixed-position readings that agree
//     with PySPH's a = 2.25 in points where they overlap).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
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

namespace {

struct Point {
  double T, Z;
};
// PySPH mm_data_2 (Martin & Moyce 1952, n^2 = 2, a = 2.25 in).
const std::vector<Point> kPySph = {{0.832, 1.217}, {1.219, 1.474}, {1.997, 2.292}, {2.547, 2.995}, {3.345, 4.134},
                                   {4.034, 4.944}, {4.418, 5.881}, {5.091, 6.980}, {5.685, 7.945}, {6.306, 8.966},
                                   {6.822, 9.986}, {7.439, 10.963}, {8.031, 11.977}, {8.633, 13.005},
                                   {9.237, 13.970}};
// Lethe's table of the same experiment.
const std::vector<Point> kLethe = {{0.41, 1.11}, {0.84, 1.23}, {1.19, 1.44}, {1.43, 1.67}, {1.63, 1.89},
                                   {1.82, 2.11}, {1.97, 2.33}, {2.2, 2.56},  {2.32, 2.78}, {2.5, 3.0},
                                   {2.64, 3.22}, {2.82, 3.44}, {2.96, 3.67}};
// PySPH mm_data_1: the same experiment with the a = 1.125 in column (the experiment's scatter between sizes).
const std::vector<Point> kPySphSmall = {{0.849, 1.245}, {1.212, 1.443}, {1.602, 1.884}, {2.283, 2.689},
                                        {2.950, 3.728}, {3.598, 4.528}, {3.905, 4.999}, {4.592, 5.841},
                                        {4.961, 6.271}, {5.316, 6.717}};
// PySPH ko_data: Koshizuka & Oka (1996), z/L against t sqrt(2g/L), the same n^2 = 2 column.
const std::vector<Point> kKoshizukaOka = {{0.381, 1.111}, {0.769, 1.252}, {1.153, 1.505}, {1.537, 1.892},
                                          {1.935, 2.241}, {2.323, 2.615}, {2.719, 3.003}, {3.096, 3.624}};
// Lethe's gate delay for the same data (its VOF comparison, see the header).
constexpr double kLetheDelay = 0.175;

// Linear interpolation of Z at T in a series sorted by T; NaN outside.
double interp(const std::vector<Point>& s, double T) {
  for (size_t i = 1; i < s.size(); ++i)
    if (s[i].T >= T && s[i - 1].T <= T) {
      const double w = (T - s[i - 1].T) / (s[i].T - s[i - 1].T);
      return s[i - 1].Z + w * (s[i].Z - s[i - 1].Z);
    }
  return std::nan("");
}

// Runs the scene and checks what holds (the bounds: items 1, 2, 4) or, with `aim`, the position aim of item 3.
void surge_front(bool aim) {
  const Scene scene = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/dam_break_mm_2d.json");
  const auto& setup = std::get<SceneSetup<2>>(scene.setup);
  const real dp = scene.dp;
  const real g = -setup.config.gravity[1];
  // Column geometry from the scene's fluid: width a, height H (the test needs the n^2 = 2 column).
  real xmax = -1e300, zmax = -1e300, xmin = 1e300;
  for (size_t i = 0; i < setup.fluid.size(); ++i) {
    xmax = std::max(xmax, setup.fluid.pos[0][i] + 0.5 * dp);
    xmin = std::min(xmin, setup.fluid.pos[0][i] - 0.5 * dp);
    zmax = std::max(zmax, setup.fluid.pos[1][i] + 0.5 * dp);
  }
  ASSERT_NEAR(xmin, 0.0, 1e-9) << "the column must stand against the wall face x = 0";
  const double a = xmax, H = zmax;
  ASSERT_NEAR(H / a, 2.0, 1e-9) << "Martin & Moyce's published points used here are for n^2 = H/a = 2";
  const double Tscale = std::sqrt(2 * g / a);  // T = t sqrt(2g/a) = n t sqrt(g/a) for n^2 = 2
  const double ritter = 2 * std::sqrt(g * H);

  const std::filesystem::path out =
      std::filesystem::path(RUNOUT_BINARY_DIR) / "validation" / (aim ? "dam_break_mm_2d_aim" : "dam_break_mm_2d");
  RunOptions opt;
  opt.out_dir = out;
  const RunSummary sum = run_scene(scene, opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;  // a leak or NaN fails here
  const auto m = nlohmann::json::parse(sum.metrics_json);

  // The simulated front, from series/run.csv.
  std::vector<Point> sim;
  std::vector<double> t_s, x_s;
  {
    std::ifstream in(out / "series" / "run.csv");
    std::string line;
    std::getline(in, line);
    std::vector<std::string> cols;
    {
      std::stringstream ss(line);
      std::string c;
      while (std::getline(ss, c, ',')) cols.push_back(c);
    }
    const auto col = [&](const std::string& name) {
      return static_cast<size_t>(std::find(cols.begin(), cols.end(), name) - cols.begin());
    };
    const size_t ct = col("t"), cx = col("front_x");
    ASSERT_LT(std::max(ct, cx), cols.size());
    while (std::getline(in, line)) {
      std::vector<double> v;
      std::stringstream ss(line);
      std::string c;
      while (std::getline(ss, c, ',')) v.push_back(std::stod(c));
      t_s.push_back(v[ct]);
      x_s.push_back(v[cx] + 0.5 * dp);
      sim.push_back({v[ct] * Tscale, (v[cx] + 0.5 * dp) / a});
    }
  }
  ASSERT_GT(sim.size(), 50u);
  EXPECT_NEAR(sim.front().Z, 1.0, 1e-9);

  // 1. Ritter bound over 0.1 s windows.
  double vmax = 0;
  for (size_t i = 0; i < t_s.size(); ++i)
    for (size_t j = i + 1; j < t_s.size(); ++j)
      if (t_s[j] - t_s[i] >= 0.1 - 1e-9) {
        vmax = std::max(vmax, (x_s[j] - x_s[i]) / (t_s[j] - t_s[i]));
        break;
      }

  // 2. Mean front speed over T in [2, 6], simulation and experiment, as fractions of the Ritter speed.
  const double sim_speed = a * (interp(sim, 6.0) - interp(sim, 2.0)) / (4.0 / Tscale) / ritter;
  const double exp_speed = a * (interp(kPySph, 6.0) - interp(kPySph, 2.0)) / (4.0 / Tscale) / ritter;

  // 3. Front position at the same T, against Martin & Moyce (both tables as one curve) and Koshizuka & Oka.
  std::vector<Point> mm;
  for (const auto& p : kPySph) mm.push_back(p);
  for (const auto& p : kLethe) mm.push_back(p);
  std::sort(mm.begin(), mm.end(), [](const Point& l, const Point& r) { return l.T < r.T; });
  // Mean |relative error| of curve `c` (at T + dT) against the points of `ref` with T in [T0, T1].
  auto mean_error = [](const std::vector<Point>& c, const std::vector<Point>& ref, double T0, double T1, double dT,
                       double* worst) {
    double s = 0;
    int n = 0;
    for (const auto& p : ref) {
      const double z = interp(c, p.T + dT);
      if (p.T < T0 || p.T > T1 || std::isnan(z)) continue;
      s += std::abs(z - p.Z) / p.Z;
      ++n;
      if (worst) *worst = std::max(*worst, std::abs(z - p.Z) / p.Z);
    }
    return n ? s / n : std::nan("");
  };
  double worst_mm = 0, worst_ko = 0;
  const double err_mm = mean_error(sim, mm, 1.0, 6.35, 0.0, &worst_mm);
  const double err_ko = mean_error(sim, kKoshizukaOka, 1.0, 3.1, 0.0, &worst_ko);
  // The limit: what the release delay alone makes of an exact solution, plus the experiment's size scatter.
  const double release_part = mean_error(mm, mm, 1.0, 6.35, kLetheDelay, nullptr);
  double scatter = 0;
  int n_scatter = 0;
  for (const auto& p : kPySphSmall) {
    const double z = interp(mm, p.T);
    if (std::isnan(z)) continue;
    scatter += std::abs(p.Z - z) / z;
    ++n_scatter;
  }
  scatter /= n_scatter;
  const double limit = release_part + scatter;

  std::printf("     T      Z exp   Z sim\n");
  for (const auto& p : mm)
    if (p.T >= 1.0 && p.T <= 6.35)
      std::printf("  %5.2f   %6.3f   %6.3f  (%+.1f %%)\n", p.T, p.Z, interp(sim, p.T),
                  100 * (interp(sim, p.T) - p.Z) / p.Z);
  std::printf(
      "  dam break: a = %.3f m, dp = %.4f m; front speed max over 0.1 s %.3f m/s = %.3f of Ritter %.3f m/s; mean "
      "speed T in [2,6] %.3f of Ritter (experiment %.3f, ratio %.3f); no time shift: mean error against Martin & "
      "Moyce %.1f %% (worst %.1f %%; aim 6 %%; the former limit, not asserted: %.1f %% = release %.1f %% + "
      "scatter %.1f %%), against Koshizuka & Oka %.1f %% (worst %.1f %%); Z(T=6) = %.2f (experiment %.2f); max "
      "Mach %.3f; %ld steps, %.1f s wall\n",
      a, dp, vmax, vmax / ritter, ritter, sim_speed, exp_speed, sim_speed / exp_speed, 100 * err_mm,
      100 * worst_mm, 100 * limit, 100 * release_part, 100 * scatter, 100 * err_ko, 100 * worst_ko,
      interp(sim, 6.0), interp(kPySph, 6.0), m["max_mach"].get<double>(), sum.steps, sum.wall_seconds);

  if (aim) {
    EXPECT_LE(err_mm, 0.06) << "mean front error against Martin & Moyce";
    return;
  }
  EXPECT_LE(vmax, ritter);
  EXPECT_NEAR(sim_speed / exp_speed, 1.0, 0.10);
  EXPECT_LT(m["max_mach"].get<double>(), 0.1);
  EXPECT_EQ(m["leaks"].get<int>(), 0);
  EXPECT_LT(std::abs(m["mass"]["relative_error"].get<double>()), 1e-12);
  // The comparison needs the front to have passed T = 6.3 before the run ends.
  EXPECT_GT(sim.back().T, 6.35);
}

}  // namespace

TEST(DamBreakValidation, SurgeFrontAgainstRitterAndMartinMoyce) { surge_front(false); }

// Known failure (tests/CMakeLists.txt, WILL_FAIL): item 3's aim, the front within 6 % of Martin & Moyce on
// average with no time shift; converged runs lead by 8-11 % (docs/validation.md section 2).
TEST(DamBreakValidation, DISABLED_FrontWithinSixPercentOfMartinMoyce) { surge_front(true); }
