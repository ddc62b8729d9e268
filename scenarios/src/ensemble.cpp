// Ensembles of a sweep (docs/scene-format.md, "Ensembles"): which numbers of the base scene vary, their values
// (a grid of lists and ranges, a Latin hypercube over distributions) and the members that result.
#include <boost/math/distributions/lognormal.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/triangular.hpp>

#include <cmath>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout {
namespace {

using json = nlohmann::json;

constexpr size_t kMaxMembers = 4096;  // a screening study of 8 layouts x 4096 members is days on two cores

double number(const json& o, const std::string& key, const std::string& path) {
  if (!o.contains(key) || !o[key].is_number()) throw SceneError(path + "." + key, "missing (required: a number)");
  const double v = o[key].get<double>();
  if (!std::isfinite(v)) throw SceneError(path + "." + key, "must be finite");
  return v;
}

void check_keys(const json& o, const std::string& path, const std::vector<std::string>& accepted) {
  std::string list;
  for (const auto& a : accepted) list += (list.empty() ? "" : ", ") + a;
  for (auto it = o.begin(); it != o.end(); ++it)
    if (std::find(accepted.begin(), accepted.end(), it.key()) == accepted.end())
      throw SceneError(path + "." + it.key(), "unknown field (accepted: " + list + ")");
}

void read_distribution(const json& o, const std::string& path, EnsembleParameter& p) {
  if (!o["distribution"].is_string())
    throw SceneError(path + ".distribution", "must be one of uniform, normal, lognormal, triangular");
  p.distribution = o["distribution"].get<std::string>();
  if (p.distribution == "uniform") {
    check_keys(o, path, {"pointer", "distribution", "min", "max"});
    p.a = number(o, "min", path), p.b = number(o, "max", path);
    if (!(p.a < p.b)) throw SceneError(path + ".max", "must be greater than min");
  } else if (p.distribution == "normal") {
    check_keys(o, path, {"pointer", "distribution", "mean", "sd"});
    p.a = number(o, "mean", path), p.b = number(o, "sd", path);
    if (!(p.b > 0)) throw SceneError(path + ".sd", "must be > 0");
  } else if (p.distribution == "lognormal") {
    check_keys(o, path, {"pointer", "distribution", "median", "sd_log"});
    p.a = number(o, "median", path), p.b = number(o, "sd_log", path);
    if (!(p.a > 0)) throw SceneError(path + ".median", "must be > 0");
    if (!(p.b > 0)) throw SceneError(path + ".sd_log", "must be > 0");
  } else if (p.distribution == "triangular") {
    check_keys(o, path, {"pointer", "distribution", "min", "mode", "max"});
    p.a = number(o, "min", path), p.b = number(o, "mode", path), p.c = number(o, "max", path);
    if (!(p.a < p.c) || p.b < p.a || p.b > p.c) throw SceneError(path + ".mode", "must satisfy min <= mode <= max, min < max");
  } else {
    throw SceneError(path + ".distribution",
                     "unknown value '" + p.distribution + "' (accepted: uniform, normal, lognormal, triangular)");
  }
}

void read_grid_axis(const json& o, const std::string& path, EnsembleParameter& p) {
  if (o.contains("values")) {
    check_keys(o, path, {"pointer", "values"});
    if (!o["values"].is_array() || o["values"].empty() || o["values"].size() > kMaxMembers)
      throw SceneError(path + ".values", "must be an array of 1 to " + std::to_string(kMaxMembers) + " numbers");
    for (size_t k = 0; k < o["values"].size(); ++k) {
      if (!o["values"][k].is_number()) throw SceneError(path + ".values[" + std::to_string(k) + "]", "must be a number");
      p.values.push_back(o["values"][k].get<double>());
    }
    return;
  }
  check_keys(o, path, {"pointer", "range"});
  const json& r = o["range"];
  if (!r.is_object()) throw SceneError(path + ".range", "must be an object {min, max, count}");
  check_keys(r, path + ".range", {"min", "max", "count"});
  const double lo = number(r, "min", path + ".range"), hi = number(r, "max", path + ".range");
  if (!r.contains("count") || !r["count"].is_number_integer() || r["count"].get<long>() < 2 ||
      r["count"].get<long>() > static_cast<long>(kMaxMembers))
    throw SceneError(path + ".range.count", "must be an integer in [2, " + std::to_string(kMaxMembers) + "]");
  if (!(lo < hi)) throw SceneError(path + ".range.max", "must be greater than min");
  const long n = r["count"].get<long>();
  for (long k = 0; k < n; ++k) p.values.push_back(k == n - 1 ? hi : lo + (hi - lo) * static_cast<double>(k) / (n - 1));
}

EnsembleParameter read_parameter(const json& o, const std::string& path, const json& base) {
  if (!o.is_object()) throw SceneError(path, "must be an object {pointer, values | range | distribution ...}");
  EnsembleParameter p;
  if (!o.contains("pointer") || !o["pointer"].is_string())
    throw SceneError(path + ".pointer", "missing (required: a JSON pointer to a number of the base scene, e.g. /materials/0/friction_angle)");
  p.pointer = o["pointer"].get<std::string>();
  try {
    const json::json_pointer ptr(p.pointer);
    if (!base.contains(ptr) || !base.at(ptr).is_number())
      throw SceneError(path + ".pointer", "'" + p.pointer + "' names no number of the base scene");
  } catch (const json::exception& e) {
    throw SceneError(path + ".pointer", "'" + p.pointer + "' is not a JSON pointer (" + e.what() + ")");
  }
  const int forms = int(o.contains("values")) + int(o.contains("range")) + int(o.contains("distribution"));
  if (forms != 1) throw SceneError(path, "give exactly one of values, range or distribution");
  if (o.contains("distribution"))
    read_distribution(o, path, p);
  else
    read_grid_axis(o, path, p);
  return p;
}

}  // namespace

double parameter_quantile(const EnsembleParameter& p, double u) {
  namespace bm = boost::math;
  if (p.distribution == "uniform") return p.a + u * (p.b - p.a);
  if (p.distribution == "normal") return bm::quantile(bm::normal(p.a, p.b), u);
  if (p.distribution == "lognormal") return bm::quantile(bm::lognormal(std::log(p.a), p.b), u);
  return bm::quantile(bm::triangular(p.a, p.b, p.c), u);
}

std::vector<std::vector<double>> latin_hypercube(size_t n, size_t d, uint64_t seed) {
  std::mt19937_64 rng(seed);
  // In (0, 1), 53 bits: std::uniform_real_distribution and std::shuffle are not the same on every library.
  auto unit = [&] { return (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53; };
  std::vector<std::vector<double>> u(n, std::vector<double>(d));
  std::vector<size_t> stratum(n);
  for (size_t j = 0; j < d; ++j) {
    for (size_t i = 0; i < n; ++i) stratum[i] = i;
    for (size_t i = n; i > 1; --i) std::swap(stratum[i - 1], stratum[rng() % i]);  // Fisher-Yates
    for (size_t i = 0; i < n; ++i) u[i][j] = (static_cast<double>(stratum[i]) + unit()) / static_cast<double>(n);
  }
  return u;
}

Ensemble parse_ensemble(const std::string& ensemble_json, const std::string& base_json) {
  const json e = json::parse(ensemble_json);
  const json base = json::parse(base_json);
  if (!e.is_object()) throw SceneError("ensemble", "must be an object {parameters, members, seed}");
  check_keys(e, "ensemble", {"parameters", "members", "seed", "pressure_thresholds_pa"});
  Ensemble out;
  if (!e.contains("parameters") || !e["parameters"].is_array() || e["parameters"].empty() || e["parameters"].size() > 16)
    throw SceneError("ensemble.parameters", "must be an array of 1 to 16 parameters");
  size_t grid = 1, sampled = 0;
  for (size_t k = 0; k < e["parameters"].size(); ++k) {
    out.parameters.push_back(read_parameter(e["parameters"][k], "ensemble.parameters[" + std::to_string(k) + "]", base));
    const auto& p = out.parameters.back();
    if (p.distribution.empty()) grid *= p.values.size(); else ++sampled;
    if (grid > kMaxMembers) throw SceneError("ensemble.parameters", "the grid has over " + std::to_string(kMaxMembers) + " points");
  }
  if (e.contains("seed")) {
    if (!e["seed"].is_number_unsigned()) throw SceneError("ensemble.seed", "must be an integer >= 0");
    out.seed = e["seed"].get<uint64_t>();
  }
  if (e.contains("pressure_thresholds_pa")) {
    const json& t = e["pressure_thresholds_pa"];
    bool ok = t.is_array() && !t.empty() && t.size() <= 8;
    for (size_t k = 0; ok && k < t.size(); ++k)
      ok = t[k].is_number() && t[k].get<double>() > 0.0 && t[k].get<double>() <= 1e8 &&
           (k == 0 || t[k].get<double>() > t[k - 1].get<double>());
    if (!ok) throw SceneError("ensemble.pressure_thresholds_pa", "must be 1 to 8 ascending pressures in (0, 1e8] Pa");
    out.pressure_thresholds_pa = t.get<std::vector<double>>();
  }
  if (sampled > 0) {
    if (!e.contains("members") || !e["members"].is_number_integer() || e["members"].get<long>() < 1 ||
        static_cast<size_t>(e["members"].get<long>()) * grid > kMaxMembers)
      throw SceneError("ensemble.members", "must be an integer in [1, " + std::to_string(kMaxMembers / grid) +
                                               "] (the Latin-hypercube points; members x grid points <= " +
                                               std::to_string(kMaxMembers) + ")");
    out.samples = static_cast<size_t>(e["members"].get<long>());
  } else if (e.contains("members")) {
    throw SceneError("ensemble.members", "only with a distribution (a grid's members are its points)");
  }
  return out;
}

std::vector<std::vector<ParameterValue>> ensemble_members(const Ensemble& e) {
  std::vector<size_t> grid_axes, sampled_axes;
  size_t grid = 1;
  for (size_t k = 0; k < e.parameters.size(); ++k)
    if (e.parameters[k].distribution.empty()) grid_axes.push_back(k), grid *= e.parameters[k].values.size();
    else sampled_axes.push_back(k);
  const auto u = latin_hypercube(e.samples, sampled_axes.size(), e.seed);
  std::vector<std::vector<ParameterValue>> members;
  for (size_t g = 0; g < grid; ++g)
    for (size_t s = 0; s < e.samples; ++s) {
      std::vector<ParameterValue> m(e.parameters.size());
      size_t rest = g;
      for (size_t a = grid_axes.size(); a-- > 0;) {  // the last grid axis varies fastest
        const auto& p = e.parameters[grid_axes[a]];
        m[grid_axes[a]] = {p.pointer, p.values[rest % p.values.size()]};
        rest /= p.values.size();
      }
      for (size_t a = 0; a < sampled_axes.size(); ++a) {
        const auto& p = e.parameters[sampled_axes[a]];
        m[sampled_axes[a]] = {p.pointer, parameter_quantile(p, u[s][a])};
      }
      members.push_back(std::move(m));
    }
  return members;
}

}  // namespace runout
