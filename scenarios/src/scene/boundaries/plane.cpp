// Plane and flume: a bed slab under a straight surface from `origin`, `length` along x and descending at `angle`;
// a flume adds two side walls in 3D (in 2D it is a plane). Declared together: a flume is a plane with walls.
#include "../boundary_types.hpp"

namespace runout::scene_reader::boundary_detail {
namespace {

template <int D>
void make(const Fields& f, const BoundaryType& type, real dp, int layers, Walls<D>& w) {
  const Vec<D> origin = declared_vector<D>(f, type, "origin");
  const real length = declared_number(f, type, "length");
  const real width = D == 3 ? declared_number(f, type, "width") : 0.0;
  const real angle = declared_number(f, type, "angle");
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
  if (type.name == "flume" && D == 3) {
    const real wall_h = declared_number(f, type, "wall_height");
    slab(0, length, -t, 0, -t, wall_h);
    slab(0, length, width, width + t, -t, wall_h);
  }
}

std::vector<FieldSpec> bed_fields() {
  FieldSpec origin = shaped_field("origin", "vector", "the surface's upstream end");
  origin.parameters = {{"origin", "m", 0.0, -1e7, 1e7, false, false, false, "a component"}};
  return {origin,
          number_field({"length", "m", 0.0, 0.0, 1e6, true, false, true, "along the surface"}),
          number_field({"angle", "degrees", 0.0, -89.0, 89.0, false, false, false,
                        "slope, descending along +x when positive"}),
          number_field({"width", "m", 0.0, 0.0, 1e6, true, false, true, "across, from origin's y"}, 3)};
}

}  // namespace

const BoundaryType& plane_type() {
  static const BoundaryType type{"plane", "a bed `layers` rows deep under a straight surface", bed_fields(),
                                 make<2>, make<3>};
  return type;
}

const BoundaryType& flume_type() {
  static const BoundaryType type = [] {
    std::vector<FieldSpec> fields = bed_fields();
    fields.push_back(number_field(
        {"wall_height", "m", 0.0, 0.0, 1e4, true, false, true, "side walls above the bed, at y = origin and origin + width"},
        3));
    return BoundaryType{"flume", "a plane with two side walls in 3D (in 2D the same as a plane)", fields, make<2>,
                        make<3>};
  }();
  return type;
}

}  // namespace runout::scene_reader::boundary_detail
