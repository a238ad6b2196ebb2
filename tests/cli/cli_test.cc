// The executables as a user runs them: exit codes and messages.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/json.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "take_fixture.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome {
namespace {

namespace fs = std::filesystem;

using dome::testing::RunDomeBinary;
using Result = dome::testing::CommandResult;

// The small synthetic take of `instants` instants (no tape, no calibration images) at
// `take`; false, with the output, when dome synth fails.
bool SynthSmallTake(const fs::path& take, int instants) {
  const Result r = RunDomeBinary("synth --preset small --instants " + std::to_string(instants) +
                                 " --no-tape --no-calib --out " + take.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return r.exit_code == 0;
}

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

// A negative worker count is refused before the take is read (0 lets dome run choose).
TEST(Cli, RunRefusesANegativeWorkerCount) {
  const Result r = RunDomeBinary("run /nonexistent/take --out /tmp/dome_never_written --workers -1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("--workers: must be 0 (from the session) or more"), std::string::npos)
      << r.output;
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

// DOME_MAX_SIMD holds the cost kernel to a lower path. AVX2 gives the same depth maps
// to the byte as AVX-512 (this small take's neighbours are not pre-warped, so the exact
// warp runs: its homogeneous division must round alike on both); the scalar path, on
// the float images, agrees only up to their rounding (cost_kernel.h), so it is only
// run. A value it does not know is named.
TEST(Cli, MaxSimdChangesNoDepthAndNamesABadValue) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take";
  ASSERT_TRUE(SynthSmallTake(take, 1));
  auto stereo = [&](const char* simd, const std::string& out) {
    if (simd != nullptr) setenv("DOME_MAX_SIMD", simd, 1);
    const Result r = RunDomeBinary("stereo " + take.string() + " --camera c00 --out " + out);
    unsetenv("DOME_MAX_SIMD");
    return r;
  };
  const Result plain = stereo(nullptr, (tmp / "plain").string());
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  std::vector<fs::path> maps;
  for (const auto& e : fs::recursive_directory_iterator(tmp / "plain"))
    if (e.path().extension() == ".tiff") maps.push_back(fs::relative(e.path(), tmp / "plain"));
  ASSERT_FALSE(maps.empty());
  const Result avx2 = stereo("avx2", (tmp / "avx2").string());
  ASSERT_EQ(avx2.exit_code, 0) << avx2.output;
  for (const auto& m : maps)
    EXPECT_TRUE(io::ReadFileBytes(tmp / "avx2" / m) == io::ReadFileBytes(tmp / "plain" / m)) << m;
  const Result scalar = stereo("scalar", (tmp / "scalar").string());
  ASSERT_EQ(scalar.exit_code, 0) << scalar.output;
  for (const auto& m : maps) EXPECT_TRUE(fs::exists(tmp / "scalar" / m)) << m;
  const Result bad = stereo("sse4", (tmp / "bad").string());
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  EXPECT_NE(bad.output.find("DOME_MAX_SIMD: must be avx512, avx2 or scalar, got 'sse4'"),
            std::string::npos)
      << bad.output;
}

// `dome masks`: plates of a synthetic take, one line per camera with its IoU against the
// truth masks; the given masks folder is never an output; too few instants without
// plates is named.
TEST(Cli, MasksFromPlatesAndTheirErrors) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take";
  ASSERT_TRUE(SynthSmallTake(take, 2));
  EXPECT_NE(RunDomeBinary("info " + take.string()).output.find("background plates: 6"),
            std::string::npos);
  const Result masks = RunDomeBinary("masks " + take.string() + " --threads 2");
  ASSERT_EQ(masks.exit_code, 0) << masks.output;
  EXPECT_NE(masks.output.find("masks of 6 camera(s) x 2 instant(s) in " +
                              (take / "masks-derived").string()),
            std::string::npos)
      << masks.output;
  EXPECT_NE(masks.output.find("  c05            plate  foreground"), std::string::npos)
      << masks.output;
  EXPECT_NE(masks.output.find("IoU vs truth over 12 masks: mean 0.9"), std::string::npos)
      << masks.output;
  EXPECT_TRUE(fs::exists(take / "masks-derived" / "00-00-10-05" / "c03.png"));
  const Result onto_given =
      RunDomeBinary("masks " + take.string() + " --out " + (take / "masks").string());
  EXPECT_EQ(onto_given.exit_code, 1);
  EXPECT_NE(onto_given.output.find("is the take's given masks folder"), std::string::npos)
      << onto_given.output;
  fs::remove_all(take / "background");
  const Result no_median = RunDomeBinary("masks " + take.string());
  EXPECT_EQ(no_median.exit_code, 1);
  EXPECT_NE(no_median.output.find("2 instant(s): a median background needs at least 3"),
            std::string::npos)
      << no_median.output;
}

// `dome calibrate --points`: each missing or contradictory flag and each degenerate
// point file is named, exit 1, and no rig is written.
// A Linux folder name may be any bytes: a take and an output folder named with byte
// 0xE9 (not UTF-8) run like any other, the paths crossing the runtime's wire unchanged.
TEST(Cli, RunOnFoldersWhoseNamesAreNotUtf8) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take\xE9", out = tmp / "out\xE9";
  ASSERT_EQ(RunDomeBinary("synth --preset small --instants 1 --no-tape --no-calib --out '" +
                          take.string() + "'")
                .exit_code,
            0);
  const Result r = RunDomeBinary("run '" + take.string() + "' --out '" + out.string() +
                                 "' --workers 2 --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "00-00-10-00" / "mesh_decimated.ply")) << r.output;
  EXPECT_EQ(r.output.find("not a dome runtime envelope"), std::string::npos) << r.output;
}

// The small dome is a sparse rig with plates: the session derives the photo hull's
// carving and says so, `--no-photo-carve` turns it off (in session.json and the notes),
// and the carving changes the surface.
TEST(Cli, PhotoCarvingIsDerivedOnASparseRigAndItsFlagTurnsItOff) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take";
  ASSERT_TRUE(SynthSmallTake(take, 1));
  auto run = [&](const std::string& name, const std::string& flags) {
    const fs::path out = tmp / name;
    const Result r = RunDomeBinary("run " + take.string() + " --out " + out.string() +
                                   " --workers 1 --threads 2 --no-texture --no-preview" + flags);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return out;
  };
  const fs::path on = run("on", ""), off = run("off", " --no-photo-carve");
  const std::string session_on = io::ReadFileBytes(on / "session.json");
  const std::string session_off = io::ReadFileBytes(off / "session.json");
  EXPECT_NE(session_on.find("\"photo_carve\": true"), std::string::npos) << session_on;
  EXPECT_NE(session_off.find("\"photo_carve\": false"), std::string::npos) << session_off;
  EXPECT_NE(io::ReadFileBytes(on / "report.json").find("hull surface true, photo carving true"),
            std::string::npos);
  EXPECT_NE(io::ReadFileBytes(off / "report.json").find("hull surface true, photo carving false"),
            std::string::npos);
  EXPECT_NE(io::ReadFileBytes(on / "00-00-10-00" / "mesh.ply"),
            io::ReadFileBytes(off / "00-00-10-00" / "mesh.ply"));
}

// The small preset's calibration images are 160x120: its dots are a couple of pixels
// across, too few to calibrate from, and the error says that is the cause.
TEST(Cli, CalibratingImagesWithTinyDotsSaysTheDotsAreTooSmall) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take";
  ASSERT_EQ(
      RunDomeBinary("synth --preset small --instants 1 --no-tape --out " + take.string()).exit_code,
      0);
  const Result r = RunDomeBinary("calibrate " + take.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("(160x120 px) are only "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" px across, and calibration needs at least 3 px to place their "
                          "centres: capture or render the calibration images larger"),
            std::string::npos)
      << r.output;
}

TEST(Cli, CalibratePointsFlagsAndDegenerateFilesAreNamed) {
  const testing::TempDir tmp;
  const fs::path few = tmp / "few.txt", line = tmp / "line.txt", rig = tmp / "rig.json";
  {
    std::ofstream f(few);
    for (int i = 0; i < 6; ++i)
      f << i * 10 << " " << i * 7 << " 0 " << 100 + i << " " << 50 + i << "\n";
    std::ofstream l(line);
    for (int i = 0; i < 12; ++i)
      l << i * 10 << " " << i * 20 << " " << i * 5 << " " << 100 + i << " 50\n";
  }
  const std::string sensor = " --size 640 480 --sensor 640 640 0.01 0.01 --out " + rig.string();
  const struct {
    std::string args;
    const char* message;
  } cases[] = {
      {"--points " + few.string() + " --sensor 640 640 0.01 0.01",
       "--size: needs the image width and height (px)"},
      {"--points " + few.string() + " --size 640 480", "--sensor: needs the sensor constants"},
      {"/some/take --points " + few.string() + sensor, "TAKE: give a take or --points, not both"},
      {"--points " + few.string() + sensor, "needs at least 7 correspondences, got 6"},
      {"--points " + line.string() + sensor, "the points are collinear"},
      {"--points " + (tmp / "none.txt").string() + sensor, "none.txt"},
  };
  for (const auto& c : cases) {
    const Result r = RunDomeBinary("calibrate " + c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists(rig));
}

// The video and Panoptic import flags, checked before anything is written.
TEST(Cli, ImportFlagsNameTheFlag) {
  const testing::TempDir tmp;
  take::testing::WriteTake(tmp / "t", take::testing::MakeRingRig(2, 24, 16), 1);
  fs::create_directories(tmp / "videos");
  const std::string video = "import video " + (tmp / "t").string() + " " +
                            (tmp / "videos").string() + " --out " + (tmp / "out").string();
  const struct {
    std::string args;
    const char* message;
  } cases[] = {
      {video + " --offset c0", "--offset: expected CAMERA=VALUE, got 'c0'"},
      {video + " --offset c0=x", "--offset c0: expected a whole number of frames, got 'x'"},
      {video + " --offset c9=3", "--offset c9: no such camera in the rig"},
      {video + " --every 0", "--every: must be at least 1, got 0"},
      {video + " --fps 60", "--fps: must be 1..30"},
      {video + " --instants 3 --every 2", "--instants: cannot be combined with --range or --every"},
      {video, "c0.*: missing: camera 'c0' has no video"},
      {"import panoptic " + (tmp / "none.json").string() + " --out " + (tmp / "out").string(),
       "none.json: missing"},
  };
  for (const auto& c : cases) {
    const Result r = RunDomeBinary(c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << ": " << r.output;
  }
  EXPECT_FALSE(fs::exists(tmp / "out"));
}

TEST(Cli, ImportPanopticWholeDomeCalibrationIsARigOnlyTake) {
  const fs::path json = fs::path(DOME_SHARED_DIR) / "data/panoptic/calibration_160906_band1.json";
  if (!fs::exists(json)) GTEST_SKIP() << "no shared data at " << json;
  const testing::TempDir tmp;
  const Result r =
      RunDomeBinary("import panoptic " + json.string() + " --out " + (tmp / "dome").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("520 camera(s), rig only (no images)"), std::string::npos) << r.output;
}

// A take's instants (its frames/ folders), in order.
std::vector<std::string> SortedInstants(const fs::path& take) {
  std::vector<std::string> instants;
  for (const auto& e : fs::directory_iterator(take / "frames")) {
    instants.push_back(e.path().filename().string());
  }
  std::sort(instants.begin(), instants.end());
  return instants;
}

// Every camera's frame of instant `to` rewritten with the bytes of instant `from`'s.
void CopyFrames(const fs::path& take, const std::string& from, const std::string& to) {
  for (const auto& e : fs::directory_iterator(take / "frames" / from)) {
    fs::copy_file(e.path(), take / "frames" / to / e.path().filename(),
                  fs::copy_options::overwrite_existing);
  }
}

// Resume keys on the inputs' contents, not the take's path: a frame rewritten with
// other bytes redoes exactly its instant, and the outputs are those of a fresh run of
// the same session. With silhouettes (the synthetic take's plates): the derived volume
// is the masks' hull at the take's instants, so the rewritten frames would change it;
// the second run keeps the session the folder holds instead of deriving again.
TEST(Cli, RunAgainAfterAFrameChangedRedoesItsInstantOnly) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", out = tmp / "out", fresh = tmp / "fresh";
  ASSERT_EQ(RunDomeBinary("synth --preset small --instants 2 --out " + take.string()).exit_code, 0);
  const std::string flags = " --workers 2 --no-texture --no-preview";
  const Result first = RunDomeBinary("run " + take.string() + " --out " + out.string() + flags);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("derived silhouettes: volume true, stereo true, fusion true"),
            std::string::npos)
      << first.output;
  EXPECT_NE(first.output.find("shrunk to the bounding box of the masks' visual hull"),
            std::string::npos)
      << first.output;
  const std::vector<std::string> instants = SortedInstants(take);
  ASSERT_EQ(instants.size(), 2u);
  // The second instant's frames become the first's: other bytes, same paths.
  CopyFrames(take, instants[0], instants[1]);
  const Result again = RunDomeBinary("run " + take.string() + " --out " + out.string() + flags);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find((out / "session.json").string() +
                              ": the same take and options: its session kept"),
            std::string::npos)
      << again.output;
  EXPECT_NE(again.output.find("instant " + instants[1] + ": the take's rig or frames changed"),
            std::string::npos)
      << again.output;
  EXPECT_EQ(again.output.find("instant " + instants[0] + ": the take's rig or frames changed"),
            std::string::npos)
      << again.output;
  const core::Json report = core::Json::parse(io::ReadFileBytes(out / "report.json"));
  const int total = report.value("jobs", -1);
  ASSERT_GT(total, 0) << report.dump();
  EXPECT_EQ(report.value("jobs_resumed_from_journal", -1), total / 2) << report.dump();
  const Result scratch =
      RunDomeBinary("run " + (out / "session.json").string() + " --out " + fresh.string() + flags);
  ASSERT_EQ(scratch.exit_code, 0) << scratch.output;
  for (const auto& instant : instants) {
    for (const char* mesh : {"mesh.ply", "mesh_decimated.ply"}) {
      EXPECT_EQ(io::ReadFileBytes(out / instant / mesh), io::ReadFileBytes(fresh / instant / mesh))
          << instant << "/" << mesh;
    }
  }
  // The masks stage's jobs made the take's masks (silhouette::TakeMasks, as `dome masks`
  // makes them), the rewritten instant's from its new frames.
  const fs::path derived = tmp / "masks";
  ASSERT_EQ(RunDomeBinary("masks " + take.string() + " --out " + derived.string()).exit_code, 0);
  int compared = 0;
  for (const auto& instant : instants) {
    for (const auto& e : fs::directory_iterator(derived / instant)) {
      const cv::Mat want = io::ReadImage(e.path(), io::ImageMode::kGray8);
      const cv::Mat got =
          io::ReadImage(out / instant / "mask" / e.path().filename(), io::ImageMode::kGray8);
      ASSERT_EQ(got.size(), want.size()) << e.path();
      EXPECT_EQ(cv::countNonZero(got != want), 0) << e.path();
      ++compared;
    }
  }
  EXPECT_EQ(compared, 12);  // 6 cameras x 2 instants
}

// The line of a failed command that carries its error ("dome: ..."); "" when none.
std::string ErrorLine(const std::string& output) {
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("dome: ", 0) == 0) return line;
  }
  return "";
}

// A bad value given as a flag of `dome run` is refused like the same value in a session
// file (one place checks both: pipeline::ResolveSessionOptions), with the same message,
// exit code 1, and no output folder made. A voxel too fine for the volume names the
// volume derived from the take, not the seed's cube, which does not apply to it.
// Time-aware fusion adds each slab's previous evidence: when the middle instant of three
// changes, the first instant's slabs (dropped once the second had them) are made again
// for it, and every mesh is the one a fresh run makes.
TEST(Cli, TemporalFusionRunAgainRemakesThePreviousSlabsItNeeds) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", out = tmp / "out", fresh = tmp / "fresh";
  ASSERT_EQ(RunDomeBinary("synth --preset small --instants 3 --out " + take.string()).exit_code, 0);
  const std::string flags = " --workers 2 --no-texture --no-preview --temporal-fusion";
  const Result first = RunDomeBinary("run " + take.string() + " --out " + out.string() + flags);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  // The take has plates: the masks are on, and the run says what that does to the carry.
  EXPECT_NE(first.output.find("temporal.fusion with silhouettes.fusion"), std::string::npos)
      << first.output;
  const std::vector<std::string> instants = SortedInstants(take);
  ASSERT_EQ(instants.size(), 3u);
  CopyFrames(take, instants[0], instants[1]);
  const Result again = RunDomeBinary("run " + take.string() + " --out " + out.string() + flags);
  ASSERT_EQ(again.exit_code, 0) << again.output;
  // The second instant changed, and the third with it (its slabs hold the second's).
  EXPECT_NE(again.output.find("instant " + instants[1] + ": the take's rig or frames changed"),
            std::string::npos)
      << again.output;
  EXPECT_NE(again.output.find("instant " + instants[2] + ": the take's rig or frames changed"),
            std::string::npos)
      << again.output;
  const Result scratch =
      RunDomeBinary("run " + (out / "session.json").string() + " --out " + fresh.string() + flags);
  ASSERT_EQ(scratch.exit_code, 0) << scratch.output;
  for (const auto& instant : instants) {
    EXPECT_EQ(io::ReadFileBytes(out / instant / "mesh.ply"),
              io::ReadFileBytes(fresh / instant / "mesh.ply"))
        << instant;
  }
}

// Without masks a take of several instants gets time-aware fusion (derived:
// pipeline/derive.cc): the second instant's surface adds the first's evidence, the first
// is fused alone either way; --no-temporal-fusion turns it off.
TEST(Cli, TimeAwareFusionIsDerivedWithoutMasksAndTurnsOff) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", on = tmp / "on", off = tmp / "off";
  ASSERT_TRUE(SynthSmallTake(take, 2));
  const std::string flags = " --workers 2 --no-texture --no-preview --no-masks";
  const Result a = RunDomeBinary("run " + take.string() + " --out " + on.string() + flags);
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const Result b = RunDomeBinary("run " + take.string() + " --out " + off.string() + flags +
                                 " --no-temporal-fusion");
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_NE(a.output.find("derived temporal.fusion: true (several instants without fusion "
                          "masks: the still parts steadied)"),
            std::string::npos)
      << a.output;
  auto temporal = [](const fs::path& out) {
    return core::Json::parse(io::ReadFileBytes(out / "session.json"))["temporal"];
  };
  EXPECT_EQ(temporal(on)["fusion"], true) << temporal(on);
  EXPECT_EQ(temporal(off)["fusion"], false) << temporal(off);
  const std::vector<std::string> instants = SortedInstants(take);
  ASSERT_EQ(instants.size(), 2u);
  EXPECT_EQ(io::ReadFileBytes(on / instants[0] / "mesh.ply"),
            io::ReadFileBytes(off / instants[0] / "mesh.ply"));
  EXPECT_NE(io::ReadFileBytes(on / instants[1] / "mesh.ply"),
            io::ReadFileBytes(off / instants[1] / "mesh.ply"));
}

TEST(Cli, RunFlagsAreRefusedWithTheMessagesOfTheSameSessionFields) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", out = tmp / "out";
  ASSERT_TRUE(SynthSmallTake(take, 1));
  const struct {
    const char* flag;
    const char* field;  // the same value in a session file (JSON)
    const char* message;
  } cases[] = {
      {"--voxel-mm -20", R"("volume": {"voxel_size_mm": -20})",
       "dome: session: volume.voxel_size_mm: must be a positive number of mm, got -20"},
      {"--slab-planes -3", R"("slab_planes": -3)",
       "dome: session: slab_planes: must be positive, got -3"},
      {"--decimate-ratio 0", R"("decimate_ratio": 0)",
       "dome: session: decimate_ratio: must be in (0, 1], got 0"},
      // Settings in a section of the session file are named by their path there.
      {"--levels -5", R"("stereo": {"num_levels": -5})",
       "dome: session: stereo.num_levels: must be 0 (from the geometry) or 3..100000, got -5"},
      {"--windows 4", R"("stereo": {"window_sizes_px": [4]})",
       "dome: session: stereo.window_sizes_px: "},
      {"--truncation-mm -5", R"("fusion": {"truncation_mm": -5})",
       "dome: session: fusion.truncation_mm: must be a positive number of mm, got -5"},
      {"--voxel-mm 1.4e-06", R"("volume": {"voxel_size_mm": 1.4e-06})",
       "dome: session: volume.voxel_size_mm: 1.4e-06 mm makes "},
  };
  for (const auto& c : cases) {
    const Result flag =
        RunDomeBinary("run " + take.string() + " --out " + out.string() + " " + c.flag);
    const fs::path session = tmp / "session.json";
    std::ofstream(session) << "{\"take\": \"" << take.string() << "\", \"out\": \"" << out.string()
                           << "\", " << c.field << "}";
    const Result file = RunDomeBinary("run " + session.string());
    EXPECT_EQ(flag.exit_code, 1) << c.flag << ": " << flag.output;
    EXPECT_EQ(file.exit_code, 1) << c.field << ": " << file.output;
    EXPECT_EQ(ErrorLine(flag.output).rfind(c.message, 0), 0u) << c.flag << ": " << flag.output;
    EXPECT_EQ(ErrorLine(flag.output), ErrorLine(file.output)) << c.flag << " vs " << c.field;
    EXPECT_EQ(flag.output.find("seed"), std::string::npos) << c.flag << ": " << flag.output;
    if (std::string(c.flag).find("1.4e-06") != std::string::npos) {
      EXPECT_NE(flag.output.find("voxels along an axis of the volume derived from the take, "),
                std::string::npos)
          << flag.output;
    }
    EXPECT_FALSE(fs::exists(out)) << c.flag;
  }
}

// A frame of a camera that rig.json does not have: `dome run` refuses the take with
// the message `dome info` gives for it, and makes no output folder.
TEST(Cli, RunRefusesAFrameOfACameraNotInTheRigWithInfosMessage) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", out = tmp / "out";
  ASSERT_TRUE(SynthSmallTake(take, 1));
  const fs::path instant = fs::directory_iterator(take / "frames")->path();
  const fs::path frame = fs::directory_iterator(instant)->path();
  fs::copy_file(frame, instant / ("stranger" + frame.extension().string()));
  const Result info = RunDomeBinary("info " + take.string());
  const Result run = RunDomeBinary("run " + take.string() + " --out " + out.string());
  EXPECT_EQ(info.exit_code, 1) << info.output;
  EXPECT_EQ(run.exit_code, 1) << run.output;
  const std::string named = "frames/" + instant.filename().string() + "/stranger";
  EXPECT_NE(info.output.find(named), std::string::npos) << info.output;
  EXPECT_NE(run.output.find(named), std::string::npos) << run.output;
  // The problem line of info, in run's error.
  std::istringstream in(info.output);
  std::string problem;
  for (std::string line; std::getline(in, line);) {
    if (line.find(named) != std::string::npos) problem = line;
  }
  const std::string message = problem.substr(problem.find(named));
  EXPECT_NE(run.output.find(message), std::string::npos) << message << " | " << run.output;
  EXPECT_FALSE(fs::exists(out));
}

// A volume that misses the scene ends "done" with empty surfaces: report.json counts
// them per instant and in all, and `dome run` ends with a warning naming the instants
// and the volume.
TEST(Cli, RunWhoseVolumeMissesTheSceneCountsAndNamesTheEmptyInstants) {
  const testing::TempDir tmp;
  const fs::path take = tmp / "take", out = tmp / "out";
  ASSERT_TRUE(SynthSmallTake(take, 2));
  // Above the actor, in every camera's view: empty space.
  const Result r = RunDomeBinary("run " + take.string() + " --out " + out.string() +
                                 " --workers 2 --no-texture --no-preview --box -300 -300 2300 300 "
                                 "300 2700");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const core::Json report = core::Json::parse(io::ReadFileBytes(out / "report.json"));
  std::vector<std::string> instants;
  for (const auto& e : report.at("per_instant")) {
    EXPECT_EQ(e.value("surface_vertices", int64_t(-1)), 0) << e.dump();
    EXPECT_TRUE(e.value("empty_surface", false)) << e.dump();
    instants.push_back(e.at("instant").get<std::string>());
  }
  ASSERT_EQ(instants.size(), 2u) << report.dump();
  EXPECT_EQ(report.at("empty_surfaces").value("count", -1), 2) << report.dump();
  EXPECT_EQ(report.at("empty_surfaces").at("instants").get<std::vector<std::string>>(), instants);
  EXPECT_NE(r.output.find("2 of 2 instants ended with an empty surface (" + instants[0] + ", " +
                          instants[1] +
                          "): no camera saw a surface inside the volume [-300 "
                          "-300 2300] .. ["),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("] mm; it may miss the scene (dome run --box)"), std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace dome
