// Block: a solid box (a pillar, a dam), particles `layers` deep inside each face.
#include "../boundary_types.hpp"

namespace runout::scene_reader::boundary_detail {
namespace {

template <int D>
void make(const Fields& f, const BoundaryType&, real dp, int layers, Walls<D>& w) {
  const OrientedBox<D> box = parse_box<D>(f);
  FaceMask<D> none{};
  w.points = solid_box_shell<D>(box, dp, layers, none);
  auto regions = solid_box_leak_regions<D>(box, dp, none, w.tag);
  w.regions.insert(w.regions.end(), regions.begin(), regions.end());
}

}  // namespace

const BoundaryType& block_type() {
  static const BoundaryType type{"block", "a solid box (a pillar, a dam): particles `layers` deep inside each face",
                                 box_fields("the block"), make<2>, make<3>};
  return type;
}

}  // namespace runout::scene_reader::boundary_detail
