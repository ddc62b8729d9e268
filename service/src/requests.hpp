#pragma once
// Validation of the service's request bodies: a body becomes a resolved job (scene JSON at a fidelity with
// its layout applied, particle count checked against the budget) or an ApiError naming the field and the
// accepted range. The scene validator (parse_scene) does the scene itself; this adds the envelope, names,
// file paths and the budget. nlohmann-json stays out of this header.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "jobs.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout::service {

struct ApiError : std::runtime_error {
  int status;
  std::string field;
  std::vector<std::pair<std::string, std::string>> headers;  // sent with the error (Retry-After)
  std::string budget_json;  // a JSON object added to the body as "budget" (429 over the work budget)
  // Every invalid field, {field, message}, when a request's fields were checked together (FieldErrors); empty:
  // just this one. The first is `field` and what().
  std::vector<std::pair<std::string, std::string>> errors;
  ApiError(int status_code, std::string field_name, const std::string& message)
      : std::runtime_error(message), status(status_code), field(std::move(field_name)) {}
};

// Collects the errors of a request's own fields, so that one answer lists every invalid field instead of the
// first (the problem document's `errors`). A check that depends on another (a layout on its base scene) runs
// only when that one passed; a scene's own validation (parse_scene) still stops at its first error.
class FieldErrors {
 public:
  // Runs `check`; an ApiError it throws is recorded instead of propagating. True when it passed.
  template <class Check>
  bool check(Check&& check) {
    try {
      check();
      return true;
    } catch (const ApiError& e) {
      add(e);
      return false;
    }
  }
  void add(const ApiError& e);
  bool empty() const { return errors_.empty(); }
  // At most this many are listed (a body of a million unknown keys must not make a bigger answer); the rest
  // are counted in a last entry, "(errors)".
  static constexpr size_t kMaxListed = 100;
  // Throws one ApiError carrying every error recorded (none: returns). Its status is the first error's, or
  // 422 when the errors differ in status and one is 422 (a body whose content is wrong).
  void raise() const;

 private:
  std::vector<ApiError> errors_;
  size_t unlisted_ = 0;
};

// Arrays and objects may nest at most this deep in a request body (422 beyond); checked on the bytes before
// the JSON parser is entered, so a deep document never reaches recursive code.
constexpr int kMaxJsonDepth = 64;
void check_json_depth(const std::string& body, const std::string& field);

struct Limits {
  int64_t particle_budget = 2'000'000;  // particles (fluid + boundary) a job may have
  std::filesystem::path scene_dir;       // where relative file names in scenes (terrain.dem) resolve
};

struct NewScene {
  std::string name, scene_json, content_hash;
  std::vector<std::string> structures;  // candidate structure names
};

struct NewSweep {
  std::string name;
  std::optional<int64_t> scene_id;
  std::string fidelity;
  std::vector<JobSpec> jobs;
  // What a sweep file needs (a sweep handed to an MPI launcher, sweep_launcher.hpp): the base scene as the
  // jobs were resolved from it, and the layouts, one per job in order.
  std::string base_json;
  std::vector<SweepVariant> variants;  // the layouts (an ensemble's jobs are every layout at every member)
  std::optional<std::string> ensemble_json;  // the request's "ensemble", when it has one
  // A multi-fidelity study (docs/service.md, "Studies"): `jobs` are its screening stage (stage 1); here the
  // detailed stage's rung and its candidates, every layout at the ensemble's median member (stage 2), of which
  // the layouts that can still be best are queued once the screening stage has ended.
  struct Study {
    Fidelity fidelity;
    std::vector<ParameterValue> median;
    std::vector<JobSpec> candidates;
  };
  std::optional<Study> study;
};

// Bodies are JSON text; malformed JSON is a 400, everything else that is wrong a 422.
// `stopped`, when given, is asked between the layouts checked (each builds the scene: seconds on a catchment);
// true stops the check with std::runtime_error (a server shutting down does not wait for the rest).
NewScene parse_scene_request(const std::string& body, const Limits& limits,
                             const std::function<bool()>& stopped = {});
JobSpec parse_job_request(const std::string& body, const Limits& limits, const JobQueue& queue,
                          std::optional<std::string>& body_key);
NewSweep parse_sweep_request(const std::string& body, const Limits& limits, const JobQueue& queue,
                             std::optional<std::string>& body_key);

// A scene file of FOLDER (a path relative to the scene directory) with every file it names (terrain.dem, each
// layer reference's file) made relative to the scene directory instead: "../dem/alr_5m.tif" of a scene in
// "catchment" becomes "dem/alr_5m.tif", which a request may name. The JSON text (dumped); throws
// std::invalid_argument naming the field when a name is absolute or would leave the scene directory.
std::string rebase_scene_files(const std::string& scene_json, const std::filesystem::path& folder);

// An Idempotency-Key: 1 to 200 printable ASCII characters (400 otherwise).
void check_idempotency_key(const std::string& key, const std::string& field);
// Names of series and rasters in URLs: 1 to 64 of [A-Za-z0-9_.-], no "..".
bool safe_file_name(const std::string& name);

}  // namespace runout::service
