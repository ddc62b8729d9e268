// Request validation (requests.hpp). Every refusal names the field (a JSON path into the body) and the
// accepted range; scene errors are the scene validator's own messages, prefixed with where the scene is.
#include "requests.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <variant>

#include <nlohmann/json.hpp>

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/multi_fidelity.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/scene_refs.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/common/sha256.hpp"

namespace runout::service {

namespace {

using json = nlohmann::json;

constexpr size_t kMaxStructures = 64;
constexpr size_t kMaxVariants = 1024;

json parse_body(const std::string& body) {
  if (body.find_first_not_of(" \t\r\n") == std::string::npos)
    throw ApiError(400, "(body)", "empty body (accepted: a JSON object)");
  check_json_depth(body, "(body)");
  try {
    json j = json::parse(body);
    if (!j.is_object()) throw ApiError(422, "(body)", "must be a JSON object");
    return j;
  } catch (const json::exception& e) {  // parse errors, and numbers beyond a double (1e400)
    throw ApiError(400, "(body)", std::string("malformed JSON (accepted: a JSON object; NaN and Infinity are not "
                                              "JSON): ") + e.what());
  }
}

// Every unknown field of `j`, each its own error.
void refuse_unknown(const json& j, const std::string& path, const std::set<std::string>& allowed, FieldErrors& errors) {
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!allowed.count(it.key()))
      errors.add(ApiError(422, path.empty() ? it.key() : path + "." + it.key(), "unknown field (accepted: " + list + ")"));
}

void refuse_unknown(const json& j, const std::string& path, const std::set<std::string>& allowed) {
  FieldErrors errors;
  refuse_unknown(j, path, allowed, errors);
  errors.raise();
}

std::string at(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

// Names used as labels (sweep, variant): 1 to 64 of [A-Za-z0-9_.+-], not "." or "..".
bool label_ok(const std::string& s) {
  const bool chars_ok = std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '+' || c == '-';
  });
  return !s.empty() && s.size() <= 64 && chars_ok && s.find("..") == std::string::npos;
}

void check_label(const json& v, const std::string& field) {
  const std::string accepted = "a string of 1 to 64 characters from A-Z a-z 0-9 _ . + -, without '..'";
  if (!v.is_string()) throw ApiError(422, field, "must be " + accepted);
  const std::string s = v.get<std::string>();
  if (!label_ok(s)) throw ApiError(422, field, "'" + s.substr(0, 80) + "' is not accepted (accepted: " + accepted + ")");
}

// A scene's own name: 1 to 128 printable ASCII characters without / \ or "..".
void check_scene_name(const json& scene, const std::string& field) {
  if (!scene.contains("name")) return;
  const std::string accepted = "a string of 1 to 128 printable ASCII characters without '/', '\\' or '..'";
  const json& v = scene["name"];
  if (!v.is_string()) throw ApiError(422, field, "must be " + accepted);
  const std::string s = v.get<std::string>();
  const bool chars_ok = std::all_of(s.begin(), s.end(), [](char c) { return c >= 0x20 && c < 0x7f && c != '/' && c != '\\'; });
  if (s.empty() || s.size() > 128 || !chars_ok || s.find("..") != std::string::npos)
    throw ApiError(422, field, "is not accepted (accepted: " + accepted + ")");
}

// The parts of a scene that resolve_variant reads, checked so that it cannot throw on a wrong type.
void check_resolvable(const json& scene, const std::string& path) {
  if (scene.contains("dp") && !scene["dp"].is_number())
    throw ApiError(422, at(path, "dp"), "must be a number in [0.0001, 100]");
  check_scene_name(scene, at(path, "name"));
  try {
    check_scene_shapes(scene, path);
  } catch (const SceneError& e) {
    throw ApiError(422, e.field, std::string(e.what()).substr(e.field.size() + 2));
  }
  // File names (the DEM and every vector layer): relative, inside the service's scene directory.
  for (const auto& [field, value] : scene_file_fields(scene, path)) {
    if (!value->is_string()) throw ApiError(422, field, "must be a file name relative to the service's scene directory");
    const std::filesystem::path p = value->get<std::string>();
    bool dotdot = false;
    for (const auto& part : p) dotdot = dotdot || part == "..";
    if (p.empty() || p.is_absolute() || dotdot || p.string().find('\\') != std::string::npos)
      throw ApiError(422, field,
                     "must be a relative file name inside the service's scene directory (--scene-dir; no '..', not "
                     "absolute)");
  }
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s.empty() ? "(none)" : s;
}

// A layout: unique names of candidate structures of the base.
std::vector<std::string> parse_structures(const json& v, const std::string& field, const std::vector<std::string>& cands) {
  if (!v.is_array()) throw ApiError(422, field, "must be an array of structure names (candidates: " + join(cands) + ")");
  if (v.size() > kMaxStructures)
    throw ApiError(422, field, "has " + std::to_string(v.size()) + " entries (accepted: 0 to " +
                                   std::to_string(kMaxStructures) + " structure names)");
  std::vector<std::string> out;
  for (size_t k = 0; k < v.size(); ++k) {
    const std::string f = field + "[" + std::to_string(k) + "]";
    if (!v[k].is_string()) throw ApiError(422, f, "must be a structure name (candidates: " + join(cands) + ")");
    const std::string s = v[k].get<std::string>();
    if (std::find(cands.begin(), cands.end(), s) == cands.end())
      throw ApiError(422, f, "no candidate structure '" + s.substr(0, 80) + "' in the base scene (candidates: " + join(cands) + ")");
    if (std::find(out.begin(), out.end(), s) != out.end())
      throw ApiError(422, f, "structure '" + s + "' is listed twice (accepted: each candidate at most once)");
    out.push_back(s);
  }
  return out;
}

Fidelity parse_fidelity(const json& body, const std::string& field) {
  Fidelity f;
  if (!body.contains(field)) return f;  // standard
  const json& v = body[field];
  const std::string accepted = "one of draft, standard, fine, screening, or {\"dp\": a number in [0.0001, 100]}";
  if (v.is_string()) {
    const std::string name = v.get<std::string>();
    if (std::find(fidelity_names().begin(), fidelity_names().end(), name) == fidelity_names().end())
      throw ApiError(422, field, "unknown fidelity '" + name.substr(0, 80) + "' (accepted: " + accepted + ")");
    f.name = name;
    return f;
  }
  if (v.is_object()) {
    refuse_unknown(v, field, {"dp"});
    if (!v.contains("dp") || !v["dp"].is_number()) throw ApiError(422, field + ".dp", "must be a number in [0.0001, 100]");
    const double dp = v["dp"].get<double>();
    if (!std::isfinite(dp) || dp < 1e-4 || dp > 100)
      throw ApiError(422, field + ".dp", "must be a number in [0.0001, 100]");
    f.name = "custom";
    f.dp = dp;
    return f;
  }
  throw ApiError(422, field, "must be " + accepted);
}

std::optional<std::string> parse_key(const json& body) {
  if (!body.contains("idempotency_key")) return std::nullopt;
  if (!body["idempotency_key"].is_string())
    throw ApiError(422, "idempotency_key", "must be a string of 1 to 200 printable ASCII characters");
  std::string k = body["idempotency_key"].get<std::string>();
  check_idempotency_key(k, "idempotency_key");
  return k;
}

// A priced scene's particle counts and cost features, into the job spec.
void record_estimate(const SceneEstimate& e, JobSpec& spec) {
  spec.cost = e.cost;
  spec.fluid_particles = e.counts.fluid;
  // Every wall particle the scene describes (a terrain's bed is laid near the flow: fewer are alive).
  spec.boundary_particles = e.counts.walls + e.counts.bed;
  if (spec.cost.model == "screening") {  // its own particles at most at once; its bed is a grid
    spec.fluid_particles = std::llround(spec.cost.fluid_peak);
    spec.boundary_particles = 0;
  }
  spec.particles = spec.fluid_particles + spec.boundary_particles;
  spec.dimensions = e.dimensions;
  spec.resolved_dp = e.dp;
}

// The files a scene names must be inside the scene directory after every symbolic link is followed (the
// lexical check of check_resolvable is not enough: a link inside the directory may point anywhere). A link
// whose target is missing is refused too: weakly_canonical keeps it as a plain name, while GDAL reads a
// relative target against the server's working directory.
void check_contained(const json& scene, const std::string& path, const Limits& limits) {
  namespace fs = std::filesystem;
  for (const auto& [field, value] : scene_file_fields(scene, path)) {
    if (!value->is_string()) continue;
    const std::string name = value->get<std::string>();
    std::error_code ec;
    const fs::path root =
        fs::weakly_canonical(fs::absolute(limits.scene_dir.empty() ? fs::path(".") : limits.scene_dir), ec);
    bool dangling = false;
    fs::path prefix;
    for (const fs::path& part : root / name) {
      if (ec || dangling) break;
      prefix /= part;
      std::error_code lec;
      if (fs::is_symlink(fs::symlink_status(prefix, lec))) dangling = !fs::exists(prefix, lec);
    }
    const fs::path file = ec || dangling ? fs::path() : fs::weakly_canonical(root / name, ec);
    const fs::path rel = file.lexically_relative(root);
    if (ec || rel.empty() || *rel.begin() == ".." || rel == ".")
      throw ApiError(422, field, "'" + name.substr(0, 80) + "' resolves outside the service's scene directory (symbolic "
                                 "links followed; a link's target must exist) (accepted: a file inside --scene-dir)");
  }
}

// Reads a resolved scene (its name and duration into `spec`) and, when `price`, prices it under the particle
// budget (estimate_scene: every check of a build; its particle counts and cost features into `spec`).
void read_resolved(const json& resolved, const std::string& path, const Limits& limits, bool price, JobSpec& spec) {
  check_contained(resolved, path, limits);
  json j = resolved;
  const bool budget_binds = apply_particle_budget(j, limits.particle_budget);  // checked before building
  try {
    const SceneSpec scene = read_scene(j, limits.scene_dir);
    spec.scene_name = scene.name;
    spec.duration = scene.duration;
    if (price) record_estimate(estimate_scene(scene), spec);
  } catch (const SceneError& e) {
    std::string msg = std::string(e.what()).substr(std::min(e.field.size() + 2, std::string(e.what()).size()));
    const std::string lim = "limits.max_particles = " + std::to_string(limits.particle_budget);
    if (budget_binds && msg.find(lim) != std::string::npos) {
      msg.replace(msg.find(lim), lim.size(), "the particle budget");
      // The field the scene names: dp for the 3D lattice, screening.spacing for the screening rung's own.
      throw ApiError(422, at(path, e.field),
                     msg + " (accepted: at most " + std::to_string(limits.particle_budget) +
                         " particles per job, --particle-budget; choose a coarser fidelity)");
    }
    ApiError err(422, at(path, e.field), msg);
    if (e.errors.size() > 1)  // every declared field's error at once
      for (const auto& [field, message] : e.errors) err.errors.emplace_back(at(path, field), message);
    throw err;
  } catch (const std::exception& e) {
    throw ApiError(422, path.empty() ? "scene" : path, e.what());
  }
}

// Resolves `base` with a layout at a fidelity (resolve_variant), checks it; the job spec.
// `parameters`: an ensemble member's values; `check` false reads the scene without pricing it (its declared fields
// and files are still checked), the particles and cost left as given in `spec`.
JobSpec make_job(const json& base, const std::string& path, const std::optional<std::vector<std::string>>& layout,
                 const std::string& variant, const Fidelity& fidelity, const Limits& limits,
                 const std::vector<ParameterValue>& parameters = {}, bool check = true, JobSpec spec = {}) {
  const auto cands = structure_names(base);
  SweepVariant v;
  v.name = variant;
  v.structures = layout ? *layout : cands;
  v.parameters = parameters;
  json r;
  try {
    r = resolve_variant(base, v, fidelity);
    if (!layout) {  // a complete scene: its own name, as written
      if (base.contains("name"))
        r["name"] = base["name"];
      else
        r.erase("name");
    }
  } catch (const json::exception& e) {
    throw ApiError(422, path, std::string("cannot apply the layout and fidelity: ") + e.what());
  }
  read_resolved(r, path, limits, check, spec);
  spec.scene_json = r.dump();
  spec.fidelity = fidelity.dp ? "custom" : fidelity.name;
  spec.dp = fidelity.dp;
  spec.variant = layout ? variant : "";
  return spec;
}

// The base scene of a request: inline under `key`, or a stored one by scene_id.
struct Base {
  json scene;
  std::string path;
  std::optional<int64_t> scene_id;
};

Base base_of(const json& body, const char* inline_key, const JobQueue& queue) {
  Base b;
  const bool has_inline = body.contains(inline_key), has_id = body.contains("scene_id");
  if (has_inline == has_id)
    throw ApiError(422, inline_key, std::string("give exactly one of ") + inline_key + " (a scene object) or scene_id");
  if (has_id) {
    const json& v = body["scene_id"];
    if (!v.is_number_integer() || v.get<int64_t>() < 1)
      throw ApiError(422, "scene_id", "must be the id of a stored scene (an integer >= 1)");
    const auto doc = queue.scene_document(v.get<int64_t>());  // parsed once per process
    if (!doc) throw ApiError(404, "scene_id", "no stored scene with id " + std::to_string(v.get<int64_t>()));
    b.scene = *doc;
    b.scene_id = v.get<int64_t>();
    b.path = "";  // fields of a stored scene are named as in the scene
  } else {
    b.scene = body[inline_key];
    if (!b.scene.is_object()) throw ApiError(422, inline_key, "must be a scene (a JSON object)");
    b.path = inline_key;
  }
  check_resolvable(b.scene, b.path);
  return b;
}

}  // namespace

void check_json_depth(const std::string& body, const std::string& field) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (const char c : body) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw ApiError(422, field, "arrays and objects nest deeper than " + std::to_string(kMaxJsonDepth) +
                                       " levels (accepted: at most " + std::to_string(kMaxJsonDepth) + ")");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

void FieldErrors::add(const ApiError& e) {
  auto keep = [&](const ApiError& one) {
    if (errors_.size() < kMaxListed) errors_.push_back(one);
    else ++unlisted_;
  };
  if (e.errors.empty()) keep(e);
  for (const auto& [field, message] : e.errors) keep(ApiError(e.status, field, message));
}

void FieldErrors::raise() const {
  if (errors_.empty()) return;
  int status = errors_.front().status;
  for (const auto& e : errors_)
    if (e.status != status && e.status == 422) status = 422;
  ApiError out(status, errors_.front().field, errors_.front().what());
  if (errors_.size() > 1)
    for (const auto& e : errors_) out.errors.emplace_back(e.field, e.what());
  if (unlisted_ > 0)
    out.errors.emplace_back("(errors)", "and " + std::to_string(unlisted_) + " more invalid fields, not listed (at most " +
                                            std::to_string(kMaxListed) + " are)");
  throw out;
}

void check_idempotency_key(const std::string& key, const std::string& field) {
  const bool ok = !key.empty() && key.size() <= 200 &&
                  std::all_of(key.begin(), key.end(), [](char c) { return c > 0x20 && c < 0x7f; });
  if (!ok) throw ApiError(400, field, "must be 1 to 200 printable ASCII characters without spaces");
}

bool safe_file_name(const std::string& name) {
  return !name.empty() && name.size() <= 64 && name.find("..") == std::string::npos &&
         std::all_of(name.begin(), name.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
         });
}

std::string rebase_scene_files(const std::string& scene_json, const std::filesystem::path& folder) {
  json scene = json::parse(scene_json);
  for (const auto& [field, value] : scene_file_fields(scene, "")) {
    if (!value->is_string()) continue;  // the validator names it
    const std::filesystem::path name = value->get<std::string>();
    const std::filesystem::path rebased = (folder / name).lexically_normal();
    if (name.is_absolute() || rebased.empty() || *rebased.begin() == "..")
      throw std::invalid_argument(field + ": '" + name.string() + "' is not inside the scene directory");
    *const_cast<json*>(value) = rebased.generic_string();  // scene is ours: scene_file_fields lists its own members
  }
  return scene.dump();
}

NewScene parse_scene_request(const std::string& body, const Limits& limits, const std::function<bool()>& stopped) {
  const json scene = parse_body(body);
  check_resolvable(scene, "");
  NewScene out;
  out.structures = structure_names(scene);
  // Checked at draft fidelity without structures and with each candidate structure alone (candidates may
  // exclude each other, e.g. overlap: a layout is checked when a job or sweep names it, at its fidelity).
  Fidelity draft;
  draft.name = "draft";
  (void)make_job(scene, "", std::vector<std::string>{}, "none", draft, limits);
  for (const auto& s : out.structures) {
    if (stopped && stopped()) throw std::runtime_error("stopped before structure '" + s + "' was checked");
    try {
      (void)make_job(scene, "", std::vector<std::string>{s}, "check", draft, limits);
    } catch (const ApiError& e) {
      throw ApiError(e.status, e.field, "with structure '" + s + "' alone: " + e.what());
    }
  }
  out.scene_json = scene.dump();
  out.content_hash = sha256_hex(out.scene_json);
  out.name = scene.value("name", std::string("scene"));
  return out;
}

JobSpec parse_job_request(const std::string& body, const Limits& limits, const JobQueue& queue,
                          std::optional<std::string>& body_key) {
  const json j = parse_body(body);
  // The envelope's fields are checked together (every invalid one is reported); the scene after them.
  FieldErrors errors;
  refuse_unknown(j, "", {"scene", "base", "scene_id", "structures", "variant", "fidelity", "idempotency_key"}, errors);
  errors.check([&] { body_key = parse_key(j); });
  Fidelity fidelity;
  errors.check([&] { fidelity = parse_fidelity(j, "fidelity"); });
  const bool plain = j.contains("scene");
  if (plain) {
    errors.check([&] {
      if (j.contains("base") || j.contains("scene_id"))
        throw ApiError(422, "scene", "give one of scene (a complete scene), base (a base scene) or scene_id");
      if (!j["scene"].is_object()) throw ApiError(422, "scene", "must be a scene (a JSON object)");
    });
    for (const char* layout_field : {"structures", "variant"})
      if (j.contains(layout_field))
        errors.add(ApiError(422, layout_field, "a layout goes with base or scene_id, not with a complete scene"));
    errors.raise();
    check_resolvable(j["scene"], "scene");
    return make_job(j["scene"], "scene", std::nullopt, "", fidelity, limits);
  }
  std::optional<Base> b;
  errors.check([&] { b = base_of(j, "base", queue); });
  std::string variant;
  if (j.contains("variant")) errors.check([&] {
      check_label(j["variant"], "variant");
      variant = j["variant"].get<std::string>();
    });
  std::optional<std::vector<std::string>> layout;
  if (b && j.contains("structures"))  // a layout is checked against its base's candidates
    errors.check([&] { layout = parse_structures(j["structures"], "structures", structure_names(b->scene)); });
  errors.raise();
  const auto cands = structure_names(b->scene);
  if (!j.contains("variant")) {
    const auto& s = layout ? *layout : cands;
    for (const auto& n : s) variant += (variant.empty() ? "" : "+") + n;
    if (variant.empty()) variant = "none";
    if (!label_ok(variant)) variant = "layout";
  }
  if (!layout) layout = cands;
  JobSpec spec = make_job(b->scene, b->path, layout, variant, fidelity, limits);
  spec.scene_id = b->scene_id;
  return spec;
}

namespace {

// A sweep's factorial design: 2^n layouts of 1 to 10 candidate structures.
std::vector<SweepVariant> parse_factorial(const json& f, const std::vector<std::string>& cands, FieldErrors& errors) {
  if (!f.is_object()) {
    errors.add(ApiError(422, "factorial", "must be an object {structures, prefix}"));
    return {};
  }
  refuse_unknown(f, "factorial", {"structures", "prefix"}, errors);
  std::vector<std::string> names;
  const bool names_ok = errors.check([&] {
    if (!f.contains("structures")) throw ApiError(422, "factorial.structures", "missing (required: 1 to 10 structure names)");
    names = parse_structures(f["structures"], "factorial.structures", cands);
    if (names.empty() || names.size() > 10)
      throw ApiError(422, "factorial.structures", "must name 1 to 10 structures (2^n jobs, at most 1024)");
  });
  std::string prefix = "G";
  if (f.contains("prefix")) errors.check([&] {
      check_label(f["prefix"], "factorial.prefix");
      prefix = f["prefix"].get<std::string>();
      if (prefix.size() > 32) throw ApiError(422, "factorial.prefix", "must be 1 to 32 characters");
    });
  return names_ok ? factorial_variants(names, prefix) : std::vector<SweepVariant>{};
}

// A sweep's explicit layouts: 1 to 1024 {name, structures}, every entry's errors reported.
std::vector<SweepVariant> parse_variants(const json& vs, const std::vector<std::string>& cands, FieldErrors& errors) {
  if (!vs.is_array() || vs.empty() || vs.size() > kMaxVariants) {
    errors.add(ApiError(422, "variants", "must be an array of 1 to " + std::to_string(kMaxVariants) + " {name, structures}"));
    return {};
  }
  std::vector<SweepVariant> variants;
  std::set<std::string> seen;
  for (size_t k = 0; k < vs.size(); ++k) {
    const std::string path = "variants[" + std::to_string(k) + "]";
    if (!vs[k].is_object()) {
      errors.add(ApiError(422, path, "must be an object {name, structures}"));
      continue;
    }
    refuse_unknown(vs[k], path, {"name", "structures"}, errors);
    SweepVariant v;
    errors.check([&] {
      if (!vs[k].contains("name")) throw ApiError(422, path + ".name", "missing (required: the variant's name)");
      check_label(vs[k]["name"], path + ".name");
      v.name = vs[k]["name"].get<std::string>();
      if (!seen.insert(v.name).second) throw ApiError(422, path + ".name", "duplicate variant name '" + v.name + "'");
    });
    if (vs[k].contains("structures"))
      errors.check([&] { v.structures = parse_structures(vs[k]["structures"], path + ".structures", cands); });
    variants.push_back(v);
  }
  return variants;
}

// An ensemble sweep's jobs (docs/service.md, "Sweeps"): every layout at every member, member by member, named
// LAYOUT-eNNN as `runout sweep` names them. Built as scenes, as the CLI checks them: every layout at the first
// member, and the first layout at each member holding a parameter's smallest or largest value (a sampled value
// outside the scene's own range is refused, naming the member); the other jobs take their layout's particles
// and cost from the first member (a member that changes the release volume changes them: the estimate does
// not follow). So a 64-member ensemble of 8 layouts costs 8 to 10 scene builds, not 512.
void add_ensemble_jobs(NewSweep& out, const Base& b, const Fidelity& fidelity, const Limits& limits) {
  Ensemble e;
  try {
    e = parse_ensemble(*out.ensemble_json, out.base_json);
  } catch (const SceneError& err) {
    const std::string what = err.what();  // "<field>: <message>"
    throw ApiError(422, err.field, what.substr(std::min(err.field.size() + 2, what.size())));
  }
  const auto members = ensemble_members(e);
  const size_t n = members.size() * out.variants.size();
  if (n > kMaxVariants)
    throw ApiError(422, "ensemble", std::to_string(members.size()) + " members x " + std::to_string(out.variants.size()) +
                                        " layouts = " + std::to_string(n) + " jobs (accepted: at most " +
                                        std::to_string(kMaxVariants) + " a sweep)");
  const std::vector<size_t> extremes = extreme_members(members);
  const std::vector<SweepVariant> all = ensemble_variants(out.variants, members);
  std::vector<JobSpec> first(out.variants.size());  // each layout's job at the first member
  for (size_t k = 0; k < all.size(); ++k) {
    const SweepVariant& v = all[k];
    const size_t layout = k % out.variants.size();
    const bool extreme = std::count(extremes.begin(), extremes.end(), static_cast<size_t>(v.member)) > 0;
    const bool check = v.member == 0 || (layout == 0 && extreme);
    const std::string path = b.path.empty() ? "ensemble" : b.path;
    JobSpec spec;
    try {
      spec = make_job(b.scene, path, v.structures, v.name, fidelity, limits, v.parameters, check,
                      v.member == 0 ? JobSpec{} : first[layout]);
    } catch (const ApiError& err) {
      std::string values;
      for (const auto& p : v.parameters)
        values += (values.empty() ? "" : ", ") + p.pointer + " = " + std::to_string(p.value);
      throw ApiError(err.status, err.field, "variant '" + v.name + "' (" + values + "): " + err.what());
    }
    if (v.member == 0) first[layout] = spec;
    spec.scene_id = b.scene_id;
    spec.sweep = out.name;
    out.jobs.push_back(std::move(spec));
  }
}

// A study's detailed stage (docs/service.md, "Studies"): every layout at the ensemble's median member at the
// study's rung, each built as a scene now, so that a layout the detailed rung cannot run is refused before the
// screening stage spends anything; the chosen ones are queued once that stage has ended.
void add_study_candidates(NewSweep& out, const Base& b, const Fidelity& detailed, const Limits& limits) {
  NewSweep::Study st;
  st.fidelity = detailed;
  st.median = median_member(parse_ensemble(*out.ensemble_json, out.base_json));  // checked by add_ensemble_jobs
  for (const auto& v : out.variants) {
    JobSpec spec;
    try {
      spec = make_job(b.scene, "study.fidelity", v.structures, v.name, detailed, limits, st.median);
    } catch (const ApiError& err) {
      throw ApiError(err.status, err.field, "layout '" + v.name + "' at the median member: " + err.what());
    }
    spec.scene_id = b.scene_id;
    spec.sweep = out.name + "-median";  // as `runout study` names its detailed sweep
    spec.stage = 2;
    st.candidates.push_back(std::move(spec));
  }
  out.study = std::move(st);
}

// A study's own fields: {"fidelity": the detailed rung (default standard)}; a study needs an ensemble.
std::optional<Fidelity> parse_study(const json& j, FieldErrors& errors) {
  if (!j.contains("study")) return std::nullopt;
  if (!j["study"].is_object()) {
    errors.add(ApiError(422, "study", "must be an object {fidelity} (docs/service.md, \"Studies\")"));
    return std::nullopt;
  }
  refuse_unknown(j["study"], "study", {"fidelity"}, errors);
  if (!j.contains("ensemble"))
    errors.add(ApiError(422, "study", "a study screens an ensemble: give the sweep an ensemble (docs/scene-format.md, "
                                      "\"Ensembles\")"));
  Fidelity f;
  errors.check([&] {
    try {
      f = parse_fidelity(j["study"], "fidelity");
    } catch (const ApiError& e) {
      throw ApiError(e.status, "study." + e.field, e.what());
    }
  });
  return f;
}

}  // namespace

NewSweep parse_sweep_request(const std::string& body, const Limits& limits, const JobQueue& queue,
                             std::optional<std::string>& body_key) {
  const json j = parse_body(body);
  // The envelope's fields are checked together (every invalid one is reported); each layout's scene after them.
  FieldErrors errors;
  refuse_unknown(j, "",
                 {"name", "base", "scene_id", "fidelity", "variants", "factorial", "ensemble", "study", "idempotency_key"},
                 errors);
  const std::optional<Fidelity> detailed = parse_study(j, errors);
  if (j.contains("ensemble") && !j["ensemble"].is_object())
    errors.add(ApiError(422, "ensemble",
                        "must be an object {parameters, members, seed} (docs/scene-format.md, \"Ensembles\")"));
  errors.check([&] { body_key = parse_key(j); });
  NewSweep out;
  out.name = "sweep";
  if (j.contains("name")) errors.check([&] {
      check_label(j["name"], "name");
      out.name = j["name"].get<std::string>();
    });
  Fidelity fidelity;
  if (detailed && !j.contains("fidelity")) fidelity.name = "screening";  // a study's first stage
  errors.check([&] {
    if (j.contains("fidelity")) fidelity = parse_fidelity(j, "fidelity");
  });
  out.fidelity = fidelity.dp ? "custom" : fidelity.name;
  std::optional<Base> base;
  errors.check([&] { base = base_of(j, "base", queue); });
  // Layouts name the base's candidates: they are checked once the base is valid.
  std::vector<SweepVariant> variants;
  if (j.contains("variants") == j.contains("factorial"))
    errors.add(ApiError(422, "variants", "give exactly one of variants (explicit layouts) or factorial (all subsets)"));
  else if (base && j.contains("factorial"))
    variants = parse_factorial(j["factorial"], structure_names(base->scene), errors);
  else if (base)
    variants = parse_variants(j["variants"], structure_names(base->scene), errors);
  errors.raise();
  const Base& b = *base;
  out.scene_id = b.scene_id;
  out.base_json = b.scene.dump();
  out.variants = variants;
  if (j.contains("ensemble")) {
    out.ensemble_json = j["ensemble"].dump();
    add_ensemble_jobs(out, b, fidelity, limits);
    if (detailed) {
      for (auto& spec : out.jobs) spec.stage = 1;
      add_study_candidates(out, b, *detailed, limits);
    }
    return out;
  }
  for (size_t k = 0; k < variants.size(); ++k) {
    const std::string path = b.path.empty() ? "variants[" + std::to_string(k) + "]" : b.path;
    JobSpec spec;
    try {
      spec = make_job(b.scene, path, variants[k].structures, variants[k].name, fidelity, limits);
    } catch (const ApiError& e) {
      throw ApiError(e.status, e.field, "variant '" + variants[k].name + "': " + e.what());
    }
    spec.scene_id = b.scene_id;
    spec.sweep = out.name;
    out.jobs.push_back(std::move(spec));
  }
  return out;
}

}  // namespace runout::service
