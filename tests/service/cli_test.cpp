// `runout run SCENE --out DIR` refuses a bad scene before any work: exit code 2, a message naming the field
// and the accepted range, and no output (DIR is not created; an existing DIR gets no metrics.json). Usage
// errors exit 2 too, --help and --version 0; `run --fidelity/--dp` resolve the scene as a sweep does, and
// `compare --format csv|json` print the decision metrics first, machine-readable.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/scenarios/store.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using runout::RunStore;

namespace {

const std::string kRunout = RUNOUT_BINARY_DIR "/runout";

// A scratch folder per test, removed afterwards.
class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("runout_cli_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  // Runs the command line (arguments already quoted), output to a file; the exit code, or 128 + signal.
  int run(const std::string& args) {
    return run_shell(q(kRunout) + " " + args + " > " + q(dir_ / "output.txt") + " 2>&1");
  }
  // Runs the command line with stdout to stdout.txt and stderr to output.txt (output()).
  int run_split(const std::string& args) {
    return run_shell(q(kRunout) + " " + args + " > " + q(dir_ / "stdout.txt") + " 2> " + q(dir_ / "output.txt"));
  }
  int run_shell(const std::string& cmd) {
    const int status = std::system(cmd.c_str());
    if (status == -1) return -1;
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    return -1;
  }
  // What the command printed: stdout and stderr together after run(), stderr alone after run_split().
  std::string output() const { return text(dir_ / "output.txt"); }
  std::string standard_output() const { return text(dir_ / "stdout.txt"); }
  static std::string text(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // Single-quoted for the shell. (Built with append: GCC 12 warns falsely (-Wrestrict) on "'" + string.)
  static std::string q(const fs::path& p) {
    std::string s(1, '\'');
    s.append(p.string()).push_back('\'');
    return s;
  }

  fs::path dir_;
};

std::vector<std::string> csv_fields(const std::string& line);

// A tiny valid scene: 10 x 10 water particles in a tank, 5 ms.
json good_scene() {
  return json::parse(R"({
    "name": "cli-good",
    "dimensions": 2,
    "dp": 0.02,
    "duration": 0.005,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
    "fluid": [{"min": [0, 0], "max": [0.2, 0.2], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.4, 0.3]}]
  })");
}

TEST_F(Cli, GoodSceneCompletes) {
  // The control: the same invocation with a valid scene runs and writes metrics.
  const fs::path scene = write("good.json", good_scene().dump());
  const fs::path out = dir_ / "out";
  ASSERT_EQ(run("run " + q(scene) + " --out " + q(out) + " --threads 1 --quiet"), 0) << output();
  ASSERT_TRUE(fs::exists(out / "metrics.json"));
  std::ifstream in(out / "metrics.json");
  EXPECT_EQ(json::parse(in).at("status"), "completed");
}

TEST_F(Cli, OutOfRangeValueIsRefusedWithExit2AndNoOutput) {
  json s = good_scene();
  s["materials"][0]["density"] = -1000;
  const fs::path scene = write("bad.json", s.dump());
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out)) << "the output folder was created for a refused scene";
  const std::string err = output();
  EXPECT_NE(err.find("materials[0].density"), std::string::npos) << err;
  EXPECT_NE(err.find("(0, 100000]"), std::string::npos) << err;
}

TEST_F(Cli, RefusedSceneWritesNothingIntoAnExistingOutputFolder) {
  json s = good_scene();
  s["materials"][0]["rheology"] = "friction-hbp";
  s["materials"][0]["friction_angle"] = 95;
  const fs::path scene = write("bad.json", s.dump());
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out / "metrics.json"));
  EXPECT_TRUE(fs::is_empty(out));
  const std::string err = output();
  EXPECT_NE(err.find("materials[0].friction_angle"), std::string::npos) << err;
  EXPECT_NE(err.find("[0, 90)"), std::string::npos) << err;
}

TEST_F(Cli, MalformedJsonIsRefusedWithExit2) {
  const fs::path scene = write("bad.json", R"({"dimensions": 2, "dp": 0.02,)");
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_NE(output().find("malformed JSON"), std::string::npos) << output();
}

TEST_F(Cli, MissingFieldIsRefusedWithExit2) {
  json s = good_scene();
  s.erase("dp");
  const fs::path scene = write("bad.json", s.dump());
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_NE(output().find("dp: missing"), std::string::npos) << output();
}

TEST_F(Cli, ParticleCountOverTheLimitIsRefusedWithExit2) {
  json s = good_scene();
  s["limits"]["max_particles"] = 50;
  const fs::path scene = write("bad.json", s.dump());
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_NE(output().find("limits.max_particles = 50"), std::string::npos) << output();
}

TEST_F(Cli, MissingSceneFileIsRefusedWithExit2AndNoOutput) {
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(dir_ / "no-such-scene.json") + " --out " + q(out) + " --quiet"), 2);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_NE(output().find("no-such-scene.json"), std::string::npos) << output();
}

// Disabled until scene.cpp turns nlohmann's out_of_range into a SceneError: today the CLI aborts
// (SIGABRT, exit 134) on a number beyond double range.
TEST_F(Cli, NumberBeyondDoubleRangeIsRefusedWithExit2) {
  std::string text = good_scene().dump();
  const std::string key = "\"density\":1000";
  text.replace(text.find(key), key.size(), "\"density\":1e400");
  const fs::path scene = write("bad.json", text);
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2) << output();
  EXPECT_FALSE(fs::exists(out));
}

// Disabled until scene.cpp refuses a periodic vertical axis: today the scene is accepted and the solver
// refuses it after the output folder is made ("run could not start", exit 1).
TEST_F(Cli, PeriodicVerticalAxisIsRefusedWithExit2) {
  json s = good_scene();
  s["domain"] = {{"periodic", {false, true}}, {"min", {-1, -1}}, {"max", {1, 1}}};
  const fs::path scene = write("bad.json", s.dump());
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --out " + q(out) + " --quiet"), 2) << output();
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(Cli, UsageErrorsExit2WithCli11sMessage) {
  EXPECT_EQ(run("run " + q(write("good.json", good_scene().dump())) + " --no-such-option"), 2);
  EXPECT_NE(output().find("--no-such-option"), std::string::npos) << output();
  EXPECT_EQ(run("run"), 2);  // the scene argument missing
  EXPECT_NE(output().find("scene is required"), std::string::npos) << output();
  EXPECT_EQ(run(""), 2);  // no subcommand
  EXPECT_EQ(run("sweep --jobs 0 scenarios/flume/c0_c7.json"), 2);  // out of range
  EXPECT_NE(output().find("--jobs"), std::string::npos) << output();
  EXPECT_EQ(run("compare --format xml"), 2);
  EXPECT_NE(output().find("xml"), std::string::npos) << output();
}

TEST_F(Cli, HelpAndVersionExit0) {
  ASSERT_EQ(run("--version"), 0);
  EXPECT_EQ(output(), std::string(RUNOUT_VERSION) + "\n");
  ASSERT_EQ(run("--help"), 0);
  EXPECT_NE(output().find("compare"), std::string::npos) << output();
  // Every subcommand's help ends with an example that uses a shipped file or none.
  for (const char* sub : {"run", "sweep", "compare", "report", "serve", "tradeoff", "calibrate", "calibrate-material", "study", "schema"}) {
    ASSERT_EQ(run(std::string(sub) + " --help"), 0) << sub;
    const std::string help = output();
    const size_t example = help.find("Example");
    ASSERT_NE(example, std::string::npos) << sub << ":\n" << help;
    EXPECT_NE(help.find("  runout " + std::string(sub), example), std::string::npos) << sub << ":\n" << help;
    const size_t file = help.find("scenarios/", example);
    if (file != std::string::npos) {  // the file it names is shipped
      const std::string name = help.substr(file, help.find_first_of(" )\n", file) - file);
      EXPECT_TRUE(fs::exists(fs::path(RUNOUT_SOURCE_DIR) / name)) << sub << ": " << name;
    }
  }
}

// `runout report` writes the sweep's HTML report; a missing store, sweep or baseline is a usage error (exit 2)
// naming the option, and nothing is written.
TEST_F(Cli, ReportWritesTheSweepsPageAndRefusesWhatItCannotFind) {
  write("base.json", good_scene().dump());
  const fs::path sweep = write("sweep.json", R"({"name": "cli-sweep", "base": "base.json",
                                                 "variants": [{"name": "A"}, {"name": "B", "structures": []}]})");
  const fs::path db = dir_ / "runs.db", runs = dir_ / "runs", out = dir_ / "out" / "report.html";
  ASSERT_EQ(run("sweep " + q(sweep) + " --db " + q(db) + " --out " + q(runs) + " --threads 1"), 0) << output();
  ASSERT_EQ(run("report --sweep cli-sweep --db " + q(db) + " --runs " + q(runs) + " --out " + q(out)), 0) << output();
  const std::string html = text(out);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("<h1>Study report: cli-sweep</h1>"), std::string::npos);
  EXPECT_NE(html.find("<a href=\"#layout-A\">A</a> <small>baseline</small>"), std::string::npos);
  fs::remove(out);
  EXPECT_EQ(run("report --sweep nope --db " + q(db) + " --out " + q(out)), 2);
  EXPECT_NE(output().find("--sweep: no completed run of sweep 'nope'"), std::string::npos) << output();
  EXPECT_EQ(run("report --sweep cli-sweep --baseline C0 --db " + q(db) + " --out " + q(out)), 2);
  EXPECT_NE(output().find("(accepted: A, B)"), std::string::npos) << output();
  EXPECT_EQ(run("report --sweep cli-sweep --db " + q(dir_ / "none.db") + " --out " + q(out)), 2);
  EXPECT_NE(output().find("--db: no run store at"), std::string::npos) << output();
  EXPECT_FALSE(fs::exists(dir_ / "none.db"));
  EXPECT_EQ(run("report --db " + q(db)), 2);
  EXPECT_NE(output().find("--sweep is required"), std::string::npos) << output();
  // A mistyped --runs: refused, naming the folder it looked for, rather than a page of "No map".
  EXPECT_EQ(run("report --sweep cli-sweep --db " + q(db) + " --runs " + q(dir_ / "rusn") + " --out " + q(out)), 2);
  EXPECT_NE(output().find("--runs: no folder " + (dir_ / "rusn" / "cli-sweep").string()), std::string::npos) << output();
  EXPECT_FALSE(fs::exists(out));
}

// `runout run SWEEP.json --variant NAME` runs one layout as the sweep resolves it: the same manifest as the
// sweep's run of it (so the store finds it), stored under the sweep's name and variant, in runs/<sweep>/<variant>
// by default; without --variant, or with a name that is not a layout, it is refused naming the layouts.
TEST_F(Cli, RunOneLayoutOfASweepWithVariant) {
  write("base.json", good_scene().dump());
  const fs::path sweep = write("sweep.json", R"({"name": "cli-sweep", "base": "base.json",
                                                 "variants": [{"name": "A"}, {"name": "B", "structures": []}]})");
  const fs::path db = dir_ / "runs.db";
  EXPECT_EQ(run("run " + q(sweep) + " --no-db --quiet"), 2);
  EXPECT_NE(output().find("--variant: " + sweep.string() + " is a sweep: name the layout to run (accepted: A, B)"),
            std::string::npos) << output();
  EXPECT_EQ(run("run " + q(sweep) + " --variant C3 --no-db --quiet"), 2);
  EXPECT_NE(output().find("--variant: 'C3' is not a layout of sweep cli-sweep (accepted: A, B)"), std::string::npos)
      << output();
  EXPECT_EQ(run("run " + q(dir_ / "base.json") + " --variant A --no-db --quiet"), 2);
  EXPECT_NE(output().find("--variant: only for a sweep file"), std::string::npos) << output();
  // The shipped flume study: its layouts are named.
  EXPECT_EQ(run("run " + q(fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume/c0_c7.json") + " --variant C9 --no-db"), 2);
  EXPECT_NE(output().find("(accepted: C0, C1, C2, C3, C4, C5, C6, C7)"), std::string::npos) << output();

  // Layout B alone, from the test's folder (runs/<sweep>/<variant> is relative to it), then the whole sweep:
  // the sweep finds B stored and runs only A.
  const std::string cd = "cd " + q(dir_) + " && ";
  ASSERT_EQ(run_shell(cd + q(kRunout) + " run sweep.json --variant B --db runs.db --threads 1 --quiet > output.txt 2>&1"), 0)
      << output();
  EXPECT_TRUE(fs::is_regular_file(dir_ / "runs" / "cli-sweep" / "B" / "metrics.json"));
  {
    const RunStore store(db);
    const auto runs = store.list_runs("cli-sweep");
    ASSERT_EQ(runs.size(), 1u);
    EXPECT_EQ(runs[0].variant, "B");
    EXPECT_EQ(runs[0].scene, "cli-good/B");
  }
  ASSERT_EQ(run_shell(cd + q(kRunout) + " sweep sweep.json --db runs.db --threads 1 --no-compare > output.txt 2>&1"), 0)
      << output();
  const RunStore store(db);
  EXPECT_EQ(store.list_runs("cli-sweep").size(), 2u) << output();
  EXPECT_NE(output().find("B completed, already stored"), std::string::npos) << output();
}

// `compare --db` at a mistyped path is refused (exit 2, naming the path) and creates nothing there.
TEST_F(Cli, CompareRefusesAStoreThatIsNotThere) {
  const fs::path wrong = dir_ / "runuot.db";
  EXPECT_EQ(run("compare --sweep flume-C0-C7 --db " + q(wrong)), 2);
  EXPECT_NE(output().find("--db: no run store at " + wrong.string()), std::string::npos) << output();
  EXPECT_FALSE(fs::exists(wrong));
  EXPECT_EQ(run("compare --runs 1 2 --db " + q(wrong)), 2);
  EXPECT_FALSE(fs::exists(wrong));
}

TEST_F(Cli, RunRefusesFidelityAndDpTogether) {
  const fs::path scene = write("good.json", good_scene().dump());
  const fs::path out = dir_ / "out";
  EXPECT_EQ(run("run " + q(scene) + " --fidelity draft --dp 0.04 --out " + q(out) + " --no-db"), 2);
  EXPECT_NE(output().find("--fidelity"), std::string::npos) << output();
  EXPECT_NE(output().find("--dp"), std::string::npos) << output();
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(run("run " + q(scene) + " --fidelity coarse --out " + q(out) + " --no-db"), 2);
  EXPECT_NE(output().find("coarse"), std::string::npos) << output();
}

// The smallest shipped scene (the 2D dam break, 1 s) with two sections and the tank's load at a coarse dp.
fs::path dam_break_with_monitors(const fs::path& dir) {
  std::ifstream in(fs::path(RUNOUT_SOURCE_DIR) / "scenarios/validation/dam_break_2d.json");
  json s = json::parse(in);
  s["monitors"] = json::parse(R"([{"type": "section", "name": "S1", "x": 1.0},
                                  {"type": "section", "name": "S2", "x": 2.0},
                                  {"type": "structure_load", "name": "Tank", "structure": "tank"}])");
  const fs::path p = dir / "dam_break.json";
  std::ofstream(p) << s.dump();
  return p;
}

TEST_F(Cli, RunAtAnExplicitDpRunsAndStoresAtThatDp) {
  const fs::path scene = dam_break_with_monitors(dir_);
  const fs::path out = dir_ / "out", db = dir_ / "runs.db";
  ASSERT_EQ(run("run " + q(scene) + " --dp 0.05 --out " + q(out) + " --db " + q(db) + " --threads 1 --quiet"), 0)
      << output();
  std::ifstream in(out / "metrics.json");
  const json m = json::parse(in);
  EXPECT_DOUBLE_EQ(m.at("settings").at("dp_m").get<double>(), 0.05);  // the scene says 0.01
  // Stored as a sweep stores a run at an explicit dp: fidelity "custom", the resolved dp in the manifest.
  {
    const RunStore store(db);
    const auto row = store.get_run(1);
    ASSERT_TRUE(row);
    EXPECT_EQ(row->fidelity, "custom");
    const json manifest = json::parse(store.manifest_json(1));
    EXPECT_EQ(manifest.at("fidelity"), "custom");
    EXPECT_DOUBLE_EQ(manifest.at("scene").at("dp").get<double>(), 0.05);
  }
  ASSERT_EQ(run_split("compare --runs 1 --all --format json --filter settings.dp_m --db " + q(db)), 0) << output();
  const json c = json::parse(standard_output());
  ASSERT_EQ(c.at("rows").size(), 1u) << c.dump();
  EXPECT_DOUBLE_EQ(c["rows"][0]["baseline"].get<double>(), 0.05);
  // The same scene and dp again is the same run (one manifest): it is not stored twice.
  ASSERT_EQ(run("run " + q(scene) + " --dp 0.05 --out " + q(out) + " --db " + q(db) + " --threads 1 --quiet"), 0);
  EXPECT_NE(output().find("stored as run 1 "), std::string::npos) << output();
}

TEST_F(Cli, RunAtAFidelityTakesTheScenesDefaultLadder) {
  // No presets in the scene: draft is twice its dp (0.02 m), as a sweep's layout would be.
  const fs::path scene = write("good.json", good_scene().dump());
  const fs::path out = dir_ / "out", db = dir_ / "runs.db";
  ASSERT_EQ(run("run " + q(scene) + " --fidelity draft --out " + q(out) + " --db " + q(db) + " --threads 1 --quiet"), 0)
      << output();
  std::ifstream in(out / "metrics.json");
  EXPECT_DOUBLE_EQ(json::parse(in).at("settings").at("dp_m").get<double>(), 0.04);
  const RunStore store(db);
  EXPECT_EQ(store.get_run(1)->fidelity, "draft");
  EXPECT_EQ(json::parse(store.manifest_json(1)).at("fidelity"), "draft");
  // As written, the same scene is another run (fidelity "scene"), not the draft one reused.
  ASSERT_EQ(run("run " + q(scene) + " --out " + q(dir_ / "as-written") + " --db " + q(db) + " --threads 1 --quiet"), 0);
  EXPECT_NE(output().find("stored as run 2 "), std::string::npos) << output();
}

// An ensemble sweep (runs LAYOUT-eNNN): compare prints each layout's quantiles over the members and its share of
// first places; --member compares one member's layouts as a plain sweep.
TEST_F(Cli, CompareSummarisesAnEnsembleAndComparesOneMember) {
  const fs::path db = dir_ / "runs.db";
  {
    RunStore store(db);
    const double q[3][2] = {{1.0, 2.0}, {3.0, 2.0}, {1.5, 4.0}};  // C0 first in members 0 and 2, C1 in 1
    for (int m = 0; m < 3; ++m)
      for (int l = 0; l < 2; ++l) {
        RunStore::RunRecord r;
        r.variant = "C" + std::to_string(l) + "-e00" + std::to_string(m);
        r.manifest_hash = "ens-" + r.variant;
        r.sweep = "ens";
        r.status = "completed";
        r.metrics_json =
            json{{"monitors", {{{"type", "section"}, {"name", "Outlet"}, {"peak_discharge_m3_s", q[m][l]}}}}}.dump();
        store.put_run(r);
      }
  }
  ASSERT_EQ(run_split("compare --sweep ens --db " + q(db)), 0) << output();
  const std::string table = standard_output();
  EXPECT_NE(table.find("3 members"), std::string::npos) << table;
  EXPECT_NE(table.find("C0 67 %, C1 33 %"), std::string::npos) << table;
  ASSERT_EQ(run_split("compare --sweep ens --format csv --db " + q(db)), 0) << output();
  std::istringstream csv(standard_output());
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "metric,label,layout,p10,p50,p90,count,never,first_share");
  std::getline(csv, line);  // C0's Q_m over {1, 3, 1.5}: p10 1.1, p50 1.5, p90 2.7 (type 7)
  const auto f = csv_fields(line);
  ASSERT_EQ(f.size(), 9u) << line;
  EXPECT_EQ(f[2], "C0");
  EXPECT_NEAR(std::stod(f[3]), 1.1, 1e-12);
  EXPECT_NEAR(std::stod(f[4]), 1.5, 1e-12);
  EXPECT_NEAR(std::stod(f[5]), 2.7, 1e-12);
  ASSERT_EQ(run_split("compare --sweep ens --member 1 --format json --db " + q(db)), 0) << output();
  const json j = json::parse(standard_output());
  EXPECT_EQ(j.at("baseline"), "C0-e001");
  EXPECT_EQ(j.at("runs"), json::parse(R"(["C1-e001"])"));
  EXPECT_EQ(run_split("compare --sweep ens --member 7 --db " + q(db)), 2);
}

// A protected zone the flow never reached (arrival -1 in the store) reads "never" in compare's table, CSV and
// JSON, with no per cent of it or against it (it read "-1 (-166.7%)" against an arrival at 1.5 s).
TEST_F(Cli, CompareShowsNeverForAnArrivalThatNeverHappened) {
  const fs::path db = dir_ / "runs.db";
  {
    RunStore store(db);
    const std::vector<std::pair<std::string, double>> layouts = {{"C0", 1.5}, {"C1", -1}, {"C2", 2.0}};
    for (const auto& [variant, arrival] : layouts) {
      RunStore::RunRecord r;
      r.manifest_hash = "never-" + variant;
      r.sweep = "never-sweep";
      r.variant = variant;
      r.status = "completed";
      r.metrics_json = json{{"terrain", {{"protected_zones", {{{"name", "Village"}, {"arrival_time_s", arrival}}}}}}}.dump();
      store.put_run(r);
    }
  }
  const std::string metric = "terrain.protected_zones.Village.arrival_time_s";
  ASSERT_EQ(run_split("compare --sweep never-sweep --db " + q(db)), 0) << output();
  const std::string table = standard_output();
  const size_t at = table.find(metric);
  ASSERT_NE(at, std::string::npos) << table;
  const std::string row = table.substr(at, table.find('\n', at) - at);
  EXPECT_NE(row.find("never"), std::string::npos) << row;
  EXPECT_NE(row.find("2 (+33.3%)"), std::string::npos) << row;
  EXPECT_EQ(row.find("-1"), std::string::npos) << row;
  EXPECT_EQ(row.find("-166"), std::string::npos) << row;

  ASSERT_EQ(run_split("compare --sweep never-sweep --format csv --db " + q(db)), 0) << output();
  std::istringstream csv(standard_output());
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(csv_fields(line), (std::vector<std::string>{"metric", "decision", "C0 (baseline)", "C1", "C1 %", "C2", "C2 %"}));
  std::getline(csv, line);
  EXPECT_EQ(csv_fields(line), (std::vector<std::string>{metric, "1", "1.5", "never", "", "2.0", "33.33333333333333"}));

  ASSERT_EQ(run_split("compare --sweep never-sweep --format json --db " + q(db)), 0) << output();
  const json j = json::parse(standard_output()).at("rows").at(0);
  EXPECT_EQ(j.at("metric"), metric);
  EXPECT_EQ(j.at("values"), json::parse("[null, 2.0]"));
  EXPECT_EQ(j.at("never"), json::parse("[true, false]"));
  EXPECT_EQ(j.at("baseline_never"), false);
  EXPECT_TRUE(j.at("percent")[0].is_null());

  // Against the layout that never arrived: its column says never, and no per cent is taken against it.
  ASSERT_EQ(run_split("compare --sweep never-sweep --baseline C1 --format json --db " + q(db)), 0) << output();
  const json b = json::parse(standard_output()).at("rows").at(0);
  EXPECT_TRUE(b.at("baseline").is_null());
  EXPECT_EQ(b.at("baseline_never"), true);
  EXPECT_EQ(b.at("values"), json::parse("[1.5, 2.0]"));
  EXPECT_EQ(b.at("percent"), json::parse("[null, null]"));
  ASSERT_EQ(run_split("compare --sweep never-sweep --baseline C1 --db " + q(db)), 0) << output();
  EXPECT_NE(standard_output().find("never"), std::string::npos) << standard_output();
  EXPECT_EQ(standard_output().find('%'), std::string::npos) << standard_output();
}

class CliCompare : public Cli {
 protected:
  // Two stored runs of the dam break with monitors, at dp 0.05 (run 1, the baseline) and 0.04 (run 2).
  void SetUp() override {
    Cli::SetUp();
    const fs::path scene = dam_break_with_monitors(dir_);
    db_ = dir_ / "runs.db";
    for (const char* dp : {"0.05", "0.04"})
      ASSERT_EQ(run("run " + q(scene) + " --dp " + dp + " --out " + q(dir_ / dp) + " --db " + q(db_) +
                    " --threads 1 --quiet"),
                0)
          << output();
  }
  fs::path db_;
};

TEST_F(CliCompare, JsonHasTheDecisionMetricsFirst) {
  ASSERT_EQ(run_split("compare --runs 1 2 --format json --all --db " + q(db_)), 0) << output();
  const json c = json::parse(standard_output());
  EXPECT_EQ(c.at("baseline"), "#1");
  EXPECT_EQ(c.at("runs"), json::array({"#2"}));
  EXPECT_EQ(c.at("outlet"), "S2");
  const json& rows = c.at("rows");
  ASSERT_GT(rows.size(), 20u);
  EXPECT_EQ(rows[0]["metric"], "monitors.section.S2.peak_discharge_m3_s");
  EXPECT_EQ(rows[1]["metric"], "monitors.section.S2.volume_passed_m3");
  EXPECT_EQ(rows[2]["metric"], "monitors.structure_load.Tank.peak_force_n");
  EXPECT_EQ(rows[3]["metric"], "monitors.structure_load.Tank.peak_mean_pressure_pa");
  size_t decision = 0;
  while (decision < rows.size() && rows[decision]["decision"].get<bool>()) ++decision;
  EXPECT_EQ(decision, 4u);
  for (size_t k = decision; k < rows.size(); ++k) EXPECT_FALSE(rows[k]["decision"].get<bool>()) << rows[k].dump();
  for (const auto& r : rows) {
    ASSERT_EQ(r["values"].size(), 1u);
    ASSERT_EQ(r["percent"].size(), 1u);
    if (r["baseline"].is_number() && r["values"][0].is_number() && r["baseline"].get<double>() != 0) {
      const double base = r["baseline"].get<double>(), value = r["values"][0].get<double>();
      EXPECT_NEAR(r["percent"][0].get<double>(), (value - base) / std::abs(base) * 100,
                  1e-9 * (1 + std::abs(r["percent"][0].get<double>())))
          << r.dump();
    }
  }
  // --baseline with --runs is a run id; the second run as the baseline swaps the columns.
  ASSERT_EQ(run_split("compare --runs 1 2 --baseline 2 --format json --db " + q(db_)), 0) << output();
  EXPECT_EQ(json::parse(standard_output()).at("baseline"), "#2");
  EXPECT_EQ(run_split("compare --runs 1 2 --baseline C0 --db " + q(db_)), 2);
  EXPECT_NE(output().find("--baseline 'C0' must be a run id"), std::string::npos) << output();
  // Without --all: the decision metrics alone.
  ASSERT_EQ(run_split("compare --runs 1 2 --format json --db " + q(db_)), 0) << output();
  EXPECT_EQ(json::parse(standard_output()).at("rows").size(), 4u);
}

// RFC 4180 fields of one line (no line breaks inside fields here).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t k = 0; k < line.size(); ++k) {
    const char c = line[k];
    if (quoted && c == '"' && k + 1 < line.size() && line[k + 1] == '"') out.back() += '"', ++k;
    else if (c == '"') quoted = !quoted;
    else if (c == ',' && !quoted) out.emplace_back();
    else out.back() += c;
  }
  return out;
}

TEST_F(CliCompare, CsvHasOneColumnPerValueAndPercent) {
  ASSERT_EQ(run_split("compare --runs 1 2 --format csv --all --db " + q(db_)), 0) << output();
  std::istringstream in(standard_output());
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const auto header = csv_fields(line);
  EXPECT_EQ(header, (std::vector<std::string>{"metric", "decision", "#1 (baseline)", "#2", "#2 %"}));
  size_t rows = 0;
  while (std::getline(in, line)) {
    const auto f = csv_fields(line);
    ASSERT_EQ(f.size(), header.size()) << line;
    if (rows == 0) {
      EXPECT_EQ(f[0], "monitors.section.S2.peak_discharge_m3_s");
      EXPECT_EQ(f[1], "1");
    }
    for (size_t k = 2; k < f.size(); ++k)
      if (!f[k].empty() && !(f[k] == "never" && f[0].find("arrival_time_s") != std::string::npos)) {
        size_t used = 0;
        (void)std::stod(f[k], &used);  // a plain number, not "12.3 (+4.0%)"
        EXPECT_EQ(used, f[k].size()) << line;
      }
    ++rows;
  }
  EXPECT_GT(rows, 20u);
}

}  // namespace
