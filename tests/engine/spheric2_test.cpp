// Validation: SPHERIC Test 2, the MARIN 3D dam break against a box (Kleefsman et al. 2005, J. Comput. Phys.
// 206:363-393; scenarios/validation/spheric2_3d.json, docs/validation.md section 7), run through run_scene at
// the CI resolution dp = 0.55/15 and compared with the measured series (tests/data/spheric2_exp_*.csv, taken
// from the SPHERIC data file; docs/validation-data.md section 1).
//
// What is compared, and the tolerances (written down in commit e5bdacd, before the comparison was first run):
//  1. Arrival times: P1 and P2 (first sample over 1 kPa) and the wetting of the two gauges nearest the gate,
//     x = 1.488 and 0.992 m (first sample over 1 cm). The flow covers these distances at about the front
//     speed, which the project's 2D dam break holds to 10 % of Martin & Moyce's (tests/engine/dam_break_test.cpp:
//     10 %, the spread between their two column sizes): 10 % of the measured time either way. The experiment's
//     clock starts as its gate begins to rise, the simulated column is free at once, so the simulation may
//     lead by a gate-opening time as well: the converged 2D front leads Martin & Moyce's by about 0.22 in T,
//     12 ms for their 0.114 m column (docs/validation.md, section 2);
//     an opening time scales as the column's fall time sqrt(H/g), sqrt(0.55/0.114) = 2.2 times that here,
//     26 ms. So t_sim - t_exp in [-(0.1 t_exp + 0.026 s), +0.1 t_exp].
//  2. P1 and P2, the peak of the 10 ms (11-sample centred) moving average over the first impact: within 25 %.
//     An impact pressure scales as rho u^2; the 10 % band on the front speed is 21 % on u^2; how an 11-sample
//     average catches a spike of a few samples moves the measured peak by 11 % (raw 11.24 kPa against
//     10.03 kPa averaged for P1); in quadrature 24 %, rounded to 25 %.
//  3. P1 and P2, the mean over 0.495-0.995 s (the flow piled against the face, after the impact): within 25 %:
//     the same 21 % on the flow's rho u^2, and the probe's reading is a Shepard mean over rows up to 2h above the
//     sensor (the floor cuts the rest of the support), about rho g 0.03 m = 0.3 kPa (7 % of the level) low;
//     in quadrature 22 %, rounded to 25 %.
//  4. Water heights H2 (x = 0.992 m) and H4 (x = 2.638 m, the reservoir), the two gauges whose labels are
//     unambiguous, as 10 ms means at 0.5, 1.0 and 1.5 s: within dp + 10 % of the measured height. dp is the
//     project's depth-gauge tolerance (the surface is where the interpolated fluid fraction falls to 1/2; the
//     top row stands anywhere within a spacing of it: docs/validation.md section 6); 10 % the front-speed band
//     again, now on the discharge that fills and drains the gauges.
// What holds at this resolution is asserted (Spheric2Validation.HeightsAndP2ArrivalAgainstKleefsman): the six
// heights of H2 and H4 (item 4) and P2's arrival. The rest of items 1-3 — P1's arrival, the wetting of the two
// gauges nearest the gate, P1's and P2's 10 ms peaks and post-impact means — is asserted with the same declared
// bands in a known failure (DISABLED_PressuresAndArrivalsAgainstKleefsman, ctest WILL_FAIL; docs/validation.md
// sections 7 and 7.1 have the numbers): the front reaches the gauges and P1 late (the coarse 3D front is a few
// particles thick and slower than the experiment's), the face's 10 ms impact peaks are 1.9-4 times the measured
// ones (the DBC wall's own continuity pressure during the impact: on extrapolated walls they are +42 / +59 %),
// and F1, in the floor-face corner, reads half the pressure after the impact; F2's post-impact mean is within its
// band (+7 %). Refined to SPHERIC's 0.55/30 (18 minutes, not run here) the means and F1's arrival come inside their
// bands and the peaks fall to +68 / +45 %. The tolerances were not moved. (Issue 42 sets the aim for P1's peak
// and post-impact pressure at 20 %; the bands here, declared first, are 25 %.) The known failure runs the scene again in its own process (about 200 s on CI's two threads).
// P3 and P4 and the gauges at x = 0.496 and 1.488 m are printed only: at dp = 0.55/15 the box is laid 4 spacings
// (0.147 m) high against 0.161 m, P4 (z = 0.141 m) is 6 mm under its top, and the probes' kernel support
// (2h = 0.11 m) reaches over the top into the overtopping jet from P3 up; the other two gauges' labels are the
// ambiguous ones (docs/validation-data.md 1.2). At this resolution P1 at z = 0.021 m lies within the first
// particle row (centres at dp/2 = 0.018 m): its support is cut by the floor and the face, and it reads dry
// (kernel sum under 0.25) in about a third of the samples after the impact.
// Since 2026-12-06 (issue 42 item 2; docs/validation.md section 7.1, declared there before it was built or run) the
// pressures of items 1-3 are read by face sensors F1-F4 (face_pressure: the flow's push on the box's particles
// around the sensor's point on the face, as a transducer reads the force on its membrane), not by the fluid
// probes P1-P4 at face + h, which are printed beside them: next to the DBC face a fluid probe's support is
// centred on the row of flow the wall holds off, which is in tension in a quarter of the samples after the
// impact while the wall is pushed. The bands did not move (the 7 % Shepard allowance of item 3 was the fluid
// probe's; the 25 % stays). F1 at z = 0.021 m is centred on the box's bottom row (z = dp/2; the lattices are
// cell-centred) and its weights reach up only (the floor is another structure).
// The experiment's pressures carry a sensor zero offset (their mean before the flow arrives, t < 0.35 s,
// about -27 Pa): it is subtracted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;

namespace {

// A CSV file's columns by name; lines starting with '#' are comments.
using Table = std::map<std::string, std::vector<double>>;

Table read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot open " << path;
  std::string line;
  std::vector<std::string> names;
  Table out;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string cell;
    if (names.empty()) {
      while (std::getline(ss, cell, ',')) names.push_back(cell);
      continue;
    }
    for (size_t c = 0; std::getline(ss, cell, ',') && c < names.size(); ++c) out[names[c]].push_back(std::stod(cell));
  }
  return out;
}

struct Series {
  std::vector<double> t, v;
};

Series column(const Table& tab, const std::string& name, double offset = 0) {
  Series s;
  s.t = tab.at("t");
  for (double x : tab.at(name)) s.v.push_back(x - offset);
  return s;
}

// Mean over lo <= t < hi.
double window_mean(const Series& s, double lo, double hi) {
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < s.t.size(); ++i)
    if (s.t[i] >= lo && s.t[i] < hi) sum += s.v[i], ++n;
  EXPECT_GT(n, 0) << "no samples in [" << lo << ", " << hi << ")";
  return n ? sum / n : std::nan("");
}

// First time the series exceeds a threshold; -1 if never.
double first_over(const Series& s, double threshold) {
  for (size_t i = 0; i < s.t.size(); ++i)
    if (s.v[i] > threshold) return s.t[i];
  return -1;
}

// Peak of the 11-sample centred moving average (10 ms at the 1 kHz of both series) for t in [lo, hi]; its time.
std::pair<double, double> peak_10ms(const Series& s, double lo, double hi) {
  double best = -1e300, when = -1;
  for (size_t i = 5; i + 5 < s.t.size(); ++i) {
    if (s.t[i] < lo || s.t[i] > hi) continue;
    double sum = 0;
    for (size_t j = i - 5; j <= i + 5; ++j) sum += s.v[j];
    if (sum / 11 > best) best = sum / 11, when = s.t[i];
  }
  return {best, when};
}

// An arrival time's band (header, item 1): the simulation may lead by 10 % + 26 ms and lag by 10 %.
struct Band {
  double lo, hi;
};
Band arrival_band(double exp) { return {exp - (0.1 * exp + 0.026), exp + 0.1 * exp}; }

// Everything the header compares, from one run.
struct Figures {
  RunSummary run;
  nlohmann::json metrics;
  double dp = 0;
  struct Probe {
    double arrival_sim, arrival_exp, peak_sim, peak_exp, mean_sim, mean_exp;
  } probe[4];
  double wets_1488_sim, wets_1488_exp, wets_0992_sim, wets_0992_exp;
  struct Height {
    const char* gauge;
    double t, sim, exp;
  };
  std::vector<Height> heights;  // H1-H4 at 0.5, 1.0, 1.5 s
};

Figures run_and_compare(const std::string& folder) {
  Figures f;
  const Scene scene = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/spheric2_3d.json");
  f.dp = scene.dp;
  const std::filesystem::path out = std::filesystem::path(RUNOUT_BINARY_DIR) / "validation" / folder;
  RunOptions opt;
  opt.out_dir = out;
  f.run = run_scene(scene, opt);
  if (f.run.status != "completed") return f;
  f.metrics = nlohmann::json::parse(f.run.metrics_json);
  const Table e10 = read_csv(RUNOUT_SOURCE_DIR "/tests/data/spheric2_exp_10ms.csv");
  const Table e1k = read_csv(RUNOUT_SOURCE_DIR "/tests/data/spheric2_exp_impact_1khz.csv");
  const auto sim = [&](const std::string& file, const std::string& col) {
    return column(read_csv(out / "series" / file), col);
  };
  const char* exp_cols[] = {"p1_pa", "p2_pa", "p3_pa", "p4_pa"};
  std::printf("  SPHERIC Test 2 at dp = %.4f m: %ld steps, %.1f s wall, max Mach %.3f\n", f.dp, f.run.steps,
              f.run.wall_seconds, f.metrics["max_mach"].get<double>());
  for (int k = 0; k < 4; ++k) {
    const double zero = window_mean(column(e10, exp_cols[k]), -1, 0.35);
    const Series pe = column(e1k, exp_cols[k], zero), pe10 = column(e10, exp_cols[k], zero);
    const auto [pk_e, tpk_e] = peak_10ms(pe, 0.0, 0.55);
    const double arrival_e = first_over(pe, 1000), mean_e = window_mean(pe10, 0.495, 0.995);
    // The face sensor (compared) and the fluid probe at face + h (printed).
    for (const char* kind : {"F", "P"}) {
      const bool face = kind[0] == 'F';
      const std::string name = kind + std::to_string(k + 1);
      const Series ps = sim((face ? "face_pressure_" : "pressure_probe_") + name + ".csv", "pressure_pa");
      const auto [pk_s, tpk_s] = peak_10ms(ps, 0.0, 0.55);
      const double arrival_s = first_over(ps, 1000), mean_s = window_mean(ps, 0.495, 0.995);
      if (face) f.probe[k] = {arrival_s, arrival_e, pk_s, pk_e, mean_s, mean_e};
      std::printf("  %s (%s): first > 1 kPa sim %.3f / exp %.3f s; 10 ms peak sim %.0f Pa at %.3f s / exp %.0f Pa at "
                  "%.3f s (%+.0f %%); mean 0.495-0.995 s sim %.0f / exp %.0f Pa (%+.0f %%); mean 0.995-1.495 s sim "
                  "%.0f / exp %.0f Pa\n",
                  name.c_str(), face ? "face sensor" : "fluid probe at face + h", arrival_s, arrival_e, pk_s, tpk_s,
                  pk_e, tpk_e, 100 * (pk_s / pk_e - 1), mean_s, mean_e, 100 * (mean_s / mean_e - 1),
                  window_mean(ps, 0.995, 1.495), window_mean(pe10, 0.995, 1.495));
    }
  }
  f.wets_1488_sim = first_over(sim("depth_gauge_H3.csv", "depth_m"), 0.01);
  f.wets_1488_exp = first_over(column(e1k, "h_x1488_m"), 0.01);
  f.wets_0992_sim = first_over(sim("depth_gauge_H2.csv", "depth_m"), 0.01);
  f.wets_0992_exp = first_over(column(e1k, "h_x0992_m"), 0.01);
  std::printf("  wetting (> 1 cm): x = 1.488 m sim %.3f / exp %.3f s; x = 0.992 m sim %.3f / exp %.3f s\n",
              f.wets_1488_sim, f.wets_1488_exp, f.wets_0992_sim, f.wets_0992_exp);
  const struct {
    const char* gauge;
    const char* exp_col;
  } gauges[] = {{"H1", "h_x0496_m"}, {"H2", "h_x0992_m"}, {"H3", "h_x1488_m"}, {"H4", "h_x2638_m"}};
  for (const auto& g : gauges) {
    const Series hs = sim(std::string("depth_gauge_") + g.gauge + ".csv", "depth_m"), he = column(e10, g.exp_col);
    for (double t : {0.5, 1.0, 1.5}) {
      const double hsim = window_mean(hs, t - 0.005, t + 0.005), hexp = window_mean(he, t - 0.005, t + 0.005);
      f.heights.push_back({g.gauge, t, hsim, hexp});
      std::printf("  %s (%s) at %.1f s: sim %.3f m, experiment %.3f m: %+.3f m (band %.3f m)\n", g.gauge, g.exp_col,
                  t, hsim, hexp, hsim - hexp, f.dp + 0.1 * hexp);
    }
  }
  for (const auto& mon : f.metrics["monitors"])
    if (mon["name"] == "box")
      std::printf("  box load: peak force %.0f N at %.3f s (window %.3f s), peak mean pressure %.0f Pa\n",
                  mon["peak_force_n"].get<double>(), mon["time_of_peak_force_s"].get<double>(),
                  mon["load_window_s"].get<double>(), mon["peak_mean_pressure_pa"].get<double>());
  return f;
}

void expect_arrival(const std::string& what, double sim, double exp) {
  const Band b = arrival_band(exp);
  EXPECT_GE(sim, b.lo) << what;
  EXPECT_LE(sim, b.hi) << what;
}

}  // namespace

// What holds at this resolution: H2 and H4 (the gauges with unambiguous labels), P2's arrival (face sensor F2),
// no leak, mass.
TEST(Spheric2Validation, HeightsAndP2ArrivalAgainstKleefsman) {
  const Figures f = run_and_compare("spheric2_3d");
  ASSERT_EQ(f.run.status, "completed") << f.run.error;  // a leak or NaN fails here
  expect_arrival("F2 arrival (> 1 kPa)", f.probe[1].arrival_sim, f.probe[1].arrival_exp);
  for (const auto& h : f.heights)
    if (std::string(h.gauge) == "H2" || std::string(h.gauge) == "H4") {
      EXPECT_NEAR(h.sim, h.exp, f.dp + 0.1 * h.exp) << h.gauge << " at " << h.t << " s";
    }
  bool box = false;
  for (const auto& mon : f.metrics["monitors"]) box = box || mon["name"] == "box";
  EXPECT_TRUE(box) << "no structure_load 'box' in metrics.json";
  EXPECT_EQ(f.metrics["leaks"].get<int>(), 0);
  EXPECT_LT(std::abs(f.metrics["mass"]["relative_error"].get<double>()), 1e-12);
}

// Known failure (tests/CMakeLists.txt, WILL_FAIL): the header's items 1-3 for P1, P2 and the two gauges nearest
// the gate, with the bands declared before the first comparison.
TEST(Spheric2Validation, DISABLED_PressuresAndArrivalsAgainstKleefsman) {
  const Figures f = run_and_compare("spheric2_3d_known_failure");
  ASSERT_EQ(f.run.status, "completed") << f.run.error;
  expect_arrival("F1 arrival (> 1 kPa)", f.probe[0].arrival_sim, f.probe[0].arrival_exp);
  expect_arrival("x = 1.488 m wets (> 1 cm)", f.wets_1488_sim, f.wets_1488_exp);
  expect_arrival("x = 0.992 m wets (> 1 cm)", f.wets_0992_sim, f.wets_0992_exp);
  for (int k = 0; k < 2; ++k) {
    const auto& p = f.probe[k];
    EXPECT_NEAR(p.peak_sim, p.peak_exp, 0.25 * std::abs(p.peak_exp)) << "F" << k + 1 << " 10 ms peak";
    EXPECT_NEAR(p.mean_sim, p.mean_exp, 0.25 * std::abs(p.mean_exp)) << "F" << k + 1 << " mean 0.495-0.995 s";
  }
}
