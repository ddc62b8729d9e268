// Geometry in map coordinates: an inline list of [x, y] points or a layer of a vector file
// ({"layer", "name", "where", "crs"}, read by terrain's read_vector_shape and reprojected to the working CRS).
#include "readers.hpp"

#include "runout/terrain/vector.hpp"

namespace runout::scene_reader {

bool is_layer_ref(const json& v) { return v.is_object(); }

terrain::Polyline read_shape(const json& v, const std::string& field, size_t min_points, terrain::ShapeKind kind,
                             const ShapeSource& source) {
  if (!is_layer_ref(v)) return parse_polyline(v, field, min_points);
  Fields f(v, field, {"layer", "name", "where", "crs"});
  terrain::LayerRef ref;
  std::filesystem::path path = f.string("layer");
  if (path.is_relative() && !source.base_dir.empty()) path = source.base_dir / path;
  ref.path = path.string();
  ref.name = f.string_or("name", "");
  ref.where = f.string_or("where", "");
  ref.crs = f.string_or("crs", "");
  if (!source.working_crs) throw SceneError(field, "a layer needs a terrain section (its DEM sets the working CRS)");
  try {
    const terrain::VectorShape s = terrain::read_vector_shape(ref, kind, source.working_crs(), field);
    if (kind == terrain::ShapeKind::line && s.path.size() < min_points)
      throw SceneError(field, "the layer's line has " + std::to_string(s.path.size()) + " vertices; at least " +
                                  std::to_string(min_points) + " needed");
    return s.path;
  } catch (const terrain::TerrainError& e) {
    const std::string what = e.what();
    throw SceneError(e.field, what.substr(std::min(what.size(), e.field.size() + 2)));
  }
}

}  // namespace runout::scene_reader
