// Speed against accuracy (tradeoff.hpp, docs/tradeoff.md).
#include "runout/scenarios/tradeoff.hpp"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <memory>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <omp.h>

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/study.hpp"

namespace runout {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string fmt(double v, const char* f = "%.4g") {
  char b[48];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// Peak resident memory of this process since the last reset (Linux: writing 5 to clear_refs resets VmHWM).
// Levels run one at a time, so the peak after a reset is the level's own.
bool reset_peak_memory() {
  std::ofstream f("/proc/self/clear_refs");
  if (!f) return false;
  f << "5";
  return static_cast<bool>(f.flush());
}
double peak_memory_mb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  return 0;
}

// "numerics.kernel=cubic" applied to a scene: the path's objects are created as needed.
void apply_option(json& scene, const std::string& option) {
  const auto eq = option.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == option.size())
    throw SceneError("options", "'" + option + "' is not PATH=VALUE (for example numerics.kernel=cubic)");
  const std::string path = option.substr(0, eq), text = option.substr(eq + 1);
  json value = json::parse(text, nullptr, false);
  if (value.is_discarded()) value = text;
  json* node = &scene;
  std::stringstream s(path);
  std::string key;
  std::vector<std::string> keys;
  while (std::getline(s, key, '.')) keys.push_back(key);
  for (size_t k = 0; k < keys.size(); ++k) {
    if (keys[k].empty()) throw SceneError("options", "'" + option + "' has an empty name in its path");
    if (node->is_null()) *node = json::object();  // created on the way
    if (!node->is_object()) throw SceneError("options", "'" + option + "': " + keys[k - 1] + " is not an object");
    if (k + 1 == keys.size())
      (*node)[keys[k]] = value;
    else
      node = &(*node)[keys[k]];
  }
}

struct Planned {
  TradeoffLevel level;
  std::string resolved;
  Fidelity fidelity;
  std::shared_ptr<Scene> scene;  // built just before its run, freed after it (the peak memory is the level's)
  double build_seconds = 0;
};

// Builds a level's scene (refused with the field named if it cannot run), timed: a terrain scene's build
// (DEM warp, corridor, particles) is part of what a level costs.
void build(Planned& p, const fs::path& base_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  p.scene = std::make_shared<Scene>(parse_scene(p.resolved, base_dir));
  p.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A level priced without its particles (--predict-only): its terrain built, its particles counted, timed.
CostFeatures price(Planned& p, const fs::path& base_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  const SceneEstimate e = estimate_scene(read_scene(parse_scene_document(p.resolved), base_dir));
  p.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return e.cost;
}

}  // namespace

bool is_result_metric(const std::string& n) {
  auto starts = [&](const char* p) { return n.rfind(p, 0) == 0; };
  auto ends = [&](const char* p) {
    const std::string s(p);
    return n.size() >= s.size() && n.compare(n.size() - s.size(), s.size(), s) == 0;
  };
  // A monitor's filter settings (its window, least wetted area) are inputs, not results.
  if (starts("monitors.")) return !ends("_window_s") && !ends(".min_wetted_area_m2");
  if (starts("terrain.inundation.")) return !ends(".cell_size_m") && !ends(".threshold_m");
  if (starts("terrain.protected_zones.")) return true;
  if (starts("terrain.structures.")) return ends(".retained_volume_m3");
  return n == "front_x_m";
}

std::optional<double> observed_order(double dp1, double f1, double dp2, double f2, double dp3, double f3) {
  if (!(dp1 > dp2 && dp2 > dp3 && dp3 > 0)) return std::nullopt;
  const double d12 = f1 - f2, d23 = f2 - f3;
  if (d23 == 0 || d12 == 0 || (d12 > 0) != (d23 > 0)) return std::nullopt;  // oscillatory or flat
  const double R = d12 / d23;
  auto g = [&](double p) {
    return (std::pow(dp1, p) - std::pow(dp2, p)) / (std::pow(dp2, p) - std::pow(dp3, p)) - R;
  };
  double lo = 0.05, hi = 8.0;
  if (g(lo) > 0 || g(hi) < 0) return std::nullopt;
  for (int it = 0; it < 200; ++it) {  // g increases with p
    const double mid = 0.5 * (lo + hi);
    (g(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {

// A level's value of a metric; nullopt when it lacks it or when it says "never": an arrival time of -1 (the
// flow did not reach the section or zone at that resolution) is not a time to compare.
std::optional<double> metric_value(const TradeoffLevel& l, const std::string& name) {
  const auto it = l.metrics.find(name);
  if (it == l.metrics.end()) return std::nullopt;
  if (means_never(name, it->second)) return std::nullopt;
  return it->second;
}

}  // namespace

void analyse_tradeoff(TradeoffResult& r) {
  r.metrics.clear();
  std::vector<size_t> ladder;
  for (size_t k = 0; k < r.levels.size(); ++k)
    if (r.levels[k].option.empty() && r.levels[k].status == "completed") ladder.push_back(k);
  if (ladder.empty()) return;
  const TradeoffLevel& finest = r.levels[ladder.back()];
  for (const auto& entry : finest.metrics) {
    const std::string& name = entry.first;
    if (!is_result_metric(name)) continue;
    const std::optional<double> ref = metric_value(finest, name);
    if (!ref) continue;  // the finest level says "never": nothing to converge to
    TradeoffMetric m;
    m.name = name;
    m.finest = *ref;
    for (const auto& l : r.levels) {
      const auto v = metric_value(l, name);
      if (!v || *ref == 0 || l.status != "completed")
        m.deviation_percent.emplace_back();
      else
        m.deviation_percent.emplace_back(100.0 * (*v - *ref) / std::abs(*ref));
    }
    if (ladder.size() >= 3) {
      const auto& a = r.levels[ladder[ladder.size() - 3]];
      const auto& b = r.levels[ladder[ladder.size() - 2]];
      const auto va = metric_value(a, name), vb = metric_value(b, name);
      if (va && vb) m.order = observed_order(a.dp, *va, b.dp, *vb, finest.dp, *ref);
    }
    // The coarsest rung from which every finer rung is within the tolerance of the finest.
    for (const double tol : {5.0, 10.0}) {
      double dp = finest.dp;
      for (size_t i = ladder.size() - 1; i-- > 0;) {
        const auto& l = r.levels[ladder[i]];
        const auto v = metric_value(l, name);
        if (!v || std::abs(*v - *ref) > tol / 100.0 * std::abs(*ref)) break;
        dp = l.dp;
      }
      (tol == 5.0 ? m.dp_within_5 : m.dp_within_10) = dp;
    }
    r.metrics.push_back(std::move(m));
  }
}

TradeoffResult run_tradeoff(RunStore& store, const TradeoffSpec& spec, const TradeoffRunOptions& opt) {
  // Resolve everything first: a bad level or option is refused before any run.
  if (spec.levels.size() < 2) throw SceneError("levels", "need at least 2 levels (accepted: draft, standard, fine or dp values)");
  std::vector<Planned> plan;
  std::vector<double> plan_dp;  // in spec.levels' order
  for (const auto& token : spec.levels) {
    Planned p;
    if (token == "screening")  // another model at the scene's dp, not a dp level (docs/tradeoff.md, "Screening")
      throw SceneError("levels", "'screening' is another model, not a dp level: sweep it with --fidelity screening "
                                 "and compare its runs (runout compare) against a dp level's");
    if (std::find(fidelity_names().begin(), fidelity_names().end(), token) != fidelity_names().end()) {
      p.fidelity.name = token;
    } else {
      size_t used = 0;
      double dp = 0;
      try {
        dp = std::stod(token, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != token.size() || !(dp >= 1e-4 && dp <= 100))
        throw SceneError("levels", "'" + token + "' is neither draft, standard, fine nor a dp in [0.0001, 100] m");
      p.fidelity.name = "custom";
      p.fidelity.dp = dp;
    }
    p.resolved = resolve_variant(spec.base_json, spec.variant, p.fidelity);
    p.level.dp = json::parse(p.resolved).value("dp", 0.0);
    p.level.label = "dp=" + fmt(p.level.dp);
    (void)estimate_scene(read_scene(parse_scene_document(p.resolved), spec.base_dir));  // refused here if it cannot run
    plan_dp.push_back(p.level.dp);
    plan.push_back(std::move(p));
  }
  std::stable_sort(plan.begin(), plan.end(), [](const Planned& a, const Planned& b) { return a.level.dp > b.level.dp; });
  for (size_t k = 1; k < plan.size(); ++k)
    if (plan[k].level.dp == plan[k - 1].level.dp)
      throw SceneError("levels", "two levels have the same dp (" + fmt(plan[k].level.dp) + " m)");
  if (!spec.options.empty()) {
    const Planned* at = &plan.front();  // the coarsest rung by default
    if (!spec.option_level.empty()) {
      const auto k = std::find(spec.levels.begin(), spec.levels.end(), spec.option_level);
      if (k == spec.levels.end()) throw SceneError("option_level", "'" + spec.option_level + "' is not one of the levels");
      const double dp = plan_dp[k - spec.levels.begin()];
      for (const auto& p : plan)
        if (p.level.dp == dp) at = &p;
    }
    const Planned base = *at;
    for (const auto& o : spec.options) {
      Planned p = base;
      json j = json::parse(p.resolved);
      apply_option(j, o);
      p.resolved = j.dump();
      p.level.option = o;
      p.level.label = base.level.label + " " + o;
      try {
        (void)estimate_scene(read_scene(j, spec.base_dir));
      } catch (const SceneError& e) {
        throw SceneError("options", "'" + o + "' makes the scene invalid: " + e.what());
      }
      plan.push_back(std::move(p));
    }
  }

  const CostModel model = CostModel::calibrated();
  const int threads = opt.threads > 0 ? opt.threads : 0;
  TradeoffResult result;
  for (auto& p : plan) {
    TradeoffLevel& L = p.level;
    L.status = "not run";
    if (opt.stop && opt.stop->load()) {
      result.levels.push_back(L);
      continue;
    }
    const bool reset = reset_peak_memory();
    if (!opt.predict_only) build(p, spec.base_dir);
    const CostFeatures features = opt.predict_only ? price(p, spec.base_dir) : cost_features(*p.scene);
    const CostPrediction pred = model.predict(features, threads > 0 ? threads : omp_get_max_threads());
    L.predicted_steps = pred.steps;
    L.predicted_seconds = pred.seconds;
    L.predicted_fluid_peak = pred.fluid_peak;
    L.predicted_boundary_peak = pred.boundary_peak;
    if (opt.predict_only) {
      L.fluid = features.fluid;
      L.boundary = pred.particles - L.fluid;
      L.build_seconds = p.build_seconds;
      if (opt.on_line)
        opt.on_line(L.label + ": " + fmt(pred.particles, "%.0f") + " particles described, predicted at most " +
                    fmt(pred.fluid_peak, "%.0f") + " flow and " + fmt(pred.boundary_peak, "%.0f") + " wall alive, " +
                    fmt(pred.steps, "%.0f") + " steps, " + fmt(pred.seconds, "%.0f") + " s");
      result.levels.push_back(std::move(L));
      continue;
    }
    const Scene& scene = *p.scene;
    const Manifest manifest = make_manifest(p.resolved, spec.base_dir, p.fidelity);
    std::optional<int64_t> id;
    if (const auto found = store.find_run(manifest.hash)) {
      const auto row = store.get_run(*found);
      if (row && row->status == "completed") {
        id = found;
        L.reused = true;
      }
    }
    if (!id) {
      if (opt.on_line)
        opt.on_line(L.label + ": running (" + fmt(pred.particles, "%.0f") + " particles, predicted " +
                    fmt(pred.seconds, "%.0f") + " s)");
      RunOptions ro;
      ro.out_dir = opt.out_dir / L.label;
      ro.threads = threads;
      ro.stop = opt.stop;
      ro.checkpoint_interval = opt.checkpoint_interval;
      if (!(ro.checkpoint_interval > 0 && has_checkpoint_of(scene, ro.out_dir))) fs::remove_all(ro.out_dir);
      const RunSummary s = run_scene(scene, ro);
      json m = json::parse(s.metrics_json, nullptr, false);
      // Only a reset peak is the run's own (the process may have held more before).
      if (reset && m.is_object()) m["peak_memory_mb"] = peak_memory_mb();
      if (m.is_object()) m["scene_build_s"] = p.build_seconds;
      RunStore::RunRecord rec;
      rec.manifest_hash = manifest.hash;
      rec.manifest_json = manifest.json;
      rec.sweep = "tradeoff:" + spec.name;
      rec.variant = L.label;
      rec.scene = scene.name;
      rec.fidelity = p.fidelity.dp ? "custom" : p.fidelity.name;
      rec.status = s.status;
      rec.metrics_json = m.is_object() ? m.dump(2) : s.metrics_json;
      rec.series_csv = read_series(ro.out_dir);
      id = store.put_run(rec);
    }
    L.run_id = *id;
    L.status = store.get_run(*id)->status;
    L.metrics = store.metrics(*id);
    auto get = [&](const char* k) { const auto it = L.metrics.find(k); return it == L.metrics.end() ? 0.0 : it->second; };
    L.fluid = get("particles.fluid_initial");
    L.boundary = get("particles.boundary");
    L.boundary_peak = get("particles.boundary_peak");
    L.steps = get("steps");
    L.wall_seconds = get("wall_time_s");
    L.particle_steps_per_s = get("particle_steps_per_s");
    L.peak_memory_mb = get("peak_memory_mb");
    L.build_seconds = get("scene_build_s");
    p.scene.reset();
    if (opt.on_line)
      opt.on_line(L.label + ": " + L.status + (L.reused ? " (already stored)" : "") + ", " + fmt(L.steps, "%.0f") +
                  " steps, " + fmt(L.wall_seconds, "%.1f") + " s wall (predicted " + fmt(L.predicted_seconds, "%.0f") +
                  " s), run " + std::to_string(L.run_id));
    result.levels.push_back(std::move(L));
  }
  analyse_tradeoff(result);
  return result;
}

std::string format_tradeoff(const TradeoffResult& r) {
  auto table = [](const std::vector<std::vector<std::string>>& rows) {
    std::vector<size_t> w;
    for (const auto& row : rows)
      for (size_t k = 0; k < row.size(); ++k) {
        if (w.size() <= k) w.push_back(0);
        w[k] = std::max(w[k], row[k].size());
      }
    std::string out;
    for (const auto& row : rows) {
      for (size_t k = 0; k < row.size(); ++k) {
        const std::string pad(w[k] - row[k].size(), ' ');
        out += k == 0 ? row[k] + pad : "  " + pad + row[k];
      }
      out += "\n";
    }
    return out;
  };
  std::vector<std::vector<std::string>> rows{{"level", "dp [m]", "fluid", "boundary", "alive", "alive pred.", "steps",
                                              "wall [s]", "predicted [s]", "pred/meas", "fluid p-steps/s", "peak MB",
                                              "build [s]", "status"}};
  for (const auto& l : r.levels)
    rows.push_back({l.label, fmt(l.dp), fmt(l.fluid, "%.0f"), fmt(l.boundary, "%.0f"),
                    l.boundary_peak > 0 ? fmt(l.boundary_peak, "%.0f") : "-", fmt(l.predicted_boundary_peak, "%.0f"),
                    fmt(l.steps, "%.0f"),
                    fmt(l.wall_seconds, "%.1f"), fmt(l.predicted_seconds, "%.1f"),
                    l.wall_seconds > 0 ? fmt(l.predicted_seconds / l.wall_seconds, "%.2f") : "-",
                    fmt(l.particle_steps_per_s, "%.3g"), l.peak_memory_mb > 0 ? fmt(l.peak_memory_mb, "%.0f") : "-",
                    fmt(l.build_seconds, "%.1f"), l.status + (l.reused ? " (stored)" : "")});
  std::string out = table(rows) + "\n";
  std::vector<std::string> head{"metric", "finest"};
  for (const auto& l : r.levels) head.push_back(l.label);
  head.insert(head.end(), {"order", "dp 5%", "dp 10%"});
  rows = {head};
  for (const auto& m : r.metrics) {
    std::vector<std::string> row{m.name, fmt(m.finest)};
    for (const auto& d : m.deviation_percent) row.push_back(d ? fmt(*d, "%+.1f%%") : "-");
    row.push_back(m.order ? fmt(*m.order, "%.2f") : "-");
    row.push_back(m.dp_within_5 ? fmt(*m.dp_within_5) : "-");
    row.push_back(m.dp_within_10 ? fmt(*m.dp_within_10) : "-");
    rows.push_back(row);
  }
  return out + table(rows);
}

void write_tradeoff_csv(const TradeoffResult& r, const fs::path& dir) {
  fs::create_directories(dir);
  std::ofstream lv(dir / "levels.csv");
  lv << "level,dp_m,option,run_id,status,reused,fluid,boundary,steps,wall_s,predicted_steps,predicted_s,"
        "fluid_particle_steps_per_s,peak_memory_mb,scene_build_s,boundary_peak,predicted_fluid_peak,"
        "predicted_boundary_peak\n";
  for (const auto& l : r.levels)
    lv << '"' << l.label << "\"," << fmt(l.dp, "%.6g") << ",\"" << l.option << "\"," << l.run_id << ',' << l.status << ','
       << (l.reused ? 1 : 0) << ',' << fmt(l.fluid, "%.0f") << ',' << fmt(l.boundary, "%.0f") << ','
       << fmt(l.steps, "%.0f") << ',' << fmt(l.wall_seconds, "%.3f") << ',' << fmt(l.predicted_steps, "%.0f") << ','
       << fmt(l.predicted_seconds, "%.3f") << ',' << fmt(l.particle_steps_per_s, "%.6g") << ','
       << fmt(l.peak_memory_mb, "%.1f") << ',' << fmt(l.build_seconds, "%.3f") << ',' << fmt(l.boundary_peak, "%.0f")
       << ',' << fmt(l.predicted_fluid_peak, "%.0f") << ',' << fmt(l.predicted_boundary_peak, "%.0f") << '\n';
  std::ofstream mt(dir / "metrics.csv");
  mt << "metric,finest";
  for (const auto& l : r.levels) mt << ",\"deviation_percent " << l.label << '"';
  mt << ",order,dp_within_5_percent_m,dp_within_10_percent_m\n";
  for (const auto& m : r.metrics) {
    mt << m.name << ',' << fmt(m.finest, "%.8g");
    for (const auto& d : m.deviation_percent) mt << ',' << (d ? fmt(*d, "%.4g") : "");
    mt << ',' << (m.order ? fmt(*m.order, "%.3g") : "") << ',' << (m.dp_within_5 ? fmt(*m.dp_within_5, "%.6g") : "")
       << ',' << (m.dp_within_10 ? fmt(*m.dp_within_10, "%.6g") : "") << '\n';
  }
}

void write_tradeoff_svg(const TradeoffResult& r, const fs::path& file, const std::string& title) {
  // Two log-log panels: |deviation from the finest| [%] of the headline metrics against dp, and wall time
  // (measured, and the cost model's prediction) against dp.
  std::vector<const TradeoffLevel*> ladder;
  for (const auto& l : r.levels)
    if (l.option.empty() && l.status == "completed") ladder.push_back(&l);
  const char* headline[] = {"peak_discharge", "arrival_time", "peak_force", "peak_mean_pressure",
                            "inundated_area", "runout", "front_x", "retained_volume", "max_depth"};
  std::vector<const TradeoffMetric*> shown;
  for (const auto& m : r.metrics)
    for (const char* h : headline)
      if (m.name.find(h) != std::string::npos && shown.size() < 12) {
        shown.push_back(&m);
        break;
      }
  const char* colours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                           "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#637939"};
  double dpmin = 1e300, dpmax = 0;
  for (const auto* l : ladder) dpmin = std::min(dpmin, l->dp), dpmax = std::max(dpmax, l->dp);
  if (ladder.empty()) dpmin = 1, dpmax = 2;
  if (dpmax <= dpmin) dpmax = dpmin * 2;
  const double W = 1100, H = 470, pw = 380, ph = 330, top = 60, left1 = 70, left2 = 560;
  auto xpos = [&](double left, double dp) {
    return left + pw * (std::log(dp) - std::log(dpmin / 1.15)) / (std::log(dpmax * 1.15) - std::log(dpmin / 1.15));
  };
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  s << "<text x='" << W / 2 << "' y='22' text-anchor='middle' font-size='15'>" << title << "</text>\n";
  auto panel = [&](double left, double ylo, double yhi, const std::string& ylabel) {
    auto ypos = [&, ylo, yhi](double v) {
      v = std::clamp(v, ylo, yhi);
      return top + ph - ph * (std::log(v) - std::log(ylo)) / (std::log(yhi) - std::log(ylo));
    };
    s << "<rect x='" << left << "' y='" << top << "' width='" << pw << "' height='" << ph
      << "' fill='none' stroke='#333'/>\n";
    for (double d = std::pow(10, std::floor(std::log10(ylo))); d <= yhi * 1.001; d *= 10)
      if (d >= ylo * 0.999) {
        s << "<line x1='" << left << "' x2='" << left + pw << "' y1='" << ypos(d) << "' y2='" << ypos(d)
          << "' stroke='#ddd'/><text x='" << left - 5 << "' y='" << ypos(d) + 4 << "' text-anchor='end'>" << fmt(d, "%g")
          << "</text>\n";
      }
    for (const auto* l : ladder)
      s << "<line x1='" << xpos(left, l->dp) << "' x2='" << xpos(left, l->dp) << "' y1='" << top << "' y2='" << top + ph
        << "' stroke='#eee'/><text x='" << xpos(left, l->dp) << "' y='" << top + ph + 16 << "' text-anchor='middle'>"
        << fmt(l->dp, "%g") << "</text>\n";
    s << "<text x='" << left + pw / 2 << "' y='" << top + ph + 34 << "' text-anchor='middle'>dp [m]</text>\n";
    s << "<text transform='translate(" << left - 48 << "," << top + ph / 2 << ") rotate(-90)' text-anchor='middle'>"
      << ylabel << "</text>\n";
    return ypos;
  };
  // Left: deviations.
  auto yd = panel(left1, 0.1, 1000, "|deviation from finest| [%]");
  for (double tol : {5.0, 10.0})
    s << "<line x1='" << left1 << "' x2='" << left1 + pw << "' y1='" << yd(tol) << "' y2='" << yd(tol)
      << "' stroke='#999' stroke-dasharray='4 3'/><text x='" << left1 + pw - 4 << "' y='" << yd(tol) - 3
      << "' text-anchor='end' fill='#777'>" << tol << " %</text>\n";
  for (size_t k = 0; k < shown.size(); ++k) {
    std::string pts;
    for (size_t i = 0; i < r.levels.size(); ++i) {
      const auto& l = r.levels[i];
      if (!l.option.empty() || l.status != "completed" || !shown[k]->deviation_percent[i]) continue;
      if (ladder.size() && &l == ladder.back()) continue;  // the reference itself
      pts += fmt(xpos(left1, l.dp), "%.1f") + "," + fmt(yd(std::max(0.1, std::abs(*shown[k]->deviation_percent[i]))), "%.1f") + " ";
    }
    s << "<polyline points='" << pts << "' fill='none' stroke='" << colours[k] << "' stroke-width='2'/>\n";
    s << "<rect x='" << left1 + pw + 8 << "' y='" << top + 4 + 15 * k << "' width='10' height='10' fill='" << colours[k]
      << "'/><text x='" << left1 + pw + 22 << "' y='" << top + 13 + 15 * k << "' font-size='10'>" << shown[k]->name
      << "</text>\n";
  }
  // Right: wall time.
  double tlo = 1e300, thi = 0;
  for (const auto* l : ladder)
    for (double t : {l->wall_seconds, l->predicted_seconds})
      if (t > 0) tlo = std::min(tlo, t), thi = std::max(thi, t);
  if (thi <= 0) tlo = 1, thi = 10;
  tlo = std::pow(10, std::floor(std::log10(tlo))), thi = std::pow(10, std::ceil(std::log10(thi)));
  if (thi <= tlo) thi = tlo * 10;
  auto yt = panel(left2, tlo, thi, "wall time [s]");
  std::string meas, pred;
  for (const auto* l : ladder) {
    if (l->wall_seconds > 0) meas += fmt(xpos(left2, l->dp), "%.1f") + "," + fmt(yt(l->wall_seconds), "%.1f") + " ";
    if (l->predicted_seconds > 0)
      pred += fmt(xpos(left2, l->dp), "%.1f") + "," + fmt(yt(l->predicted_seconds), "%.1f") + " ";
  }
  s << "<polyline points='" << meas << "' fill='none' stroke='#000' stroke-width='2'/>\n";
  s << "<polyline points='" << pred << "' fill='none' stroke='#d62728' stroke-width='2' stroke-dasharray='6 4'/>\n";
  s << "<text x='" << left2 + pw + 8 << "' y='" << top + 14 << "'>measured</text><line x1='" << left2 + pw + 70
    << "' x2='" << left2 + pw + 100 << "' y1='" << top + 10 << "' y2='" << top + 10 << "' stroke='#000' stroke-width='2'/>\n";
  s << "<text x='" << left2 + pw + 8 << "' y='" << top + 32 << "'>predicted</text><line x1='" << left2 + pw + 70
    << "' x2='" << left2 + pw + 100 << "' y1='" << top + 28 << "' y2='" << top + 28
    << "' stroke='#d62728' stroke-width='2' stroke-dasharray='6 4'/>\n";
  s << "</svg>\n";
  std::ofstream(file) << s.str();
}

}  // namespace runout
