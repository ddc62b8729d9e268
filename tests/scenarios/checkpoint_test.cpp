// Checkpoints (RunOptions::checkpoint_interval): a run killed after a checkpoint and resumed from it ends as the
// run that was never interrupted, to the bit on one thread (metrics, every series table, the inundation rasters);
// a stopped run saves its state and resumes from it; a checkpoint of another scene is refused, not overwritten.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kFlume = fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "flume";

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The flume's C6 (deposition area and check dam) at draft, to `duration`: a terrain run with wall tiles, sections,
// a structure load and inundation rasters.
Scene flume_c6(double duration) {
  json j = json::parse(resolve_variant(read_file(kFlume / "flume.json"), {"C6", {"FD_P1", "CD_P2"}}, {"draft", {}}));
  j["duration"] = duration;
  return parse_scene(j.dump(), kFlume);
}

// A raster's cells as bytes (its metadata holds the time it was written).
std::string raster_cells(const fs::path& p) {
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(p.string().c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  if (!ds) return "cannot open " + p.string();
  const int nx = ds->GetRasterXSize(), ny = ds->GetRasterYSize();
  std::vector<float> cells(static_cast<size_t>(nx) * ny);
  if (ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, nx, ny, cells.data(), nx, ny, GDT_Float32, 0, 0) != CE_None)
    return "cannot read " + p.string();
  std::string bytes(cells.size() * sizeof(float), '\0');
  std::memcpy(bytes.data(), cells.data(), bytes.size());
  return bytes;
}

// metrics.json without what depends on the wall clock or on the run having been resumed.
json comparable_metrics(const fs::path& dir) {
  json m = json::parse(read_file(dir / "metrics.json"));
  for (const char* k : {"wall_time_s", "particle_steps_per_s", "resumed"}) m.erase(k);
  return m;
}

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) : path(fs::temp_directory_path() / name) { fs::remove_all(path); }
  ~TempDir() { fs::remove_all(path); }
};

class OneThread : public ::testing::Test {
 protected:
  void SetUp() override { threads_ = omp_get_max_threads(), omp_set_num_threads(1); }
  void TearDown() override { omp_set_num_threads(threads_); }
  int threads_ = 1;
};

}  // namespace

// The run writes a checkpoint every 0.3 s of wall time; the one on disk once the flow has passed 1.2 s (after the
// front crossed the Chute section, 1.1 s, while the dam is loaded) is kept aside, as a kill would leave it. Resumed
// from it in an empty directory, the run ends with the same bits as the run that went on.
TEST_F(OneThread, ARunKilledAfterACheckpointEndsAsIfNeverInterrupted) {
  const Scene scene = flume_c6(1.6);
  TempDir whole("runout-checkpoint-whole"), resumed("runout-checkpoint-resumed");
  const fs::path kept = whole.path.string() + ".kept";
  fs::remove(kept);
  RunOptions opt;
  opt.out_dir = whole.path;
  opt.checkpoint_interval = 0.3;
  opt.on_progress = [&](const RunProgress& p) {
    if (p.time > 1.2 && !fs::exists(kept) && fs::exists(whole.path / "checkpoint.bin"))
      fs::copy_file(whole.path / "checkpoint.bin", kept);
  };
  const RunSummary a = run_scene(scene, opt);
  ASSERT_EQ(a.status, "completed") << a.error;
  EXPECT_FALSE(fs::exists(whole.path / "checkpoint.bin")) << "a completed run leaves no checkpoint";
  ASSERT_TRUE(fs::exists(kept)) << "no checkpoint was on disk past 1.2 s";

  fs::create_directories(resumed.path);
  fs::rename(kept, resumed.path / "checkpoint.bin");
  opt.out_dir = resumed.path;
  opt.on_progress = nullptr;
  const RunSummary b = run_scene(scene, opt);
  ASSERT_EQ(b.status, "completed") << b.error;
  EXPECT_GT(b.resumed_from, 1.0);  // checkpoints 0.3 s of wall time apart: well under 0.2 s of flow
  EXPECT_LT(b.resumed_from, 1.6);
  EXPECT_EQ(b.steps, a.steps);
  EXPECT_EQ(comparable_metrics(resumed.path), comparable_metrics(whole.path));
  const json m = json::parse(read_file(resumed.path / "metrics.json"));
  EXPECT_EQ(m["resumed"]["sessions"], 2);
  EXPECT_GT(m["monitors"].size(), 2u);
  for (const auto& f : fs::directory_iterator(whole.path / "series"))
    EXPECT_EQ(read_file(resumed.path / "series" / f.path().filename()), read_file(f.path())) << f.path().filename();
  for (const char* raster : {"max_depth.tif", "max_speed.tif", "arrival_time.tif"})
    EXPECT_EQ(raster_cells(resumed.path / "rasters" / raster), raster_cells(whole.path / "rasters" / raster)) << raster;
}

// A stopped run saves its state; the same options resume it from the time it stopped to the end.
TEST_F(OneThread, AStoppedRunSavesItsStateAndResumesFromIt) {
  const Scene scene = flume_c6(0.6);
  TempDir dir("runout-checkpoint-stopped");
  std::atomic<bool> stop{false};
  RunOptions opt;
  opt.out_dir = dir.path;
  opt.checkpoint_interval = 1e6;  // only when stopped
  opt.stop = &stop;
  opt.on_progress = [&](const RunProgress& p) { stop = stop || p.time > 0.2; };
  const RunSummary first = run_scene(scene, opt);
  ASSERT_EQ(first.status, "stopped");
  ASSERT_TRUE(fs::exists(dir.path / "checkpoint.bin"));
  EXPECT_TRUE(has_checkpoint_of(scene, dir.path));
  stop = false;
  opt.on_progress = nullptr;
  const RunSummary second = run_scene(scene, opt);
  ASSERT_EQ(second.status, "completed") << second.error;
  EXPECT_DOUBLE_EQ(second.resumed_from, first.simulated_time);
  EXPECT_GE(second.simulated_time, 0.6);
  EXPECT_FALSE(fs::exists(dir.path / "checkpoint.bin"));
}

// A checkpoint of another scene (here: another duration) is refused with the file's name, and kept; one of the
// same scene reworded in its description only is the same run's.
TEST_F(OneThread, ACheckpointOfAnotherSceneIsRefusedAndKept) {
  TempDir dir("runout-checkpoint-other");
  std::atomic<bool> stop{true};
  RunOptions opt;
  opt.out_dir = dir.path;
  opt.checkpoint_interval = 1e6;
  opt.stop = &stop;
  ASSERT_EQ(run_scene(flume_c6(0.3), opt).status, "stopped");
  stop = false;
  json reworded = json::parse(flume_c6(0.3).canonical_json);
  reworded["description"] = "the same flume, described again";
  EXPECT_TRUE(has_checkpoint_of(parse_scene(reworded.dump(), kFlume), dir.path));
  const Scene other = flume_c6(0.4);
  EXPECT_FALSE(has_checkpoint_of(other, dir.path));
  try {
    run_scene(other, opt);
    FAIL() << "resumed from a checkpoint of another scene";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("another scene"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("checkpoint.bin"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(dir.path / "checkpoint.bin"));
}

// A checkpoint that cannot be written (here its temporary name is taken by a directory) does not stop the run:
// it completes and metrics.json says how many checkpoints were lost and why.
TEST_F(OneThread, ACheckpointThatCannotBeWrittenWarnsAndTheRunGoesOn) {
  TempDir dir("runout-checkpoint-unwritable");
  fs::create_directories(dir.path / "checkpoint.bin.tmp");
  RunOptions opt;
  opt.out_dir = dir.path;
  opt.checkpoint_interval = 0.05;
  const RunSummary s = run_scene(flume_c6(0.3), opt);
  EXPECT_EQ(s.status, "completed") << s.error;
  EXPECT_GE(s.simulated_time, 0.3);
  const json m = json::parse(read_file(dir.path / "metrics.json"));
  ASSERT_TRUE(m.contains("warnings")) << m.dump(2);
  EXPECT_NE(m["warnings"].dump().find("checkpoint(s) could not be written"), std::string::npos) << m["warnings"];
}
