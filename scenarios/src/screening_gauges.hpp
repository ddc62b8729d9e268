#pragma once
// What the screening run measures besides the inundation (screening_run.cpp): the scene's section monitors
// (discharge through a line, as the 3D section gauge counts it: engine/src/monitors/section.cpp) and each check
// dam's load from the flow state in front of it (a depth-averaged estimate, not the 3D structure_load monitor's
// force of the particles on the wall: reported under its own key). Sampled every screening.output_interval.
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/engine/depth_averaged.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout {

struct ScreeningSettings;

class ScreeningGauges {
 public:
  ScreeningGauges(const Scene& scene, const ScreeningSettings& settings, const depth_averaged::Model& model);
  void sample(const depth_averaged::Model& model);
  // OUT/series/section_<name>.csv and screening_load_<name>.csv.
  void write(const std::filesystem::path& series_dir) const;
  // metrics.json's monitors (the section gauges; other monitor types are not sampled: listed in `skipped`).
  nlohmann::json sections() const;
  std::vector<std::string> skipped() const { return skipped_; }
  // metrics.json's terrain.structures[k].screening_load for each check dam (null for other structures).
  nlohmann::json dam_load(size_t structure) const;

 private:
  struct Section {
    std::string name;
    std::vector<std::array<double, 2>> line;
    int downstream = 1;
    std::vector<int8_t> side;  // by particle id
    double passed = 0, arrival_volume = 0, arrival = -1, peak = 0, peak_t = 0, last_t = 0;
    std::ostringstream csv;
  };
  struct DamLoad {
    size_t structure = 0;
    std::vector<std::array<double, 2>> points;  // local plan points upstream of the axis, one per ds
    double ds = 0, offset = 0, peak = 0, peak_t = 0, peak_line = 0;
    std::array<double, 2> normal{0, 0};
    std::ostringstream csv;
  };
  int raw_side(const Section& s, double x, double y) const;
  void sample_dam(DamLoad& d, const depth_averaged::Model& m);
  double ground_cos(double x, double y, const depth_averaged::Model& m) const;

  const terrain::TerrainModel& tm_;
  double density_, gravity_, window_;
  std::vector<std::unique_ptr<Section>> sections_;
  std::vector<std::unique_ptr<DamLoad>> dams_;
  std::vector<std::string> skipped_;
};

}  // namespace runout
