// The limits section: the particle-count limit, checked on an estimate before any particle is made.
#include "readers.hpp"

#include <algorithm>

namespace runout::scene_reader {

const std::set<std::string>& limits_keys() {
  static const std::set<std::string> keys = {"max_particles"};
  return keys;
}

namespace {

// Lattice points of a box of extents e (the same floor rule as the geometry), for estimates.
real lattice_count(const std::vector<real>& e, real dp) {
  real n = 1;
  for (real x : e) n *= std::max<real>(0.0, std::floor(x / dp + 1e-9));
  return n;
}

// Estimate of the wall particles of one boundary object, from its JSON before validation (0 if unreadable:
// validation then refuses it). Tanks: the walls around the inside, open top; blocks: a shell `layers` deep;
// planes and flumes: the bed slab (and the flume's side walls).
real boundary_estimate(const json& b, int D, real dp) {
  auto num = [&](const char* key, real fallback) {
    return b.contains(key) && b[key].is_number() ? b[key].get<double>() : fallback;
  };
  auto extents = [&]() {
    std::vector<real> e(D, 0.0);
    for (int d = 0; d < D; ++d) {
      if (b.contains("size") && b["size"].is_array() && b["size"].size() > size_t(d) && b["size"][d].is_number())
        e[d] = b["size"][d].get<double>();
      else if (b.contains("min") && b.contains("max") && b["min"].is_array() && b["max"].is_array() &&
               b["min"].size() > size_t(d) && b["max"].size() > size_t(d) && b["min"][d].is_number() &&
               b["max"][d].is_number())
        e[d] = b["max"][d].get<double>() - b["min"][d].get<double>();
    }
    return e;
  };
  const real layers = std::clamp<real>(num("layers", 3), 1, 10);
  const std::string type = b.contains("type") && b["type"].is_string() ? b["type"].get<std::string>() : "";
  const real t = layers * dp;
  if (type == "tank") {
    std::vector<real> inner = extents(), outer = inner;
    for (int d = 0; d < D; ++d) outer[d] += (d == D - 1 ? 1 : 2) * t;
    return lattice_count(outer, dp) - lattice_count(inner, dp);
  }
  if (type == "block") {
    std::vector<real> outer = extents(), inner = outer;
    for (auto& x : inner) x = std::max<real>(0.0, x - 2 * t);
    return lattice_count(outer, dp) - lattice_count(inner, dp);
  }
  if (type == "plane" || type == "flume") {
    const real length = num("length", 0), width = D == 3 ? num("width", 0) : dp;
    real n = lattice_count({length, width, t}, dp);
    if (type == "flume" && D == 3) n += 2 * lattice_count({length, t, t + num("wall_height", 0)}, dp);
    return n;
  }
  return 0.0;
}

real box_volume_particles(const json& j, int D, real dp) {
  // Cheap estimate for the particle-count limit: bounding size / dp per axis.
  auto extent = [&](int d) -> real {
    if (j.contains("size") && j["size"].is_array() && j["size"].size() > static_cast<size_t>(d) &&
        j["size"][d].is_number())
      return j["size"][d].get<double>();
    if (j.contains("min") && j.contains("max") && j["min"].is_array() && j["max"].is_array() &&
        j["min"].size() > static_cast<size_t>(d) && j["max"].size() > static_cast<size_t>(d) &&
        j["min"][d].is_number() && j["max"][d].is_number())
      return j["max"][d].get<double>() - j["min"][d].get<double>();
    return 0.0;
  };
  real n = 1;
  for (int d = 0; d < D; ++d) n *= std::max<real>(0.0, extent(d) / dp);
  return n;
}

}  // namespace

template <int D>
void read_limits(Build<D>& b) {
  const json& j = b.j;
  const real dp = b.dp;
  Scene& scene = b.scene;
  Fields lim(j.contains("limits") ? j["limits"] : json::object(), "limits", limits_keys());
  scene.max_particles = lim.integer("max_particles", scene.max_particles, 1, 200'000'000);
  real est = 0;
  if (j.contains("fluid") && j["fluid"].is_array())
    for (const auto& f : j["fluid"]) est += box_volume_particles(f, D, dp);
  if (j.contains("boundaries") && j["boundaries"].is_array())
    for (const auto& w : j["boundaries"]) est += boundary_estimate(w, D, dp);
  if (est > static_cast<real>(scene.max_particles))
    throw SceneError("dp", "the geometry at dp = " + fmt(dp) + " m needs about " + fmt(std::round(est)) +
                               " particles, over limits.max_particles = " + std::to_string(scene.max_particles) +
                               " (raise dp or the limit)");
}

template void read_limits<2>(Build<2>&);
template void read_limits<3>(Build<3>&);

}  // namespace runout::scene_reader
