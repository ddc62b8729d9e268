// `runout run SCENE --out DIR` refuses a bad scene before any work: exit code 2, a message naming the field
// and the accepted range, and no output (DIR is not created; an existing DIR gets no metrics.json).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;
using json = nlohmann::json;

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
    const std::string cmd = q(kRunout) + " " + args + " > " + q(dir_ / "output.txt") + " 2>&1";
    const int status = std::system(cmd.c_str());
    if (status == -1) return -1;
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    return -1;
  }
  // What the command printed, stdout and stderr together (spdlog's default logger writes to stdout).
  std::string output() const {
    std::ifstream in(dir_ / "output.txt");
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

TEST_F(Cli, MissingSceneFileFailsWithoutOutput) {
  // CLI11 checks the file exists (exit 105 today, not 2): only "fails and writes nothing" is asserted.
  const fs::path out = dir_ / "out";
  EXPECT_NE(run("run " + q(dir_ / "no-such-scene.json") + " --out " + q(out) + " --quiet"), 0);
  EXPECT_FALSE(fs::exists(out));
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

}  // namespace
