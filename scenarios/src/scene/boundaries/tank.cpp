// Tank: the box is the inside; walls are laid outside its closed faces.
#include "../boundary_types.hpp"

namespace runout::scene_reader::boundary_detail {
namespace {

template <int D>
void make(const Fields& f, const BoundaryType&, real dp, int layers, Walls<D>& w) {
  FaceMask<D> open{};
  open[D - 1][1] = true;
  open = parse_faces<D>(f, "open", f.has("open") ? FaceMask<D>{} : open);
  const OrientedBox<D> inner = parse_box<D>(f);
  w.points = tank_walls<D>(inner, dp, layers, open);
  auto regions = tank_leak_regions<D>(inner, dp, layers, open, w.tag);
  w.regions.insert(w.regions.end(), regions.begin(), regions.end());
}

}  // namespace

const BoundaryType& tank_type() {
  static const BoundaryType type = [] {
    std::vector<FieldSpec> fields = box_fields("the inside");
    FieldSpec open = shaped_field("open", "faces",
                                  "faces without a wall, replacing the default: x-, x+, y-, y+ (z-, z+ in 3D), top, "
                                  "bottom (in 2D y- and y+ are the bottom and the top)",
                                  false);
    open.default_text = "[\"top\"]";
    fields.push_back(open);
    return BoundaryType{"tank", "the box is the inside; walls `layers` deep outside its closed faces", fields,
                        make<2>, make<3>};
  }();
  return type;
}

}  // namespace runout::scene_reader::boundary_detail
