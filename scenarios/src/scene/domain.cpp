// The domain: by default the bounding box of all particles (and inlet buffers) plus 4h, every face closed;
// on terrain the corridor's box; a `domain` section sets min, max, periodic axes and outflow faces.
#include "readers.hpp"

#include <algorithm>

namespace runout::scene_reader {

const std::set<std::string>& domain_keys() {
  static const std::set<std::string> keys = {"min", "max", "periodic", "outflow"};
  return keys;
}

namespace {

template <int D>
void default_domain(const Build<D>& b, SolverConfig& cfg) {
  const SceneSetup<D>& setup = b.setup;
  Vec<D> lo = b.lo, hi = b.hi;  // every particle's, made or counted (make_particles)
  for (const auto& in : setup.inlets) {
    // The buffer behind the plane is part of the scene.
    const real length = inlet_buffer_layers(cfg) * b.dp;
    for (size_t lane = 0; lane < in.lanes(); ++lane)
      for (real s : {real(0), -length}) {
        Vec<D> p = in.origin + s * in.normal + (D == 3 ? (lane + 0.5) * b.dp : 0.0) * in.across;
        p[D - 1] = in.floor_at(lane, s);
        lo = lo.cwiseMin(p);
        p[D - 1] += in.depth;
        hi = hi.cwiseMax(p);
      }
  }
  const real margin = 4.0 * cfg.smoothing_length;
  for (int d = 0; d < D; ++d) {
    cfg.domain_min[d] = lo[d] - margin;
    cfg.domain_max[d] = hi[d] + margin;
  }
}

// The corridor's bounding box; faces on the DEM's edge let the flow leave the modelled area. The other
// faces stand `margin` off the box: flow past them has left the corridor, which the run's terrain check
// (every 10 steps, well under a margin of travel) removes as corridor outflow rather than a leak.
void terrain_domain(const terrain::TerrainModel& t, real dp, SolverConfig& cfg) {
  const real margin = 4.0 * cfg.smoothing_length;
  cfg.domain_min[0] = 0.0;
  cfg.domain_min[1] = 0.0;
  cfg.domain_max[0] = t.bed.nx * dp;
  cfg.domain_max[1] = t.bed.ny * dp;
  for (int d = 0; d < 2; ++d) {
    cfg.outflow[d] = t.open_faces[d];
    if (!cfg.outflow[d][0]) cfg.domain_min[d] -= margin;
    if (!cfg.outflow[d][1]) cfg.domain_max[d] += margin;
  }
}

template <int D>
void read_periodic(const Fields& dom, SolverConfig& cfg) {
  const json& p = dom.raw("periodic");
  if (!p.is_array() || p.size() != static_cast<size_t>(D))
    throw SceneError("domain.periodic", "must be an array of " + std::to_string(D) + " booleans");
  if (p[D - 1].is_boolean() && p[D - 1].get<bool>())
    throw SceneError("domain.periodic", "the vertical axis cannot be periodic (its entry must be false)");
  for (int d = 0; d < D; ++d) {
    if (!p[d].is_boolean()) throw SceneError("domain.periodic", "must be an array of booleans");
    cfg.periodic[d] = p[d].get<bool>();
    if (cfg.periodic[d] && (!dom.has("min") || !dom.has("max")))
      throw SceneError("domain.periodic", "a periodic axis needs domain.min and domain.max");
    if (cfg.periodic[d] && cfg.domain_max[d] - cfg.domain_min[d] < 6.0 * cfg.smoothing_length)
      throw SceneError("domain.periodic", "a periodic axis must be at least 6h long");
  }
}

// Every fluid particle starts inside the domain (above the top is allowed: the top is open). The particles as
// their lattices place them: the same whether the build makes them or counts them.
template <int D>
void check_inside(const Build<D>& b, const SolverConfig& cfg) {
  for (const auto& pf : b.pending) {
    for (const Vec<D>& x : pf.lattice.points) {
      for (int d = 0; d < D; ++d) {
        if (x[d] < cfg.domain_min[d] || (d < D - 1 && x[d] > cfg.domain_max[d])) {
          std::ostringstream s;
          s << "fluid particle at (";
          for (int e = 0; e < D; ++e) s << (e ? ", " : "") << x[e];
          s << ") m is outside the domain: domain.min and domain.max must contain every particle";
          throw SceneError("domain", s.str());
        }
      }
    }
  }
}

template <int D>
void read_domain_section(const Build<D>& b, SolverConfig& cfg) {
  Fields dom(b.top.raw("domain"), "domain", domain_keys());
  if (dom.has("min")) {
    const auto v = dom.vector("min", D);
    for (int d = 0; d < D; ++d) cfg.domain_min[d] = v[d];
  }
  if (dom.has("max")) {
    const auto v = dom.vector("max", D);
    for (int d = 0; d < D; ++d) {
      cfg.domain_max[d] = v[d];
      if (!(cfg.domain_max[d] > cfg.domain_min[d])) throw SceneError("domain.max", "must exceed domain.min");
    }
  }
  if (dom.has("periodic")) read_periodic<D>(dom, cfg);
  FaceMask<D> outflow = parse_faces<D>(dom, "outflow", FaceMask<D>{});
  for (int d = 0; d < D; ++d) cfg.outflow[d] = outflow[d];
  check_inside(b, cfg);
}

}  // namespace

template <int D>
void read_domain(Build<D>& b) {
  default_domain(b, b.cfg);
  if (b.tmodel) {
    terrain_domain(*b.tmodel, b.dp, b.cfg);
    if (b.top.has("domain")) throw SceneError("domain", "a terrain scene takes its domain from the corridor");
  }
  if (b.top.has("domain")) read_domain_section(b, b.cfg);
}

template void read_domain<2>(Build<2>&);
template void read_domain<3>(Build<3>&);

}  // namespace runout::scene_reader
