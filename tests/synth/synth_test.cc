#include "synth/synth.h"

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "brute_force_ray.h"
#include "calib.pb.h"
#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "synth/calib_target.h"
#include "synth/dome_rig.h"
#include "synth/noise.h"
#include "synth/render.h"
#include "synth/scene.h"
#include "take/take.h"
#include "take/validate.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::synth {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;

// The small preset, generated once for all tests (seed 1, two threads).
struct SmallTake {
  dome::testing::TempDir tmp;  // in a static: removed when the test program exits
  fs::path dir = tmp / "small";
  SynthSummary summary;
  SmallTake() {
    SynthOptions options;
    options.preset = "small";
    options.threads = 2;
    summary = GenerateTake(options, dir);
  }
};
const SmallTake& Small() {
  static const SmallTake take;
  return take;
}

std::map<std::string, std::string> ReadTree(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file())
      files[fs::relative(e.path(), dir).string()] = io::ReadFileBytes(e.path());
  }
  return files;
}

template <typename Message>
Message ReadJson(const fs::path& path) {
  Message m;
  const auto status = google::protobuf::util::JsonStringToMessage(io::ReadFileBytes(path), &m);
  EXPECT_TRUE(status.ok()) << path << ": " << status.ToString();
  return m;
}

bool BruteForce(const io::Mesh& mesh, const Vector3d& o, const Vector3d& d, double* t_best) {
  const dome::testing::BruteForceHit hit = dome::testing::BruteForceIntersect(mesh, o, d);
  *t_best = hit.t;
  return hit.hit();
}

TEST(Synth, SmallTakeIsValidAndComplete) {
  const SmallTake& small = Small();
  const take::TakeReport report = take::ValidateTake(small.dir);
  EXPECT_TRUE(report.ok()) << report.Summary();
  EXPECT_EQ(report.rig.cameras.size(), 6u);
  ASSERT_EQ(report.instants.size(), 3u);
  EXPECT_EQ(report.instants[0], "00-00-10-00");
  EXPECT_EQ(report.instants[1], "00-00-10-05");
  EXPECT_EQ(report.truth_instants, 3);
  EXPECT_TRUE(report.has_calib);
  for (const auto& instant : report.instants) {
    for (const auto& cam : report.rig.cameras) {
      const cv::Mat tape = io::ReadImage(small.dir / "tape" / instant / (cam.model.id + ".png"),
                                         io::ImageMode::kGray8);
      EXPECT_EQ(tape.cols, 320);
      EXPECT_EQ(tape.rows, 240);
    }
  }
  EXPECT_EQ(small.summary.truth_mesh_faces > 5000, true);
  EXPECT_EQ(small.summary.stage1_points_min, 147);
  // every camera sees the floor's whole grid and some of the plain marks around it
  EXPECT_GT(small.summary.stage2_points_min, 25);
  EXPECT_LE(small.summary.stage2_points_min, static_cast<int>(AllFloorMarkPoints().size()));
  EXPECT_GT(small.summary.bat_px_median, 1.0);
  EXPECT_NE(small.summary.BriefReport().find("6 cameras"), std::string::npos);
}

TEST(Synth, SameOptionsGiveByteIdenticalTakesWhateverTheThreads) {
  SynthOptions options;
  options.preset = "small";
  options.threads = 1;
  const dome::testing::TempDir tmp_dir;
  const fs::path dir = tmp_dir / "single";
  GenerateTake(options, dir);
  const auto a = ReadTree(Small().dir), b = ReadTree(dir);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [name, bytes] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(b.at(name) == bytes) << name << " differs";
  }
  fs::remove_all(dir);
}

TEST(Synth, AnotherSeedChangesTheNoiseOnly) {
  SynthOptions options;
  options.preset = "small";
  options.seed = 2;
  const dome::testing::TempDir tmp_dir;
  const fs::path dir = tmp_dir / "seed2";
  GenerateTake(options, dir);
  const auto a = ReadTree(Small().dir), b = ReadTree(dir);
  ASSERT_EQ(a.size(), b.size());
  int images = 0;
  for (const auto& [name, bytes] : a) {
    // Rendered images carry noise; truth (the person's masks included) does not.
    const bool image = name.size() > 4 && name.substr(name.size() - 4) == ".png" &&
                       name.rfind("truth/", 0) != 0;
    if (!image) {
      EXPECT_TRUE(b.at(name) == bytes) << name << " should not depend on the seed";
      continue;
    }
    ++images;
    const cv::Mat x = io::ReadImage(Small().dir / name, io::ImageMode::kGray8);
    const cv::Mat y = io::ReadImage(dir / name, io::ImageMode::kGray8);
    cv::Mat diff;
    cv::absdiff(x, y, diff);
    double max_diff;
    cv::minMaxLoc(diff, nullptr, &max_diff);
    EXPECT_GT(cv::countNonZero(diff), static_cast<int>(diff.total() / 3)) << name;
    EXPECT_LE(max_diff, 20.0) << name;  // noise (sigma <= 3), not content
    EXPECT_LT(cv::mean(diff)[0], 3.5) << name;
  }
  EXPECT_GT(images, 30);
  fs::remove_all(dir);
}

// truth/<instant>/depth/<camera>.tiff against the truth mesh.ply: each pixel's depth
// is the z-depth of the closest mesh triangle on its ray.
TEST(Synth, TruthDepthMapsAgreeWithTheTruthMesh) {
  const SmallTake& small = Small();
  const take::Take take = take::OpenTake(small.dir);
  Rng rng(9);
  int checked = 0;
  for (const auto& instant : take.instants) {
    const io::Mesh mesh = io::ReadPly(take.TruthMeshPath(instant));
    if (instant == take.instants.front()) {
      EXPECT_EQ(static_cast<int>(mesh.faces.size()), small.summary.truth_mesh_faces);
    }
    for (const auto& cam : take.rig.cameras) {
      const cv::Mat depth = io::ReadDepthTiff(take.TruthDepthPath(instant, cam.model.id));
      const CameraRays rays(cam.model);
      for (int i = 0; i < 12; ++i) {
        const int x = static_cast<int>(rng.Uniform(0, depth.cols));
        const int y = static_cast<int>(rng.Uniform(0, depth.rows));
        const Vector3d d = rays.Direction(x, y);
        double t;
        if (!BruteForce(mesh, rays.origin(), d, &t)) {
          EXPECT_EQ(depth.at<float>(y, x), 0.0f);
          continue;
        }
        const double z = cam.model.WorldToCamera(rays.origin() + t * d).z();
        EXPECT_NEAR(depth.at<float>(y, x), z, 1e-4 * z) << instant << " " << cam.model.id;
        ++checked;
      }
      // And the other way: the depth map never sees through the mesh -- no vertex lies
      // in front of every surface the 3x3 pixels around its projection see.
      int seen = 0;
      for (size_t v = 0; v < mesh.vertices.size(); v += 3) {
        const Vector3d p = mesh.vertices[v].cast<double>();
        Vector2d px;
        if (!cam.model.Project(p, &px)) continue;
        const int x = static_cast<int>(std::lround(px.x())),
                  y = static_cast<int>(std::lround(px.y()));
        if (x < 1 || y < 1 || x >= depth.cols - 1 || y >= depth.rows - 1) continue;
        const double z = cam.model.WorldToCamera(p).z();
        float nearest = std::numeric_limits<float>::infinity(), farthest = 0.0f;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const float d = depth.at<float>(y + dy, x + dx);
            if (d > 0) nearest = std::min(nearest, d);
            farthest = std::max(farthest, d);
          }
        }
        // A pixel's size at that depth bounds how far a convex surface bulges
        // between the pixel centres around a vertex.
        const double pixel_mm = z * cam.model.sensor.dpx_mm() / cam.model.focal_mm;
        EXPECT_GE(z, nearest - pixel_mm) << instant << " " << cam.model.id << " vertex " << v;
        if (z >= nearest - pixel_mm && z <= farthest + pixel_mm) ++seen;
      }
      EXPECT_GT(seen, 50);
    }
  }
  EXPECT_GT(checked, 150);
}

// The written images are the noise-free rendering of the scene (whose pixels agree
// with the texture exactly, render_test) plus the camera's sensor noise.
TEST(Synth, ImagesAreTheTexturedSceneWithSensorNoise) {
  const SmallTake& small = Small();
  DomeRigOptions rig_options;
  rig_options.cameras = 6;
  rig_options.width_px = 160;
  rig_options.height_px = 120;
  const auto cameras = MakeDomeRig(rig_options);
  const int k = 1;
  const SceneMesh first = BuildDomeScene(InstantTimeS(k));
  const SceneMesh second = BuildDomeScene(InstantTimeS(k) + kFieldDelayS);
  const RayCaster c1(first), c2(second);
  const Lighting lighting = DomeLighting();
  for (const auto& cam : cameras) {
    RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.response.noise_sigma = 0.0;
    request.first_field = &c1;
    request.second_field = &c2;
    request.lighting = &lighting;
    const RenderedView clean = RenderView(request);
    const cv::Mat image = io::ReadImage(
        small.dir / "frames" / InstantName(k) / (cam.rig.model.id + ".png"), io::ImageMode::kGray8);
    cv::Mat a, b;
    image.convertTo(a, CV_64F);
    clean.image.convertTo(b, CV_64F);
    const cv::Mat diff = a - b;
    cv::Scalar mean, sd;
    cv::meanStdDev(diff, mean, sd);
    EXPECT_NEAR(mean[0], 0.0, 0.3) << cam.rig.model.id;
    // Two samples averaged: sigma / sqrt(2), plus rounding.
    EXPECT_NEAR(sd[0], cam.response.noise_sigma / std::sqrt(2.0), 0.35) << cam.rig.model.id;
    double max_abs;
    cv::minMaxLoc(cv::abs(diff), nullptr, &max_abs);
    EXPECT_LE(max_abs, 5.0 * cam.response.noise_sigma);
  }
}

// The taped frame interlaces two fields 1/60 s apart: its even rows are the take
// image's field; its odd rows differ from a motionless frame only on the person.
TEST(Synth, TapeFramesCarryTheSecondFieldsMotion) {
  const SmallTake& small = Small();
  DomeRigOptions rig_options;
  rig_options.cameras = 6;
  rig_options.width_px = 160;
  rig_options.height_px = 120;
  const auto cameras = MakeDomeRig(rig_options);
  const int k = 2;
  const SceneMesh first = BuildDomeScene(InstantTimeS(k));
  const SceneMesh second = BuildDomeScene(InstantTimeS(k) + kFieldDelayS);
  const RayCaster c1(first), c2(second);
  const Lighting lighting = DomeLighting();
  int moving = 0;
  for (size_t c = 0; c < cameras.size(); ++c) {
    const auto& cam = cameras[c];
    const cv::Mat tape = io::ReadImage(
        small.dir / "tape" / InstantName(k) / (cam.rig.model.id + ".png"), io::ImageMode::kGray8);
    RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.first_field = request.second_field = &c1;  // no motion
    request.lighting = &lighting;
    request.noise_key = NoiseKey(1, 1, k, c);
    request.person_mask = true;
    request.depth = false;
    const RenderedView still = RenderView(request);
    request.second_field = &c2;
    const RenderedView moved = RenderView(request);
    EXPECT_EQ(cv::countNonZero(moved.frame != tape), 0)
        << "the tape frame is the interlaced render";
    for (int r = 0; r < tape.rows; ++r) {
      for (int j = 0; j < tape.cols; ++j) {
        const bool same = tape.at<uint8_t>(r, j) == still.frame.at<uint8_t>(r, j);
        if (r % 2 == 0) {
          ASSERT_TRUE(same) << "first field differs at " << j << "," << r;
        } else if (!same) {
          ++moving;
          // Only where the person is, at t or at t + 1/60 s.
          EXPECT_TRUE(still.on_person.at<uint8_t>(r, j) != 0 ||
                      moved.on_person.at<uint8_t>(r, j) != 0)
              << cam.rig.model.id << " " << j << "," << r;
        }
      }
    }
    // Rows of the take image are the tape's even rows, column pairs averaged.
    const cv::Mat image = io::ReadImage(
        small.dir / "frames" / InstantName(k) / (cam.rig.model.id + ".png"), io::ImageMode::kGray8);
    for (int y = 0; y < image.rows; y += 7) {
      for (int x = 0; x < image.cols; ++x) {
        EXPECT_EQ(image.at<uint8_t>(y, x),
                  (tape.at<uint8_t>(2 * y, 2 * x) + tape.at<uint8_t>(2 * y, 2 * x + 1) + 1) / 2);
      }
    }
  }
  EXPECT_GT(moving, 30);
}

TEST(Synth, CalibrationTruthIsConsistent) {
  const SmallTake& small = Small();
  const take::Take take = take::OpenTake(small.dir);
  const auto object = ReadJson<proto::TargetPoints>(small.dir / "calib/stage1/target.json");
  const auto floor = ReadJson<proto::TargetPoints>(small.dir / "calib/stage2/target.json");
  EXPECT_EQ(object.points_size(), 147);
  EXPECT_EQ(object.frame(), "object");
  EXPECT_EQ(floor.points_size(), static_cast<int>(AllFloorMarkPoints().size()));
  EXPECT_EQ(floor.grid_points(), 25u);
  EXPECT_EQ(floor.frame(), "world");
  // Stage 1: 3D points with depth variation (not coplanar).
  double spread[3] = {0, 0, 0};
  for (const auto& p : object.points()) {
    spread[0] = std::max(spread[0], p.x_mm());
    spread[1] = std::max(spread[1], p.y_mm());
    spread[2] = std::max(spread[2], p.z_mm());
  }
  EXPECT_EQ(spread[0], 700.0);
  EXPECT_EQ(spread[2], 700.0);
  for (const auto& cam : take.rig.cameras) {
    for (const char* stage : {"stage1", "stage2"}) {
      const bool one = std::string(stage) == "stage1";
      const auto view =
          ReadJson<proto::CalibView>(small.dir / "calib" / stage / (cam.model.id + ".json"));
      EXPECT_EQ(view.camera(), cam.model.id);
      EXPECT_EQ(view.source(), "truth");
      const cv::Mat image =
          io::ReadImage(small.dir / "calib" / stage / view.image(), io::ImageMode::kGray8);
      geometry::TsaiCamera posed = cam.model;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
          posed.rotation(r, c) = view.target_to_camera().rotation(3 * r + c);
      }
      for (int k = 0; k < 3; ++k)
        posed.translation_mm[k] = view.target_to_camera().translation_mm(k);
      if (!one) {
        EXPECT_LT((posed.rotation - cam.model.rotation).norm(), 1e-12);
      }
      const auto& target = one ? object : floor;
      std::map<int, Vector3d> points;
      for (const auto& p : target.points()) points[p.id()] = Vector3d(p.x_mm(), p.y_mm(), p.z_mm());
      if (one) {
        EXPECT_EQ(view.points_size(), 147) << cam.model.id << " " << stage;
      } else {  // the grid's 25 marks and some of the plain marks
        EXPECT_GT(view.points_size(), 25) << cam.model.id << " " << stage;
        for (int i = 0; i < 25; ++i) EXPECT_EQ(view.points(i).id(), static_cast<uint32_t>(i));
      }
      double dark = 0, light = 0;
      for (const auto& q : view.points()) {
        Vector2d px;
        ASSERT_TRUE(posed.Project(points.at(q.id()), &px));
        EXPECT_NEAR(px.x(), q.x_px(), 1e-6);
        EXPECT_NEAR(px.y(), q.y_px(), 1e-6);
        dark += image.at<uint8_t>(static_cast<int>(std::lround(q.y_px())),
                                  static_cast<int>(std::lround(q.x_px())));
      }
      // The marker centres are dark: far darker than the image around them.
      dark /= std::max(1, view.points_size());
      light = cv::mean(image)[0];
      EXPECT_LT(dark, 0.6 * light) << cam.model.id << " " << stage;
    }
  }
}

TEST(Synth, BadOptionsAndFoldersGiveClearErrors) {
  SynthOptions options;
  options.preset = "huge";
  testing::ExpectInputError([&] { options.Resolve(); }, {"--preset", "huge", "paper", "small"});
  options = SynthOptions();
  options.cameras = 0;
  testing::ExpectInputError([&] { options.Resolve(); }, {"--cameras", "got 0"});
  options = SynthOptions();
  options.width_px = 0;
  testing::ExpectInputError([&] { options.Resolve(); }, {"--width", "got 0"});
  options = SynthOptions();
  options.height_px = 0;
  testing::ExpectInputError([&] { options.Resolve(); }, {"--height", "got 0"});
  options = SynthOptions();
  options.instants = 0;
  testing::ExpectInputError([&] { options.Resolve(); }, {"--instants", "got 0"});
  options = SynthOptions();
  options.threads = -1;
  testing::ExpectInputError([&] { options.Resolve(); }, {"--threads"});
  // Bad options fail before anything is written.
  const dome::testing::TempDir tmp_untouched;
  const fs::path untouched = tmp_untouched / "untouched";
  options = SynthOptions();
  options.cameras = 0;
  testing::ExpectInputError([&] { GenerateTake(options, untouched); }, {"--cameras"});
  EXPECT_FALSE(fs::exists(untouched));

  // An output folder that cannot be created: under a regular file.
  const dome::testing::TempDir tmp_file;
  const fs::path file = tmp_file / "file";
  io::WriteFileAtomically(file, "not a folder");
  options = SynthOptions();
  options.preset = "small";
  testing::ExpectInputError([&] { GenerateTake(options, file / "take"); },
                            {(file / "take").string()});
  fs::remove(file);
  // An existing take is not replaced without overwrite.
  testing::ExpectInputError([&] { GenerateTake(options, Small().dir); },
                            {"rig.json", "--overwrite"});
}

TEST(Synth, OverwriteReplacesAnOlderTake) {
  const dome::testing::TempDir tmp_dir;
  const fs::path dir = tmp_dir / "overwrite";
  SynthOptions options;
  options.preset = "small";
  options.cameras = 3;
  options.instants = 2;
  options.width_px = 64;
  options.height_px = 48;
  GenerateTake(options, dir);
  options.cameras = 2;  // fewer cameras: the old ones' files must go
  options.instants = 1;
  options.overwrite = true;
  options.write_tape = false;
  GenerateTake(options, dir);
  const take::TakeReport report = take::ValidateTake(dir);
  EXPECT_TRUE(report.ok()) << report.Summary();
  EXPECT_EQ(report.rig.cameras.size(), 2u);
  EXPECT_EQ(report.instants.size(), 1u);
  EXPECT_FALSE(fs::exists(dir / "tape"));
  EXPECT_FALSE(fs::exists(dir / "calib" / "stage1" / "c02.png"));
  fs::remove_all(dir);
}

TEST(Synth, InstantNamesAreVitcTimecodesAt6Hz) {
  EXPECT_EQ(InstantName(0), "00-00-10-00");
  EXPECT_EQ(InstantName(5), "00-00-10-25");
  EXPECT_EQ(InstantName(6), "00-00-11-00");
  EXPECT_EQ(InstantName(10), "00-00-11-20");
  EXPECT_DOUBLE_EQ(InstantTimeS(6), 1.0);
  EXPECT_DOUBLE_EQ(kFieldDelayS, 1.0 / 60.0);
}

}  // namespace
}  // namespace dome::synth
