// The fluid section: blocks of flow (and a terrain scene's release) as lattices, where they may start, and
// the particles made from them once the speed of sound is known.
#include "readers.hpp"

#include <algorithm>
#include <array>

#include "runout/engine/eos.hpp"

namespace runout::scene_reader {

const std::set<std::string>& fluid_block_keys() {
  static const std::set<std::string> keys = {"shape", "min", "max", "origin", "size", "angle", "material"};
  return keys;
}

namespace {

template <int D>
void read_fluid_block(Build<D>& b, const json& block, const std::string& path) {
  Fields f(block, path, fluid_block_keys());
  f.string_or("shape", "box", {"box"});
  const OrientedBox<D> box = parse_box<D>(f);
  const std::string mat = f.string("material");
  if (!b.material_index.count(mat)) {
    std::vector<std::string> names;
    for (const auto& m : b.setup.materials) names.push_back(m.name);
    throw SceneError(f.at("material"), "no material named '" + mat + "' (defined: " + Fields::join(names) + ")");
  }
  Lattice<D> lat = fill_box<D>(box, b.dp);
  if (lat.points.empty()) throw SceneError(path, "block is thinner than dp = " + fmt(b.dp) + " m");
  for (const auto& p : lat.points) {
    b.fluid_top = std::max(b.fluid_top, p[D - 1] + 0.5 * b.dp);
    b.fluid_bottom = std::min(b.fluid_bottom, p[D - 1] - 0.5 * b.dp);
  }
  b.pending.push_back({std::move(lat), b.material_index[mat]});
}

template <int D>
void add_release(Build<D>& b) {
  Lattice<D> lat;
  for (size_t q = 0; q < b.tmodel->fluid.size(); ++q) {
    Vec<D> p;
    for (int d = 0; d < D; ++d) p[d] = b.tmodel->fluid[q][d];
    lat.points.push_back(p);
    lat.depth.push_back(b.tmodel->fluid_depth[q]);
    b.fluid_top = std::max(b.fluid_top, p[D - 1] + 0.5 * b.dp);
    b.fluid_bottom = std::min(b.fluid_bottom, p[D - 1] - 0.5 * b.dp);
  }
  b.pending.push_back({std::move(lat), b.material_index[b.release_material]});
}

// Fluid must start outside every wall (inside one it leaks on the first step).
template <int D>
void check_outside_walls(const Build<D>& b) {
  for (size_t k = 0; k < b.pending.size(); ++k) {
    for (const auto& p : b.pending[k].lattice.points) {
      for (const auto& r : b.setup.leak_regions) {
        if (!r.contains(p)) continue;
        std::ostringstream s;
        s << "a particle at (";
        for (int d = 0; d < D; ++d) s << (d ? ", " : "") << p[d];
        s << ") m starts inside the wall of boundaries[" << r.tag - 1 << "] ('" << b.scene.boundary_tags[r.tag]
          << "'): fluid must start outside walls";
        throw SceneError(item("fluid", k), s.str());
      }
    }
  }
}

// Blocks must not overlap. Cells of size dp: two particles closer than dp/2 are in the same or a
// neighbouring cell.
template <int D>
void check_no_overlap(const Build<D>& b) {
  const real dp = b.dp;
  std::map<std::array<long, D>, std::vector<std::pair<size_t, Vec<D>>>> cells;
  auto cell_of = [&](const Vec<D>& p) {
    std::array<long, D> c;
    for (int d = 0; d < D; ++d) c[d] = static_cast<long>(std::floor(p[d] / dp));
    return c;
  };
  for (size_t k = 0; k < b.pending.size(); ++k) {
    for (const auto& p : b.pending[k].lattice.points) {
      const auto c = cell_of(p);
      for (int o = 0; o < (D == 2 ? 9 : 27); ++o) {
        std::array<long, D> n = c;
        int rem = o;
        for (int d = 0; d < D; ++d, rem /= 3) n[d] += rem % 3 - 1;
        auto it = cells.find(n);
        if (it == cells.end()) continue;
        for (const auto& [other, q] : it->second)
          if (other != k && (q - p).norm() < 0.5 * dp)
            throw SceneError(item("fluid", k),
                             "overlaps fluid[" + std::to_string(other) + "]: fluid blocks must not overlap");
      }
      cells[c].push_back({k, p});
    }
  }
}

}  // namespace

// Fluid blocks (none needed when inlets bring the flow in).
template <int D>
void read_fluid(Build<D>& b) {
  const bool has_inlets = b.top.has("inlets");
  if (!b.top.has("fluid") && !b.tmodel && !has_inlets)
    throw SceneError("fluid", "missing (required: a non-empty array of fluid blocks, or inlets)");
  const json& fluid = b.top.has("fluid") ? b.top.raw("fluid") : json::array();
  if (!fluid.is_array() || (fluid.empty() && !b.tmodel && !has_inlets))
    throw SceneError("fluid", "must be a non-empty array of fluid blocks");
  for (size_t k = 0; k < fluid.size(); ++k) read_fluid_block(b, fluid[k], item("fluid", k));
  if (b.tmodel) add_release(b);
}

template <int D>
void check_fluid_placement(const Build<D>& b) {
  check_outside_walls(b);
  if (b.pending.size() > 1) check_no_overlap(b);
}

namespace {

template <int D>
void widen(Build<D>& b, const Vec<D>& p) {
  b.lo = b.lo.cwiseMin(p);
  b.hi = b.hi.cwiseMax(p);
}

// The bed laid whole at the start (terrain.walls = "all"), after the other walls: with the normals its tiles
// bring (the other walls' are estimated); counted only, tile by tile, for an estimate.
void lay_whole_bed(Build<3>& b, real bmass) {
  SceneSetup<3>& setup = b.setup;
  const bool make = b.make == Make::particles;
  if (make) setup.boundary_normals.assign(setup.boundary.size(), Vec<3>::Zero());
  std::vector<Vec<3>> pos, normals;
  std::vector<uint32_t> tags;
  for (int64_t t = 0; t < b.bed_source->tiles().count(); ++t) {
    const size_t first = pos.size();  // lay appends
    b.bed_source->lay(t, pos, normals, tags);
    for (size_t k = first; k < pos.size(); ++k) widen(b, pos[k]);
    b.scene.counts.walls += static_cast<int64_t>(pos.size() - first);
    if (!make) pos.clear(), normals.clear(), tags.clear();
  }
  if (!make) return;
  for (size_t k = 0; k < pos.size(); ++k) setup.boundary.add(pos[k], b.cfg.boundary_density, bmass, 0, tags[k]);
  setup.boundary_normals.insert(setup.boundary_normals.end(), normals.begin(), normals.end());
}

}  // namespace

// Fluid particles, with a hydrostatic initial density (less start-up shock than rho0 everywhere), and the
// boundary particles at the boundary density, made or only counted (Scene::counts, the same either way); then
// the count against the limit.
template <int D>
void make_particles(Build<D>& b) {
  const SolverConfig& cfg = b.cfg;
  SceneSetup<D>& setup = b.setup;
  const real dp = b.dp;
  setup.max_particles = b.scene.max_particles;
  if (b.make == Make::nothing) return;  // the screening rung's particles are checked against the limit by check_scene_model
  const bool make = b.make == Make::particles;
  ParticleCounts& n = b.scene.counts;
  for (const auto& pf : b.pending) {
    const real rho0 = setup.materials[pf.material].density;
    const TaitEOS eos(cfg.speed_of_sound, rho0, cfg.eos_gamma);
    for (size_t q = 0; q < pf.lattice.points.size(); ++q) {
      widen(b, pf.lattice.points[q]);
      if (!make) continue;
      const real p = rho0 * b.g_mag * pf.lattice.depth[q];
      const real rho = eos.density(p);
      setup.fluid.add(pf.lattice.points[q], rho, rho0 * std::pow(dp, D), pf.material, 0);
    }
    n.fluid += static_cast<int64_t>(pf.lattice.points.size());
  }
  const real bmass = cfg.boundary_density * std::pow(dp, D);
  for (const auto& [p, tag] : b.bparticles) {
    widen(b, p);
    if (make) setup.boundary.add(p, cfg.boundary_density, bmass, 0, tag);
  }
  n.walls += static_cast<int64_t>(b.bparticles.size());
  if constexpr (D == 3) {
    // The walls laid near the flow count from the start: the domain is the same as with all of them laid.
    if (b.bed_source && b.walls_near_flow) {
      if (make) setup.wall_source = b.bed_source;
      n.bed = b.bed_source->total();
      if (n.bed > 0) b.lo = b.lo.cwiseMin(b.bed_source->lowest());
    }
    if (b.bed_source && !b.walls_near_flow) lay_whole_bed(b, bmass);
  }
  const long total = static_cast<long>(n.fluid + n.walls);
  if (total > b.scene.max_particles)
    throw SceneError("dp", "the scene has " + std::to_string(total) + " particles, over limits.max_particles = " +
                               std::to_string(b.scene.max_particles));
}

template void read_fluid<2>(Build<2>&);
template void read_fluid<3>(Build<3>&);
template void check_fluid_placement<2>(const Build<2>&);
template void check_fluid_placement<3>(const Build<3>&);
template void make_particles<2>(Build<2>&);
template void make_particles<3>(Build<3>&);

}  // namespace runout::scene_reader
