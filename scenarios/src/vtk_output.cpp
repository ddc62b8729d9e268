#include "runout/scenarios/vtk_output.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "runout/terrain/terrain.hpp"

namespace runout {
namespace {

namespace fs = std::filesystem;
static_assert(std::endian::native == std::endian::little, "the files declare byte_order=\"LittleEndian\"");

template <class T>
constexpr const char* vtk_type_name() {
  if constexpr (std::is_same_v<T, float>) return "Float32";
  else if constexpr (std::is_same_v<T, double>) return "Float64";
  else if constexpr (std::is_same_v<T, int32_t>) return "Int32";
  else if constexpr (std::is_same_v<T, uint8_t>) return "UInt8";
  else static_assert(sizeof(T) == 0, "no VTK type for this C++ type");
}

// Written to a temporary name and renamed, so a killed run never leaves a half-written file (ParaView may be
// reading the index while the run goes on).
void write_file(const fs::path& path, const std::string& bytes) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write '" + tmp.string() + "'");
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw std::runtime_error("write failed for '" + tmp.string() + "'");
  }
  fs::rename(tmp, path);
}

// One VTK XML file with raw appended data: each array's <DataArray> element points at its block in the
// appended section (offset from the byte after '_'), a UInt64 byte count and then the values.
class AppendedFile {
 public:
  template <class T>
  std::string array(const std::string& name, int components, const std::vector<T>& values) {
    std::ostringstream e;
    e << "<DataArray type=\"" << vtk_type_name<T>() << "\" Name=\"" << name << "\" NumberOfComponents=\""
      << components << "\" NumberOfTuples=\"" << values.size() / components << "\" format=\"appended\" offset=\""
      << data_.size() << "\"/>\n";
    const uint64_t bytes = values.size() * sizeof(T);
    data_.append(reinterpret_cast<const char*>(&bytes), sizeof bytes);
    data_.append(reinterpret_cast<const char*>(values.data()), bytes);
    return e.str();
  }
  // `body` is the dataset element (<PolyData>...</PolyData>) made of this file's arrays.
  void write(const fs::path& path, const std::string& type, const std::string& body) const {
    std::string out = "<?xml version=\"1.0\"?>\n<VTKFile type=\"" + type +
                      "\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n" + body +
                      "<AppendedData encoding=\"raw\">\n_";
    out += data_;
    out += "\n</AppendedData>\n</VTKFile>\n";
    write_file(path, out);
  }

 private:
  std::string data_;
};

// Particles as the snapshot files hold them: one vertex each and the same point data in every file (so
// ParaView can append frames and walls).
struct ParticleColumns {
  std::vector<double> points;  // x y z per particle
  std::vector<float> velocity;
  std::vector<float> density, pressure, viscosity;
  std::vector<int32_t> type, tag;  // type 0 flow, 1 wall; tag: the flow's material, the wall's boundary tag
  std::vector<int32_t> id;         // the particle's stable id (the arrays are re-sorted by cell every step)

  size_t size() const { return density.size(); }
  // (x, 0, z) in 2D, as the scene's x-z plane.
  template <int D>
  void add(const ParticleArrays<D>& p, size_t i, const double origin[3], bool moving) {
    points.insert(points.end(), {p.pos[0][i] + origin[0], D == 3 ? p.pos[1][i] + origin[1] : 0.0,
                                 p.pos[D - 1][i] + origin[2]});
    velocity.insert(velocity.end(), {moving ? static_cast<float>(p.vel[0][i]) : 0.f,
                                     moving && D == 3 ? static_cast<float>(p.vel[1][i]) : 0.f,
                                     moving ? static_cast<float>(p.vel[D - 1][i]) : 0.f});
    density.push_back(static_cast<float>(p.rho[i]));
    id.push_back(i < p.id.size() ? static_cast<int32_t>(p.id[i]) : -1);
  }
};

std::string polydata(AppendedFile& f, const ParticleColumns& c, bool float64_points, const std::string& field_data) {
  const size_t n = c.size();
  std::vector<int32_t> connectivity(n), offsets(n);
  for (size_t i = 0; i < n; ++i) connectivity[i] = static_cast<int32_t>(i), offsets[i] = static_cast<int32_t>(i + 1);
  std::ostringstream o;
  o << "<PolyData>\n" << field_data << "<Piece NumberOfPoints=\"" << n << "\" NumberOfVerts=\"" << n
    << "\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n"
    << "<PointData Scalars=\"pressure\" Vectors=\"velocity\">\n"
    << f.array("velocity", 3, c.velocity) << f.array("density", 1, c.density) << f.array("pressure", 1, c.pressure)
    << f.array("effective_viscosity", 1, c.viscosity) << f.array("type", 1, c.type)
    << f.array("material_or_tag", 1, c.tag) << f.array("id", 1, c.id) << "</PointData>\n<Points>\n";
  if (float64_points) o << f.array("Points", 3, c.points);
  else o << f.array("Points", 3, std::vector<float>(c.points.begin(), c.points.end()));
  o << "</Points>\n<Verts>\n" << f.array("connectivity", 1, connectivity) << f.array("offsets", 1, offsets)
    << "</Verts>\n</Piece>\n</PolyData>\n";
  return o.str();
}

// The wall particles that exist for the whole run; on terrain without the bed (tag 1), which dem.vts shows.
template <int D>
void write_walls(const fs::path& path, const Scene& scene, const double origin[3]) {
  const ParticleArrays<D>& b = std::get<SceneSetup<D>>(scene.setup).boundary;
  ParticleColumns c;
  for (size_t i = 0; i < b.size(); ++i) {
    if (scene.terrain && b.tag[i] == 1) continue;
    c.add(b, i, origin, false);
    c.pressure.push_back(0.f);
    c.viscosity.push_back(0.f);
    c.type.push_back(1);
    c.tag.push_back(static_cast<int32_t>(b.tag[i]));
  }
  AppendedFile f;
  const std::string body = polydata(f, c, scene.terrain != nullptr, "");
  f.write(path, "PolyData", body);
}

// The DEM cells over the corridor's box (the window the rasters cover) as a StructuredGrid of their centres,
// y growing northwards. Point z is the ground the flow runs on: the bed after structures (regraded areas,
// basins) inside the corridor, the DEM outside; point data `elevation` is the DEM as loaded and `corridor`
// 1 inside. Cells with a corner off the DEM's data or no corner in the corridor are hidden (vtkGhostType).
// False when the window is narrower than two cells.
bool write_dem(const fs::path& path, const terrain::TerrainModel& tm) {
  const terrain::Grid window = terrain::InundationGrid(tm).terrain();
  const int nx = window.nx, ny = window.ny;
  if (nx < 2 || ny < 2) return false;
  double lowest = std::numeric_limits<double>::infinity();
  for (float v : window.values)
    if (!std::isnan(v)) lowest = std::min(lowest, static_cast<double>(v));
  const size_t np = static_cast<size_t>(nx) * ny;
  std::vector<double> points(3 * np);
  std::vector<float> elevation(np);
  std::vector<int32_t> corridor(np);
  for (int r = 0; r < ny; ++r) {
    const int j = ny - 1 - r;  // DEM rows run north to south
    for (int i = 0; i < nx; ++i) {
      const size_t k = static_cast<size_t>(r) * nx + i;
      const double x = window.cx(i), y = window.cy(j);
      const double bed = tm.bed_at(x - tm.origin_x, y - tm.origin_y);
      elevation[k] = window.at(i, j);
      corridor[k] = !std::isnan(bed);
      const double z = corridor[k] ? bed : std::isnan(elevation[k]) ? lowest : elevation[k];
      points[3 * k] = x, points[3 * k + 1] = y, points[3 * k + 2] = z;
    }
  }
  constexpr uint8_t kHiddenCell = 32;  // vtkDataSetAttributes::HIDDENCELL
  std::vector<uint8_t> ghost(static_cast<size_t>(nx - 1) * (ny - 1), kHiddenCell);
  for (int r = 0; r + 1 < ny; ++r)
    for (int i = 0; i + 1 < nx; ++i) {
      bool data = true, inside = false;
      for (const size_t k : {static_cast<size_t>(r) * nx + i, static_cast<size_t>(r) * nx + i + 1,
                             static_cast<size_t>(r + 1) * nx + i, static_cast<size_t>(r + 1) * nx + i + 1}) {
        data = data && !std::isnan(elevation[k]);
        inside = inside || corridor[k];
      }
      if (data && inside) ghost[static_cast<size_t>(r) * (nx - 1) + i] = 0;
    }
  AppendedFile f;
  std::ostringstream o;
  const std::string extent = "0 " + std::to_string(nx - 1) + " 0 " + std::to_string(ny - 1) + " 0 0";
  o << "<StructuredGrid WholeExtent=\"" << extent << "\">\n<Piece Extent=\"" << extent << "\">\n"
    << "<PointData Scalars=\"elevation\">\n" << f.array("elevation", 1, elevation) << f.array("corridor", 1, corridor)
    << "</PointData>\n<CellData>\n" << f.array("vtkGhostType", 1, ghost) << "</CellData>\n<Points>\n"
    << f.array("Points", 3, points) << "</Points>\n</Piece>\n</StructuredGrid>\n";
  f.write(path, "StructuredGrid", o.str());
  return true;
}

std::string frame_name(size_t index) {
  std::ostringstream name;
  name << "snapshot_" << std::setw(4) << std::setfill('0') << index << ".vtp";
  return name.str();
}

}  // namespace

template <int D>
SnapshotWriter<D>::SnapshotWriter(const Scene& scene, fs::path dir) : dir_(std::move(dir)) {
  fs::create_directories(dir_);
  if (scene.terrain) {
    map_coordinates_ = true;
    origin_[0] = scene.terrain->origin_x;
    origin_[1] = scene.terrain->origin_y;
  }
  write_walls<D>(dir_ / "walls.vtp", scene, origin_);
  if (scene.terrain) has_dem_ = write_dem(dir_ / "dem.vts", *scene.terrain);
  write_index();
}

template <int D>
void SnapshotWriter<D>::resume_after(std::vector<double> times) {
  times_ = std::move(times);
  write_index();
}

template <int D>
void SnapshotWriter<D>::write_frame(const Solver<D>& s) {
  const auto& f = s.fluid();
  const auto& p = s.fluid_pressure();
  const auto& mu = s.fluid_effective_viscosity();
  ParticleColumns c;
  for (size_t i = 0; i < f.size(); ++i) {
    c.add(f, i, origin_, true);
    c.pressure.push_back(i < p.size() ? static_cast<float>(p[i]) : 0.f);
    c.viscosity.push_back(i < mu.size() ? static_cast<float>(mu[i]) : 0.f);
    c.type.push_back(0);
    c.tag.push_back(f.material[i]);
  }
  AppendedFile file;
  const double time = s.time();
  const std::string field = "<FieldData>\n" + file.array("TimeValue", 1, std::vector<double>{time}) + "</FieldData>\n";
  const std::string body = polydata(file, c, map_coordinates_, field);
  file.write(dir_ / frame_name(times_.size()), "PolyData", body);
  times_.push_back(time);
  write_index();
}

// ParaView's collection reader reads, at a time, the data sets whose timestep matches it; one without a
// timestep is never read, so the static parts are listed again beside every frame.
template <int D>
void SnapshotWriter<D>::write_index() const {
  std::ostringstream o;
  o << std::setprecision(std::numeric_limits<double>::max_digits10);
  o << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
       "<Collection>\n";
  for (size_t k = 0; k < times_.size(); ++k) {
    const double t = times_[k];
    o << "<DataSet timestep=\"" << t << "\" part=\"0\" name=\"flow\" file=\"" << frame_name(k) << "\"/>\n"
      << "<DataSet timestep=\"" << t << "\" part=\"1\" name=\"walls\" file=\"walls.vtp\"/>\n";
    if (has_dem_) o << "<DataSet timestep=\"" << t << "\" part=\"2\" name=\"dem\" file=\"dem.vts\"/>\n";
  }
  o << "</Collection>\n</VTKFile>\n";
  write_file(dir_ / "snapshots.pvd", o.str());
}

template class SnapshotWriter<2>;
template class SnapshotWriter<3>;

}  // namespace runout
