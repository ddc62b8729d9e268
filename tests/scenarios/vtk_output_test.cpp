// The ParaView files read back without VTK: the XML header parsed (GDAL's CPL parser), each array followed
// through its appended offset and UInt64 byte count, and the values checked against the solver's particles,
// the scene's walls and the DEM; the .pvd index against the frames on disk.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

#include <cpl_minixml.h>
#include <gdal.h>  // the include links GDAL to this test (tests/CMakeLists.txt): its CPL parser reads the XML
#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/vtk_output.hpp"
#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-vtk-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

struct XmlDeleter {
  void operator()(CPLXMLNode* n) const { CPLDestroyXMLNode(n); }
};
using Xml = std::unique_ptr<CPLXMLNode, XmlDeleter>;

// The element named `name` at or under `n` (depth first), or nullptr.
const CPLXMLNode* find_element(const CPLXMLNode* n, const std::string& name, const std::string& attr_name = "",
                               const std::string& attr_value = "") {
  for (; n; n = n->psNext) {
    if (n->eType != CXT_Element) continue;
    if (name == n->pszValue && (attr_name.empty() || attr_value == CPLGetXMLValue(n, attr_name.c_str(), "")))
      return n;
    if (const CPLXMLNode* c = find_element(n->psChild, name, attr_name, attr_value)) return c;
  }
  return nullptr;
}

std::vector<const CPLXMLNode*> elements(const CPLXMLNode* parent, const std::string& name) {
  std::vector<const CPLXMLNode*> out;
  for (const CPLXMLNode* c = parent ? parent->psChild : nullptr; c; c = c->psNext)
    if (c->eType == CXT_Element && name == c->pszValue) out.push_back(c);
  return out;
}

// A VTK XML file with raw appended data: its header parsed, and the appended bytes.
struct VtkFile {
  Xml xml;
  std::string bytes;
  size_t base = 0;  // the byte after '_'

  explicit VtkFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
    const std::string tag = "<AppendedData encoding=\"raw\">";
    const size_t at = bytes.find(tag);
    if (at == std::string::npos) throw std::runtime_error(p.string() + ": no raw AppendedData");
    base = bytes.find('_', at + tag.size());
    if (base == std::string::npos) throw std::runtime_error(p.string() + ": no '_' opening the appended data");
    ++base;
    // The binary block is not XML: parse what precedes it, closed.
    const std::string header = bytes.substr(0, at + tag.size()) + "</AppendedData></VTKFile>";
    xml.reset(CPLParseXMLString(header.c_str()));
    if (!xml) throw std::runtime_error(p.string() + ": header is not XML");
    if (bytes.compare(bytes.size() - 28, 28, "\n</AppendedData>\n</VTKFile>\n") != 0)
      throw std::runtime_error(p.string() + ": does not end with </AppendedData></VTKFile>");
  }
  const CPLXMLNode* root() const { return find_element(xml.get(), "VTKFile"); }
  std::string attr(const std::string& element, const std::string& name) const {
    const CPLXMLNode* e = find_element(xml.get(), element);
    return e ? CPLGetXMLValue(e, name.c_str(), "") : "";
  }
  // The array's values, after checking its declared type, format, tuple count and block size.
  template <class T>
  std::vector<T> array(const std::string& name, const std::string& type, int components = 1) const {
    const CPLXMLNode* e = find_element(xml.get(), "DataArray", "Name", name);
    if (!e) throw std::runtime_error("no array " + name);
    EXPECT_EQ(std::string(CPLGetXMLValue(e, "type", "")), type) << name;
    EXPECT_EQ(std::string(CPLGetXMLValue(e, "format", "")), "appended") << name;
    EXPECT_EQ(std::atoi(CPLGetXMLValue(e, "NumberOfComponents", "1")), components) << name;
    const size_t offset = std::stoull(CPLGetXMLValue(e, "offset", "0"));
    uint64_t count = 0;
    if (base + offset + 8 > bytes.size()) throw std::runtime_error(name + ": offset past the end");
    std::memcpy(&count, bytes.data() + base + offset, 8);
    const size_t tuples = std::stoull(CPLGetXMLValue(e, "NumberOfTuples", "0"));
    EXPECT_EQ(count, tuples * components * sizeof(T)) << name;
    if (base + offset + 8 + count > bytes.size()) throw std::runtime_error(name + ": block past the end");
    std::vector<T> v(count / sizeof(T));
    std::memcpy(v.data(), bytes.data() + base + offset + 8, count);
    return v;
  }
};

// The index: per part, (timestep, file) in the order listed.
std::map<std::string, std::vector<std::pair<double, std::string>>> read_index(const fs::path& pvd) {
  std::ifstream in(pvd);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  Xml xml(CPLParseXMLString(text.c_str()));
  EXPECT_TRUE(xml) << "snapshots.pvd is not XML";
  std::map<std::string, std::vector<std::pair<double, std::string>>> parts;
  const CPLXMLNode* file = find_element(xml.get(), "VTKFile");
  EXPECT_TRUE(file && std::string(CPLGetXMLValue(file, "type", "")) == "Collection");
  for (const CPLXMLNode* d : elements(find_element(xml.get(), "Collection"), "DataSet"))
    parts[CPLGetXMLValue(d, "name", "")].push_back({std::stod(CPLGetXMLValue(d, "timestep", "nan")),
                                                     CPLGetXMLValue(d, "file", "")});
  return parts;
}

// The frame's particles against the solver's (values stored as Float32 unless the test says otherwise).
template <int D>
void expect_frame_matches(const VtkFile& f, const Solver<D>& s, const double origin[3], bool float64_points) {
  const auto& fl = s.fluid();
  const size_t n = fl.size();
  ASSERT_GT(n, 0u);
  EXPECT_EQ(f.attr("Piece", "NumberOfPoints"), std::to_string(n));
  EXPECT_EQ(f.attr("Piece", "NumberOfVerts"), std::to_string(n));
  EXPECT_EQ(f.array<double>("TimeValue", "Float64"), std::vector<double>{s.time()});
  std::vector<double> pts;
  if (float64_points) {
    pts = f.array<double>("Points", "Float64", 3);
  } else {
    for (float x : f.array<float>("Points", "Float32", 3)) pts.push_back(x);
  }
  const auto vel = f.array<float>("velocity", "Float32", 3);
  const auto rho = f.array<float>("density", "Float32");
  const auto p = f.array<float>("pressure", "Float32");
  const auto mu = f.array<float>("effective_viscosity", "Float32");
  const auto type = f.array<int32_t>("type", "Int32");
  const auto mat = f.array<int32_t>("material_or_tag", "Int32");
  const auto id = f.array<int32_t>("id", "Int32");
  const auto conn = f.array<int32_t>("connectivity", "Int32");
  const auto offs = f.array<int32_t>("offsets", "Int32");
  ASSERT_EQ(pts.size(), 3 * n);
  ASSERT_EQ(rho.size(), n);
  ASSERT_EQ(conn.size(), n);
  ASSERT_EQ(offs.size(), n);
  EXPECT_EQ(offs.back(), static_cast<int32_t>(n));
  for (size_t i : {size_t{0}, n / 3, n / 2, n - 1}) {
    const double want[3] = {fl.pos[0][i] + origin[0], D == 3 ? fl.pos[1][i] + origin[1] : 0.0,
                            fl.pos[D - 1][i] + origin[2]};
    for (int d = 0; d < 3; ++d) {
      if (float64_points) {
        EXPECT_DOUBLE_EQ(pts[3 * i + d], want[d]) << "particle " << i << " axis " << d;
      } else {
        EXPECT_FLOAT_EQ(static_cast<float>(pts[3 * i + d]), static_cast<float>(want[d])) << "particle " << i;
      }
    }
    EXPECT_FLOAT_EQ(vel[3 * i], static_cast<float>(fl.vel[0][i]));
    EXPECT_FLOAT_EQ(vel[3 * i + 2], static_cast<float>(fl.vel[D - 1][i]));
    EXPECT_FLOAT_EQ(rho[i], static_cast<float>(fl.rho[i]));
    EXPECT_FLOAT_EQ(p[i], static_cast<float>(s.fluid_pressure()[i]));
    EXPECT_FLOAT_EQ(mu[i], static_cast<float>(s.fluid_effective_viscosity()[i]));
    EXPECT_EQ(type[i], 0);
    EXPECT_EQ(mat[i], fl.material[i]);
    EXPECT_EQ(id[i], static_cast<int32_t>(fl.id[i]));  // the stable id that leak and NaN messages name
    EXPECT_EQ(conn[i], static_cast<int32_t>(i));
  }
}

// The index lists every frame once, by increasing time equal to the frame's TimeValue, the walls (and the
// DEM when `dem`) beside each, and every file it names exists.
void expect_index_lists(const fs::path& dir, int frames, bool dem) {
  auto parts = read_index(dir / "snapshots.pvd");
  const auto& flow = parts["flow"];
  ASSERT_EQ(flow.size(), static_cast<size_t>(frames));
  for (size_t k = 0; k < flow.size(); ++k) {
    if (k > 0) {
      EXPECT_GT(flow[k].first, flow[k - 1].first);
    }
    ASSERT_TRUE(fs::exists(dir / flow[k].second)) << flow[k].second;
    EXPECT_EQ(VtkFile(dir / flow[k].second).array<double>("TimeValue", "Float64"), std::vector<double>{flow[k].first});
  }
  ASSERT_EQ(parts["walls"].size(), flow.size());
  EXPECT_EQ(parts["dem"].size(), dem ? flow.size() : 0u);
  for (const auto& part : {"walls", "dem"})
    for (size_t k = 0; k < parts[part].size(); ++k) {
      EXPECT_EQ(parts[part][k].first, flow[k].first) << part;
      EXPECT_TRUE(fs::exists(dir / parts[part][k].second)) << parts[part][k].second;
    }
}

// The 2D dam break at dp = 2 cm (a tank and a water column).
Scene small_dam_break(double duration) {
  std::ifstream in(kSource / "scenarios/validation/dam_break_2d.json");
  json s = json::parse(in);
  s["dp"] = 0.02;
  s["duration"] = duration;
  return parse_scene(s.dump());
}

// The flume at its draft dp with one check dam (wall particles that are not the bed), no monitors.
Scene small_flume() {
  std::ifstream in(kSource / "scenarios/flume/flume.json");
  json s = json::parse(in);
  s["terrain"]["dem"] = (kSource / "scenarios/flume/flume_dem.asc").string();
  json dams = json::array();
  for (const auto& st : s["structures"])
    if (st["name"] == "CD_P1") dams.push_back(st);
  s["structures"] = dams;
  s["monitors"] = json::array();
  s["dp"] = 0.05;
  s["duration"] = 0.2;
  return parse_scene(s.dump());
}

}  // namespace

TEST(VtkOutput, PlainSceneFramesHoldTheFlowAtItsTimeAndTheWallsOnce) {
  TempDir tmp;
  const Scene scene = small_dam_break(0.2);
  const auto& setup = std::get<SceneSetup<2>>(scene.setup);
  Solver<2> solver(setup);
  SnapshotWriter<2> writer(scene, tmp.path);
  EXPECT_TRUE(read_index(tmp.path / "snapshots.pvd")["flow"].empty());
  const double origin[3] = {0, 0, 0};
  writer.write_frame(solver);
  expect_index_lists(tmp.path, 1, false);  // readable after every frame, as a stopped run leaves it
  for (int k = 0; k < 30; ++k) solver.step();
  writer.write_frame(solver);
  expect_index_lists(tmp.path, 2, false);
  EXPECT_FALSE(fs::exists(tmp.path / "dem.vts"));
  expect_frame_matches(VtkFile(tmp.path / "snapshot_0001.vtp"), solver, origin, false);
  EXPECT_GT(solver.time(), 0.0);

  // Walls: the tank's particles, once, as the scene made them.
  const VtkFile walls(tmp.path / "walls.vtp");
  const auto& b = setup.boundary;
  ASSERT_EQ(walls.attr("Piece", "NumberOfPoints"), std::to_string(b.size()));
  const auto pts = walls.array<float>("Points", "Float32", 3);
  const auto type = walls.array<int32_t>("type", "Int32");
  const auto rho = walls.array<float>("density", "Float32");
  for (size_t i : {size_t{0}, b.size() / 2, b.size() - 1}) {
    EXPECT_FLOAT_EQ(pts[3 * i], static_cast<float>(b.pos[0][i]));
    EXPECT_EQ(pts[3 * i + 1], 0.f);
    EXPECT_FLOAT_EQ(pts[3 * i + 2], static_cast<float>(b.pos[1][i]));
    EXPECT_EQ(type[i], 1);
    EXPECT_FLOAT_EQ(rho[i], static_cast<float>(b.rho[i]));
  }
  // The frames carry no wall particle.
  const auto frame_type = VtkFile(tmp.path / "snapshot_0001.vtp").array<int32_t>("type", "Int32");
  EXPECT_EQ(std::count(frame_type.begin(), frame_type.end(), 1), 0);
}

TEST(VtkOutput, TerrainFramesAreInMapCoordinatesBesideTheDemSurface) {
  TempDir tmp;
  const Scene scene = small_flume();
  const auto& setup = std::get<SceneSetup<3>>(scene.setup);
  const terrain::TerrainModel& tm = *scene.terrain;
  Solver<3> solver(setup);
  SnapshotWriter<3> writer(scene, tmp.path);
  for (int k = 0; k < 20; ++k) solver.step();
  writer.write_frame(solver);
  expect_index_lists(tmp.path, 1, true);
  const double origin[3] = {tm.origin_x, tm.origin_y, 0};
  expect_frame_matches(VtkFile(tmp.path / "snapshot_0000.vtp"), solver, origin, true);
  // Map coordinates: the flume's release is at x 500000.1-500000.6, y 5000000.45-5000000.75 (flume.json).
  const auto pts = VtkFile(tmp.path / "snapshot_0000.vtp").array<double>("Points", "Float64", 3);
  EXPECT_NEAR(pts[0], 500000.35, 0.5);
  EXPECT_NEAR(pts[1], 5000000.6, 0.3);

  // Walls: the check dam's particles only (the bed's are the DEM surface), in map coordinates.
  const auto& b = setup.boundary;
  std::vector<size_t> dam;
  for (size_t i = 0; i < b.size(); ++i)
    if (b.tag[i] != 1) dam.push_back(i);
  ASSERT_FALSE(dam.empty());
  const VtkFile walls(tmp.path / "walls.vtp");
  ASSERT_EQ(walls.attr("Piece", "NumberOfPoints"), std::to_string(dam.size()));
  const auto wpts = walls.array<double>("Points", "Float64", 3);
  const auto wtag = walls.array<int32_t>("material_or_tag", "Int32");
  for (size_t k : {size_t{0}, dam.size() - 1}) {
    EXPECT_DOUBLE_EQ(wpts[3 * k], b.pos[0][dam[k]] + tm.origin_x);
    EXPECT_DOUBLE_EQ(wpts[3 * k + 1], b.pos[1][dam[k]] + tm.origin_y);
    EXPECT_NEAR(wpts[3 * k], 500001.5, 0.1);  // the dam's axis, x = 500001.5
    EXPECT_EQ(wtag[k], static_cast<int32_t>(b.tag[dam[k]]));
  }

  // The DEM: the corridor (flume.json) is the whole 6 m x 1.2 m DEM, so the surface has all its cells.
  const terrain::Grid dem = terrain::load_dem((kSource / "scenarios/flume/flume_dem.asc").string());
  const VtkFile vts(tmp.path / "dem.vts");
  EXPECT_EQ(vts.attr("StructuredGrid", "WholeExtent"),
            "0 " + std::to_string(dem.nx - 1) + " 0 " + std::to_string(dem.ny - 1) + " 0 0");
  const auto elevation = vts.array<float>("elevation", "Float32");
  const auto dpts = vts.array<double>("Points", "Float64", 3);
  const auto ghost = vts.array<uint8_t>("vtkGhostType", "UInt8");
  ASSERT_EQ(elevation.size(), static_cast<size_t>(dem.nx) * dem.ny);
  EXPECT_EQ(ghost.size(), static_cast<size_t>(dem.nx - 1) * (dem.ny - 1));
  // Point (i, r) is DEM cell (i, ny - 1 - r): rows run south to north. One on the chute, one on the plain.
  for (const auto& [i, j] : {std::pair{40, 30}, std::pair{250, 10}}) {
    const size_t k = static_cast<size_t>(dem.ny - 1 - j) * dem.nx + i;
    EXPECT_EQ(elevation[k], dem.at(i, j));
    EXPECT_DOUBLE_EQ(dpts[3 * k], dem.cx(i));
    EXPECT_DOUBLE_EQ(dpts[3 * k + 1], dem.cy(j));
    EXPECT_NEAR(dpts[3 * k + 2], dem.at(i, j), 0.01);  // the bed there: the DEM, no structure
  }
}

TEST(VtkOutput, RunWritesAFrameEverySnapshotInterval) {
  TempDir tmp;
  const Scene scene = small_dam_break(0.1);  // 20 intervals of 5 ms
  RunOptions opt;
  opt.out_dir = tmp.path;
  opt.snapshots = true;
  opt.threads = 2;
  ASSERT_EQ(run_scene(scene, opt).status, "completed");
  expect_index_lists(tmp.path / "snapshots", 21, false);
  const auto frames = read_index(tmp.path / "snapshots" / "snapshots.pvd")["flow"];
  EXPECT_EQ(frames.front().first, 0.0);
  EXPECT_NEAR(frames.back().first, 0.1, 0.005);
}
