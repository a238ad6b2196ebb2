// The executables as a user runs them: exit codes and messages.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "take_fixture.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome {
namespace {

namespace fs = std::filesystem;

using dome::testing::RunDomeBinary;
using Result = dome::testing::CommandResult;

TEST(Cli, EveryExecutablePrintsHelp) {
  for (const char* binary : {"dome", "dome-master", "dome-worker", "dome-capture"}) {
    const Result r = RunDomeBinary("--help", binary);
    EXPECT_EQ(r.exit_code, 0) << binary;
    EXPECT_NE(r.output.find("Usage:"), std::string::npos) << binary << ": " << r.output;
  }
}

TEST(Cli, UnknownSubcommandFails) {
  const Result r = RunDomeBinary("frobnicate");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("frobnicate"), std::string::npos) << r.output;
}

TEST(Cli, BadLogLevelNamesTheFlag) {
  const Result r = RunDomeBinary("--log-level loud info /tmp");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("--log-level: unknown log level 'loud'"), std::string::npos) << r.output;
}

class InfoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    take::testing::WriteTake(dir_, take::testing::MakeRingRig(2, 24, 16), 3);
  }
  testing::TempDir tmp_;
  fs::path dir_;
};

TEST_F(InfoTest, ValidTakeExitsZeroWithSummary) {
  const Result r = RunDomeBinary("info " + dir_.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("rig: 2 camera(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("instants: 3 (00:00:01:00 .. 00:00:01:10)"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST_F(InfoTest, BrokenTakeExitsNonZeroNamingTheFile) {
  fs::remove(dir_ / "frames/00-00-01-05/c1.png");
  std::ofstream(dir_ / "frames/00-00-01-10/c0.png") << "garbage";
  const Result r = RunDomeBinary("info " + dir_.string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("2 problem(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("frames/00-00-01-05/c1.png: missing image of camera 'c1'"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("frames/00-00-01-10/c0.png: unreadable or corrupt image"),
            std::string::npos)
      << r.output;
}

TEST_F(InfoTest, MalformedRigJsonNamesTheField) {
  std::ofstream(dir_ / "rig.json")
      << R"({"format_version": 1, "cameras": [{"id": "c0", "focal_mm": "long"}]})";
  const Result r = RunDomeBinary("info " + dir_.string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("rig.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("cameras[0].focal_mm"), std::string::npos) << r.output;
}

TEST(Cli, ImportMissingSceneFails) {
  const Result r = RunDomeBinary("import halcon /nonexistent/scene --out /tmp/dome_never_written");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("dome: /nonexistent/scene: not a folder"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists("/tmp/dome_never_written"));
}

TEST(Cli, SynthBadOptionsNameTheFlag) {
  const struct {
    const char* args;
    const char* message;
  } cases[] = {
      {"--preset huge --out /tmp/dome_never_written", "--preset: unknown preset 'huge'"},
      {"--preset small --cameras 0 --out /tmp/dome_never_written", "--cameras: expected 1.."},
      {"--preset small --width 0 --out /tmp/dome_never_written",
       "--width: expected an image width"},
      {"--preset small --out /proc/dome_take", "/proc/dome_take: cannot create the take folder"},
  };
  for (const auto& c : cases) {
    const Result r = RunDomeBinary(std::string("synth ") + c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists("/tmp/dome_never_written"));
}

// Smoothing and speckle flags are checked before any take is opened or any work runs.
TEST(Cli, SmoothingAndSpeckleFlagsNameTheField) {
  const struct {
    const char* args;
    const char* message;
  } cases[] = {
      {"fuse /nonexistent --out /tmp/dome_never_written --smooth-iterations -2",
       "fuse: smooth_iterations: must be >= 0"},
      {"run /nonexistent --out /tmp/dome_never_written --smooth-iterations -1",
       "session: smooth_iterations: must be >= 0"},
      {"stereo /nonexistent --out /tmp/dome_never_written --speckle-area 100",
       "speckle_step_mm: must be positive when speckle_area_px is set"},
      {"stereo /nonexistent --out /tmp/dome_never_written --speckle-area -3",
       "speckle_area_px: must be >= 0"},
  };
  for (const auto& c : cases) {
    const Result r = RunDomeBinary(c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists("/tmp/dome_never_written"));
}

TEST(Cli, SynthSmallTakePassesInfo) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take";
  const Result synth = RunDomeBinary("synth --preset small --instants 1 --out " + take.string());
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  const Result info = RunDomeBinary("info " + take.string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("rig: 6 camera(s), source synthetic"), std::string::npos)
      << info.output;
  EXPECT_NE(info.output.find("truth: 1 instant(s)"), std::string::npos) << info.output;
}

}  // namespace
}  // namespace dome
