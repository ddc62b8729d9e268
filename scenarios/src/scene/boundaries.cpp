// The boundaries section: tanks, solid blocks, planes and flumes as wall particles with their leak regions;
// on terrain the ground and the walled structures come first (tag 1 the ground, then one per structure).
#include "readers.hpp"

#include <algorithm>

namespace runout::scene_reader {
namespace {

// Wall particles of one boundary object, and its leak regions (appended to `regions`).
template <int D>
struct Walls {
  std::vector<Vec<D>> points;
  std::vector<LeakRegion<D>>& regions;
  int tag;
};

template <int D>
void read_tank(const Fields& f, real dp, int layers, Walls<D>& w) {
  FaceMask<D> open{};
  open[D - 1][1] = true;
  open = parse_faces<D>(f, "open", f.has("open") ? FaceMask<D>{} : open);
  const OrientedBox<D> inner = parse_box<D>(f);
  w.points = tank_walls<D>(inner, dp, layers, open);
  auto regions = tank_leak_regions<D>(inner, dp, layers, open, w.tag);
  w.regions.insert(w.regions.end(), regions.begin(), regions.end());
}

template <int D>
void read_block(const Fields& f, real dp, int layers, Walls<D>& w) {
  const OrientedBox<D> box = parse_box<D>(f);
  FaceMask<D> none{};
  w.points = solid_box_shell<D>(box, dp, layers, none);
  auto regions = solid_box_leak_regions<D>(box, dp, none, w.tag);
  w.regions.insert(w.regions.end(), regions.begin(), regions.end());
}

// A plane or a flume: a bed slab under a surface line starting at `origin` (and a flume's side walls).
template <int D>
void read_bed(const Fields& f, const std::string& type, real dp, int layers, Walls<D>& w) {
  const Vec<D> origin = to_vec<D>(f.vector("origin", D));
  const real length = f.number("length", 0.0, 1e6, true);
  const real width = D == 3 ? f.number("width", 0.0, 1e6, true) : 0.0;
  const real angle = f.number_or("angle", 0.0, -89.0, 89.0);
  const real t = layers * dp;
  FaceMask<D> none{};
  auto slab = [&](real x0, real x1, real y0, real y1, real z0, real z1) {
    OrientedBox<D> b;
    b.angle_deg = angle;
    Vec<D> lo = Vec<D>::Zero();
    lo[0] = x0;
    lo[D - 1] = z0;
    if constexpr (D == 3) lo[1] = y0;
    b.origin = origin;
    b.origin = b.to_world(lo);
    b.size[0] = x1 - x0;
    b.size[D - 1] = z1 - z0;
    if constexpr (D == 3) b.size[1] = y1 - y0;
    auto p = solid_box_shell<D>(b, dp, 1000, none);
    w.points.insert(w.points.end(), p.begin(), p.end());
    auto regions = solid_box_leak_regions<D>(b, dp, none, w.tag);
    w.regions.insert(w.regions.end(), regions.begin(), regions.end());
  };
  slab(0, length, 0, width, -t, 0);
  if (type == "flume" && D == 3) {
    const real wall_h = f.number("wall_height", 0.0, 1e4, true);
    slab(0, length, -t, 0, -t, wall_h);
    slab(0, length, width, width + t, -t, wall_h);
  }
}

// The keys a boundary of `type` accepts in a scene of dimension D.
std::set<std::string> boundary_keys(const std::string& type, int D) {
  std::set<std::string> allowed = {"type", "tag", "layers", "angle"};
  if (type == "tank" || type == "block") allowed.insert({"min", "max", "origin", "size"});
  if (type == "tank") allowed.insert("open");
  if (type == "plane" || type == "flume") allowed.insert({"origin", "length"});
  if (D == 3 && (type == "plane" || type == "flume")) allowed.insert("width");
  if (D == 3 && type == "flume") allowed.insert("wall_height");
  return allowed;
}

template <int D>
void read_boundary(Build<D>& b, const json& j, size_t k) {
  const std::string path = item("boundaries", k);
  const std::string type = Fields(j, path,
                                  {"type", "tag", "min", "max", "origin", "size", "angle", "layers", "open", "length",
                                   "width", "wall_height"})
                               .string("type", {"tank", "block", "plane", "flume"});
  Fields f(j, path, boundary_keys(type, D));
  const std::string tag_name = f.string_or("tag", type + std::to_string(k));
  const uint32_t tag = static_cast<uint32_t>(b.scene.boundary_tags.size());
  b.scene.boundary_tags.push_back(tag_name);
  const int layers = static_cast<int>(f.integer("layers", 3, 1, 10));
  Walls<D> w{{}, b.setup.leak_regions, static_cast<int>(tag)};
  if (type == "tank") read_tank(f, b.dp, layers, w);
  else if (type == "block") read_block(f, b.dp, layers, w);
  else read_bed(f, type, b.dp, layers, w);
  if (w.points.empty()) throw SceneError(path, "makes no boundary particles at dp = " + fmt(b.dp) + " m");
  for (const auto& p : w.points) {
    b.bparticles.push_back({p, tag});
    b.bottom = std::min(b.bottom, p[D - 1]);
  }
}

// Tag 1 is the ground (the bed's wall source); each walled structure has its own tag, in order.
template <int D>
void add_terrain_walls(Build<D>& b) {
  b.scene.boundary_tags.push_back("terrain");
  for (const auto& st : b.tmodel->structures)
    if (st.tag) b.scene.boundary_tags.push_back(st.name);
  for (size_t q = 0; q < b.tmodel->boundary.size(); ++q) {
    Vec<D> p;
    for (int d = 0; d < D; ++d) p[d] = b.tmodel->boundary[q][d];
    b.bparticles.push_back({p, b.tmodel->boundary_tag[q]});
  }
  b.bed_source = terrain::bed_wall_source(b.tmodel);
}

}  // namespace

template <int D>
void read_boundaries(Build<D>& b) {
  b.scene.boundary_tags = {""};
  b.bottom = b.fluid_bottom;
  if (b.tmodel) add_terrain_walls(b);
  if (!b.top.has("boundaries")) return;
  const json& bs = b.top.raw("boundaries");
  if (!bs.is_array()) throw SceneError("boundaries", "must be an array of boundary objects");
  for (size_t k = 0; k < bs.size(); ++k) read_boundary(b, bs[k], k);
}

template void read_boundaries<2>(Build<2>&);
template void read_boundaries<3>(Build<3>&);

}  // namespace runout::scene_reader
