#pragma once
// Boundary types: what a scene's `boundaries` entry of each type declares (its keys, ranges and docs, read by
// the scene parser, `runout schema` and docs/scene-format.md) and the wall particles it lays. One file per type
// under scene/boundaries/, listed once in boundary_types() (boundaries.cpp).
#include <string>
#include <vector>

#include "readers.hpp"

namespace runout::scene_reader {

// Wall particles of one boundary object, and its leak regions (appended to `regions`).
template <int D>
struct Walls {
  std::vector<Vec<D>> points;
  std::vector<LeakRegion<D>>& regions;
  int tag;
};

struct BoundaryType;
template <int D>
using BoundaryMaker = void (*)(const Fields& f, const BoundaryType& type, real dp, int layers, Walls<D>& w);

struct BoundaryType {
  std::string name;
  std::string doc;
  std::vector<FieldSpec> fields;  // besides those of every boundary (boundary_common_fields())
  BoundaryMaker<2> make_2d;
  BoundaryMaker<3> make_3d;
};
const std::vector<const BoundaryType*>& boundary_types();
// The keys every boundary has: type, tag, layers.
const std::vector<FieldSpec>& boundary_common_fields();

// A declared number of `type` read from f (its key, default and range from the descriptor).
inline real declared_number(const Fields& f, const BoundaryType& type, const std::string& key) {
  return read_parameter(f, field_spec(type.fields, key).parameters.front());
}
// A declared vector of `type`, one number per axis, each in the declared range.
template <int D>
Vec<D> declared_vector(const Fields& f, const BoundaryType& type, const std::string& key) {
  const ParameterSpec& p = field_spec(type.fields, key).parameters.front();
  return to_vec<D>(f.vector(key, D, p.lo, p.hi));
}
// The box keys of a tank or a block: min/max, or origin/size/angle (parse_box reads them).
std::vector<FieldSpec> box_fields(const std::string& what);

namespace boundary_detail {
const BoundaryType& tank_type();
const BoundaryType& block_type();
const BoundaryType& plane_type();
const BoundaryType& flume_type();
}  // namespace boundary_detail

}  // namespace runout::scene_reader
