#pragma once
// `runout tradeoff` (speed against accuracy, docs/tradeoff.md) and `runout calibrate` (refits the cost model
// from stored runs).
#include <atomic>
#include <string>
#include <vector>

namespace runout::service {

struct TradeoffCommand {
  std::string file;                  // a scene, or a sweep (then `variant` picks the layout)
  std::string variant;               // sweep variant (default: the first)
  std::vector<std::string> levels;   // default: draft, standard, fine
  std::vector<std::string> options;  // PATH=VALUE numerics choices run at option_level
  std::string option_level;
  int threads = 0;
  std::string out_dir;               // default runs/tradeoff/<name>
  std::string db = "runout.db";
  bool predict_only = false;
};
int run_tradeoff_command(const TradeoffCommand& c, const std::atomic<bool>* stop);

struct CalibrateCommand {
  std::vector<std::string> dbs = {"runout.db"};  // run stores read (several: their runs together)
  std::string sweep_prefix;  // only runs whose sweep starts with this (empty: all)
  std::string json_out;      // write the fitted coefficients here (JSON)
};
int run_calibrate_command(const CalibrateCommand& c);

}  // namespace runout::service
