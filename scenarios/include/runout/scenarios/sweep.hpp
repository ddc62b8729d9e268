#pragma once
// Sweeps: a base scene plus layouts (which of its candidate structures are built) at a fidelity. A sweep
// file names either explicit variants (the flume's C0-C7 are not a full factorial) or a factorial over
// named structures (the catchment's G0-G7: every subset of Dam1-Dam3, numbered as in the study).
// docs/scene-format.md ("Sweeps") describes the file.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace runout {

// Fidelity: a named preset of dp and the numerics that go with it, or an explicit dp. A scene may define
// its presets under "fidelity"; without them draft = 2 dp, standard = dp, fine = dp / 2 of the scene's dp.
struct Fidelity {
  std::string name = "standard";  // draft | standard | fine | custom
  std::optional<double> dp;       // explicit dp (name "custom")
};
const std::vector<std::string>& fidelity_names();

// One value an ensemble member gives a number of the base scene: a JSON pointer ("/materials/0/friction_angle")
// and the value written there.
struct ParameterValue {
  std::string pointer;
  double value = 0;
};

struct SweepVariant {
  std::string name;                     // "C3", "G5"; an ensemble's member "G5-e017"
  std::vector<std::string> structures;  // candidate structures of the base scene that are built
  std::vector<ParameterValue> parameters;  // an ensemble member's values (none for a plain layout)
  std::string layout;                   // the layout's name ("G5"); the variant's own name when no ensemble
  int member = -1;                      // the ensemble member's index; -1: no ensemble
};

// An ensemble (docs/scene-format.md, "Ensembles"): numbers of the base scene varied over members, each member run
// with every layout. Listed values and ranges make a grid; distributions are sampled by a Latin hypercube of
// `members` points from `seed`, so an ensemble repeats bit for bit; members = grid points x samples.
struct EnsembleParameter {
  std::string pointer;          // JSON pointer into the base scene; the number there is replaced
  std::vector<double> values;   // a list, or a range's evenly spaced points (the grid's axis)
  std::string distribution;     // "" (grid) | uniform | normal | lognormal | triangular
  double a = 0, b = 0, c = 0;   // uniform min max; normal mean sd; lognormal median sd_log; triangular min mode max
};
struct Ensemble {
  std::vector<EnsembleParameter> parameters;
  size_t samples = 1;   // Latin-hypercube points (1 without distributions)
  uint64_t seed = 1;
  // The max pressures whose exceedance probability is mapped (ensemble_summary.hpp), [Pa], ascending.
  std::vector<double> pressure_thresholds_pa = {3.0e3, 30.0e3};
};

struct Sweep {
  std::string name;
  std::filesystem::path base_path;  // the base scene file
  std::string base_json;            // its text
  Fidelity fidelity;                // the sweep's default (the CLI may override)
  std::vector<SweepVariant> variants;
  std::optional<Ensemble> ensemble;  // the sweep file's "ensemble", when it has one
};

// Parses the sweep file's "ensemble" object (throws SceneError naming the field, e.g.
// "ensemble.parameters[1].sd"); each pointer must name a number of `base`.
Ensemble parse_ensemble(const std::string& ensemble_json, const std::string& base_json);
// A sampled parameter's value at probability u in (0, 1) (its distribution's quantile, Boost.Math).
double parameter_quantile(const EnsembleParameter& p, double u);
// The members' values, grid-major: member k = grid point k / samples, sample k % samples.
std::vector<std::vector<ParameterValue>> ensemble_members(const Ensemble& e);
// An ensemble member's variant name: LAYOUT-eNNN, the index zero-padded to at least 3 digits and to the width of
// the last member's (members - 1).
std::string member_variant_name(const std::string& layout, size_t member, size_t members);
// Every layout with every member, member by member (a member's layouts finish together, so a partial ensemble
// still compares layouts), named member_variant_name; each carries its member's values (ensemble_members).
// Nothing is checked.
std::vector<SweepVariant> ensemble_variants(const std::vector<SweepVariant>& layouts,
                                            const std::vector<std::vector<ParameterValue>>& members);
// The members holding each parameter's smallest and largest value, ascending: those a sweep checks as scenes.
std::vector<size_t> extreme_members(const std::vector<std::vector<ParameterValue>>& members);
// n points of a d-dimensional Latin hypercube in (0, 1): in each dimension, one point in each of the n strata
// [k/n, (k+1)/n). From std::mt19937_64, with the draws converted by hand so every platform gives the same points.
std::vector<std::vector<double>> latin_hypercube(size_t n, size_t d, uint64_t seed);

// Parses and validates a sweep (throws SceneError naming the field): the base scene must parse, every
// variant's structures must be candidates of the base scene, names unique.
Sweep parse_sweep(const std::string& json_text, const std::filesystem::path& base_dir = {});
Sweep load_sweep(const std::filesystem::path& path);

// All subsets of `names`, ordered by size and then in the order of `names` (none; each alone; pairs;
// ...; all), named prefix + index: for Dam1-Dam3 that is G0 none, G1 Dam1, G2 Dam2, G3 Dam3, G4 Dam1+Dam2,
// G5 Dam1+Dam3, G6 Dam2+Dam3, G7 all three.
std::vector<SweepVariant> factorial_variants(const std::vector<std::string>& names, const std::string& prefix);

// The scene JSON of one variant at a fidelity: the base with only the variant's structures kept, dp and
// the preset's numerics applied, "fidelity" removed, named "<base name>/<variant>". Validated by
// parse_scene when run.
std::string resolve_variant(const std::string& base_json, const SweepVariant& variant, const Fidelity& fidelity);
// The same on a parsed base (the service's job path, which parses a request once).
nlohmann::json resolve_variant(const nlohmann::json& base, const SweepVariant& variant, const Fidelity& fidelity);

// One scene's JSON at a fidelity, resolved as resolve_variant resolves a layout (dp and the preset's numerics
// applied, "fidelity" removed) but with its structures and name as written: `runout run --fidelity/--dp`.
// Throws SceneError on malformed JSON. Validated by parse_scene when run.
std::string resolve_scene(const std::string& scene_json, const Fidelity& fidelity);

// The run's identity: SHA-256 over the resolved scene (canonical JSON, without its prose `description`), the
// hashes of the files it reads (the DEM), the fidelity and the program version. Same inputs, same hash: a stored run is not recomputed.
struct Manifest {
  std::string hash;
  std::string json;  // what was hashed, for the record
};
Manifest make_manifest(const std::string& resolved_scene_json, const std::filesystem::path& base_dir,
                       const Fidelity& fidelity);
Manifest make_manifest(const nlohmann::json& resolved_scene, const std::filesystem::path& base_dir,
                       const Fidelity& fidelity);

}  // namespace runout
