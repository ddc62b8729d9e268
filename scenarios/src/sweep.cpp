#include "runout/scenarios/sweep.hpp"

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/common/sha256.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/scene.hpp"

#ifndef RUNOUT_VERSION
#define RUNOUT_VERSION "unknown"
#endif

namespace runout {
namespace {

using json = nlohmann::json;

std::string read_file(const std::filesystem::path& p, const std::string& field) {
  std::ifstream in(p);
  if (!in) throw SceneError(field, "cannot read '" + p.string() + "'");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> candidate_names(const json& base) {
  std::vector<std::string> names;
  if (base.contains("structures") && base["structures"].is_array())
    for (const auto& s : base["structures"])
      if (s.contains("name") && s["name"].is_string()) names.push_back(s["name"].get<std::string>());
  return names;
}

// Files of the layer references ({"layer": FILE, ...}) anywhere in a scene, as written.
void layer_files(const json& j, std::set<std::string>& out) {
  if (j.is_object() && j.contains("layer") && j["layer"].is_string()) out.insert(j["layer"].get<std::string>());
  if (j.is_structured())
    for (const auto& v : j) layer_files(v, out);
}

// Fidelity: explicit dp, the scene's preset, or the default ladder around the scene's dp; the preset's
// numerics applied and "fidelity" removed.
void apply_fidelity(json& j, const Fidelity& fidelity) {
  const double base_dp = j.value("dp", 0.0);
  json preset = json::object();
  if (j.contains("fidelity") && j["fidelity"].is_object() && j["fidelity"].contains(fidelity.name))
    preset = j["fidelity"][fidelity.name];
  j.erase("fidelity");
  // The screening rung runs the scene's terrain at its dp with the thickness-integrated model (the screening
  // section's own spacing); a preset may still set dp, the bed grid's spacing.
  if (fidelity.name == "screening") j["model"] = "screening";
  if (fidelity.dp) {
    j["dp"] = *fidelity.dp;
  } else if (preset.contains("dp")) {
    j["dp"] = preset["dp"];
  } else if (fidelity.name == "draft") {
    j["dp"] = 2.0 * base_dp;
  } else if (fidelity.name == "fine") {
    j["dp"] = 0.5 * base_dp;
  }
  if (preset.contains("numerics") && preset["numerics"].is_object())
    for (auto it = preset["numerics"].begin(); it != preset["numerics"].end(); ++it) j["numerics"][it.key()] = it.value();
}

// Every layout with every member (ensemble_variants). The members holding each parameter's smallest and largest
// value are checked as scenes now (the scene's own ranges: a sampled friction angle of 95 degrees is refused before
// anything runs); checking every member would parse the DEM hundreds of times.
std::vector<SweepVariant> expand_ensemble(const Sweep& sw, const Ensemble& e) {
  const auto members = ensemble_members(e);
  std::vector<SweepVariant> out = ensemble_variants(sw.variants, members);
  const nlohmann::json base = parse_scene_document(sw.base_json);
  for (size_t m : extreme_members(members)) {
    const SweepVariant& v = out[m * sw.variants.size()];
    try {
      (void)estimate_scene(read_scene(resolve_variant(base, v, sw.fidelity), sw.base_path.parent_path()));
    } catch (const SceneError& err) {
      std::string values;
      for (const auto& pv : v.parameters) values += (values.empty() ? "" : ", ") + pv.pointer + " = " + std::to_string(pv.value);
      throw SceneError("ensemble member " + std::to_string(m) + " (" + values + "): " + err.field,
                       std::string(err.what()).substr(err.field.size() + 2));
    }
  }
  return out;
}

}  // namespace

std::string member_variant_name(const std::string& layout, size_t member, size_t members) {
  const size_t digits = std::max<size_t>(3, std::to_string(members > 0 ? members - 1 : 0).size());
  const std::string index = std::to_string(member);
  return layout + "-e" + std::string(digits - std::min(digits, index.size()), '0') + index;
}

std::vector<size_t> extreme_members(const std::vector<std::vector<ParameterValue>>& members) {
  std::set<size_t> extremes;
  const size_t params = members.empty() ? 0 : members.front().size();
  for (size_t p = 0; p < params; ++p) {
    size_t lo = 0, hi = 0;
    for (size_t m = 0; m < members.size(); ++m) {
      if (members[m][p].value < members[lo][p].value) lo = m;
      if (members[m][p].value > members[hi][p].value) hi = m;
    }
    extremes.insert(lo), extremes.insert(hi);
  }
  return {extremes.begin(), extremes.end()};
}

std::vector<SweepVariant> ensemble_variants(const std::vector<SweepVariant>& layouts,
                                            const std::vector<std::vector<ParameterValue>>& members) {
  std::vector<SweepVariant> out;
  for (size_t m = 0; m < members.size(); ++m)
    for (const auto& layout : layouts) {
      SweepVariant v = layout;
      v.name = member_variant_name(layout.name, m, members.size());
      v.layout = layout.name;
      v.member = static_cast<int>(m);
      v.parameters = members[m];
      out.push_back(std::move(v));
    }
  return out;
}

const std::vector<std::string>& fidelity_names() {
  static const std::vector<std::string> names = {"draft", "standard", "fine", "screening"};
  return names;
}

std::vector<SweepVariant> factorial_variants(const std::vector<std::string>& names, const std::string& prefix) {
  std::vector<SweepVariant> out;
  const size_t n = names.size();
  for (size_t k = 0; k <= n; ++k) {
    // Combinations of size k in lexicographic order of indices.
    std::vector<size_t> idx(k);
    for (size_t q = 0; q < k; ++q) idx[q] = q;
    while (true) {
      SweepVariant v;
      v.name = prefix + std::to_string(out.size());
      for (size_t q : idx) v.structures.push_back(names[q]);
      out.push_back(v);
      if (k == 0) break;
      size_t q = k;
      while (q > 0 && idx[q - 1] == n - k + q - 1) --q;
      if (q == 0) break;
      ++idx[q - 1];
      for (size_t r = q; r < k; ++r) idx[r] = idx[r - 1] + 1;
    }
  }
  return out;
}

Sweep parse_sweep(const std::string& json_text, const std::filesystem::path& base_dir) {
  json j;
  try {
    j = json::parse(json_text);
  } catch (const json::exception& e) {
    throw SceneError("(json)", std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_object()) throw SceneError("(root)", "a sweep must be a JSON object");
  const std::set<std::string> allowed = {"name", "description", "base", "fidelity", "variants", "factorial", "ensemble"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!allowed.count(it.key()))
      throw SceneError(it.key(), "unknown field (accepted: base, description, ensemble, factorial, fidelity, name, variants)");
  Sweep sw;
  sw.name = j.value("name", std::string("sweep"));
  if (!j.contains("base") || !j["base"].is_string()) throw SceneError("base", "missing (required: the base scene file)");
  sw.base_path = j["base"].get<std::string>();
  if (sw.base_path.is_relative() && !base_dir.empty()) sw.base_path = base_dir / sw.base_path;
  sw.base_json = read_file(sw.base_path, "base");
  const json base = json::parse(sw.base_json, nullptr, false);
  if (base.is_discarded()) throw SceneError("base", "'" + sw.base_path.string() + "' is not valid JSON");
  if (j.contains("fidelity")) {
    if (!j["fidelity"].is_string()) throw SceneError("fidelity", "must be one of draft, standard, fine, screening");
    sw.fidelity.name = j["fidelity"].get<std::string>();
    if (std::find(fidelity_names().begin(), fidelity_names().end(), sw.fidelity.name) == fidelity_names().end())
      throw SceneError("fidelity", "unknown value '" + sw.fidelity.name + "' (accepted: draft, standard, fine, screening)");
  }
  const auto candidates = candidate_names(base);
  if (j.contains("variants") == j.contains("factorial"))
    throw SceneError("variants", "give exactly one of variants (explicit layouts) or factorial (all subsets)");
  if (j.contains("factorial")) {
    const json& f = j["factorial"];
    if (!f.is_object() || !f.contains("structures") || !f["structures"].is_array())
      throw SceneError("factorial.structures", "missing (required: an array of candidate structure names)");
    for (auto it = f.begin(); it != f.end(); ++it)
      if (it.key() != "structures" && it.key() != "prefix")
        throw SceneError("factorial." + it.key(), "unknown field (accepted: prefix, structures)");
    std::vector<std::string> names;
    for (size_t k = 0; k < f["structures"].size(); ++k) {
      const json& n = f["structures"][k];
      if (!n.is_string()) throw SceneError("factorial.structures[" + std::to_string(k) + "]", "must be a structure name");
      names.push_back(n.get<std::string>());
    }
    if (names.empty() || names.size() > 10)
      throw SceneError("factorial.structures", "must name 1 to 10 structures (2^n runs)");
    const std::string prefix = f.value("prefix", std::string("G"));
    sw.variants = factorial_variants(names, prefix);
  } else {
    const json& vs = j["variants"];
    if (!vs.is_array() || vs.empty()) throw SceneError("variants", "must be a non-empty array of {name, structures}");
    for (size_t k = 0; k < vs.size(); ++k) {
      const std::string path = "variants[" + std::to_string(k) + "]";
      const json& v = vs[k];
      if (!v.is_object() || !v.contains("name") || !v["name"].is_string())
        throw SceneError(path + ".name", "missing (required: the variant's name)");
      for (auto it = v.begin(); it != v.end(); ++it)
        if (it.key() != "name" && it.key() != "structures")
          throw SceneError(path + "." + it.key(), "unknown field (accepted: name, structures)");
      SweepVariant sv;
      sv.name = v["name"].get<std::string>();
      if (v.contains("structures")) {
        if (!v["structures"].is_array()) throw SceneError(path + ".structures", "must be an array of structure names");
        for (size_t q = 0; q < v["structures"].size(); ++q) {
          const json& n = v["structures"][q];
          if (!n.is_string()) throw SceneError(path + ".structures[" + std::to_string(q) + "]", "must be a structure name");
          sv.structures.push_back(n.get<std::string>());
        }
      }
      sw.variants.push_back(sv);
    }
  }
  std::set<std::string> seen;
  for (size_t k = 0; k < sw.variants.size(); ++k) {
    const auto& v = sw.variants[k];
    const std::string path = "variants[" + std::to_string(k) + "]";
    if (!seen.insert(v.name).second) throw SceneError(path + ".name", "duplicate variant name '" + v.name + "'");
    for (const auto& s : v.structures)
      if (std::find(candidates.begin(), candidates.end(), s) == candidates.end()) {
        std::string list;
        for (const auto& c : candidates) list += (list.empty() ? "" : ", ") + c;
        throw SceneError(j.contains("factorial") ? "factorial.structures" : path + ".structures",
                         "no candidate structure '" + s + "' in the base scene (candidates: " + list + ")");
      }
  }
  // Every variant must make a valid scene at the sweep's fidelity; checked now, before anything runs.
  for (size_t k = 0; k < sw.variants.size(); ++k) {
    try {
      (void)estimate_scene(read_scene(resolve_variant(base, sw.variants[k], sw.fidelity), sw.base_path.parent_path()));
    } catch (const SceneError& e) {
      throw SceneError("variants[" + std::to_string(k) + "] (" + sw.variants[k].name + "): " + e.field,
                       std::string(e.what()).substr(e.field.size() + 2));
    }
  }
  for (auto& v : sw.variants) v.layout = v.name;
  if (j.contains("ensemble")) {
    sw.ensemble = parse_ensemble(j["ensemble"].dump(), sw.base_json);
    sw.variants = expand_ensemble(sw, *sw.ensemble);
  }
  return sw;
}

Sweep load_sweep(const std::filesystem::path& path) {
  return parse_sweep(read_file(path, "(file)"), path.parent_path());
}

std::string resolve_variant(const std::string& base_json, const SweepVariant& variant, const Fidelity& fidelity) {
  return resolve_variant(json::parse(base_json), variant, fidelity).dump();
}

json resolve_variant(const json& base, const SweepVariant& variant, const Fidelity& fidelity) {
  json j = base;
  const std::vector<std::string> candidates = candidate_names(j);
  auto built = [&](const std::string& name) {
    return std::find(variant.structures.begin(), variant.structures.end(), name) != variant.structures.end();
  };
  if (j.contains("structures") && j["structures"].is_array()) {
    json kept = json::array();
    for (const auto& s : j["structures"])
      if (built(s.value("name", std::string()))) kept.push_back(s);
    j["structures"] = kept;
  }
  // Load monitors on candidate structures that are not built go too (sections stay).
  if (j.contains("monitors") && j["monitors"].is_array()) {
    json ms = json::array();
    for (const auto& m : j["monitors"]) {
      const std::string target = m.value("structure", std::string());
      const bool candidate = std::find(candidates.begin(), candidates.end(), target) != candidates.end();
      if (m.value("type", std::string()) != "structure_load" || !candidate || built(target)) ms.push_back(m);
    }
    j["monitors"] = ms;
  }
  for (const auto& p : variant.parameters) j[json::json_pointer(p.pointer)] = p.value;
  apply_fidelity(j, fidelity);
  j["name"] = j.value("name", std::string("scene")) + "/" + variant.name;
  return j;
}

std::string resolve_scene(const std::string& scene_json, const Fidelity& fidelity) {
  json j;
  try {
    j = json::parse(scene_json);
  } catch (const json::exception& e) {
    throw SceneError("(json)", std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_object()) throw SceneError("(root)", "a scene must be a JSON object");
  apply_fidelity(j, fidelity);
  return j.dump();
}

Manifest make_manifest(const std::string& resolved_scene_json, const std::filesystem::path& base_dir,
                       const Fidelity& fidelity) {
  return make_manifest(json::parse(resolved_scene_json), base_dir, fidelity);
}

Manifest make_manifest(const json& resolved_scene, const std::filesystem::path& base_dir, const Fidelity& fidelity) {
  json scene = resolved_scene;
  scene.erase("description");  // prose: editing it changes no result, so it must not make the runs new ones
  json m;
  m["scene"] = scene;  // nlohmann::json objects are key-sorted: this is canonical
  m["fidelity"] = fidelity.dp ? "custom" : fidelity.name;
  m["version"] = RUNOUT_VERSION;
  if (scene.contains("terrain") && scene["terrain"].contains("dem") && scene["terrain"]["dem"].is_string()) {
    std::filesystem::path dem = scene["terrain"]["dem"].get<std::string>();
    if (dem.is_relative() && !base_dir.empty()) dem = base_dir / dem;
    m["dem_sha256"] = std::filesystem::exists(dem) ? file_sha256(dem.string()) : "missing";
  }
  std::set<std::string> layers;
  layer_files(scene, layers);
  for (const auto& name : layers) {  // a layout held in a GeoPackage changes the run when the file changes
    std::filesystem::path p = name;
    if (p.is_relative() && !base_dir.empty()) p = base_dir / p;
    m["layer_sha256"][name] = std::filesystem::is_regular_file(p) ? file_sha256(p.string()) : "missing";
  }
  Manifest out;
  out.json = m.dump();
  out.hash = sha256_hex(out.json);
  return out;
}

}  // namespace runout
