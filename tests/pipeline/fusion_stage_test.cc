// The fusion job (pipeline/jobs.h) with a worker's JobMemo: the slab jobs of
// one instant prepare the range images and tables once, give the same bytes as jobs
// run without a memo, and a job with other inputs is not served stale tables. The
// decimation job with ratio 1 returns the surface as extracted.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "fusion/integrate.h"
#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "net/content_hash.h"
#include "pipeline/jobs.h"
#include "pipeline/settings.h"
#include "pipeline/shared_fusion.h"
#include "pipeline/small_take_suite.h"
#include "pipeline/stage.h"
#include "pipeline/stages.h"
#include "take/take.h"
#include "testing/expect_error.h"

namespace dome::pipeline {
namespace {

class FusionStage : public SmallTakeSuite {
 protected:
  // The blobs of a fusion job at the take's instant: the rig, then one stereo output
  // per camera made from the ground-truth depth, `scale` times it for camera 0.
  static JobBlobs Blobs(double scale) {
    const take::Take take = take::OpenTake(TakeDir());
    const std::string instant = take.instants.front();
    JobBlobs blobs{std::make_shared<const std::string>(io::ReadFileBytes(take.dir / "rig.json"))};
    for (size_t c = 0; c < take.rig.cameras.size(); ++c) {
      const std::string& id = take.rig.cameras[c].model.id;
      stereo::StereoResult r;
      r.camera = id;
      stereo::RangeImage ri;
      ri.window_px = 7;
      ri.depth_mm = io::ReadDepthTiff(take.TruthDepthPath(instant, id));
      if (c == 0) ri.depth_mm *= scale;
      ri.reliability = cv::Mat::zeros(ri.depth_mm.size(), CV_32FC1);
      r.range_images.push_back(ri);
      blobs.push_back(std::make_shared<const std::string>(EncodeStereoOutput(r)));
    }
    return blobs;
  }

  // The jobs' volume: a 3 m cube of 50 mm voxels.
  static fusion::VolumeGrid Grid() {
    fusion::VolumeGrid grid;
    grid.origin_mm = Eigen::Vector3d(-1500, -1500, -500);
    grid.voxel_size_mm = 50;
    grid.nx = grid.ny = grid.nz = 60;
    return grid;
  }
  // Truncation and clamp of 3 voxels.
  static fusion::FusionOptions Options() {
    fusion::FusionOptions options;
    options.truncation_mm = options.front_clamp_mm = 3 * Grid().voxel_size_mm;
    return options;
  }

  // The fusion job of planes [k0, k1) over `blobs`; `temporal`: time-aware (its blobs
  // then go on with the previous slab and two frames per camera).
  static runtime::Job Job(const JobBlobs& blobs, int k0, int k1, bool temporal = false,
                          const std::function<void(runtime::FusionJob*)>& edit = nullptr) {
    const fusion::VolumeGrid grid = Grid();
    const fusion::FusionOptions options = Options();
    runtime::Job job;
    job.set_id("s/i/fusion/" + std::to_string(k0));
    job.set_threads(2);
    job.set_stage("fusion");
    runtime::FusionJob fj;
    fj.set_k0(k0);
    fj.set_k1(k1);
    *fj.mutable_volume() = ToVolume(grid);
    *fj.mutable_fusion() = ToFusionSettings(options);
    if (temporal) {
      TemporalUse use;
      use.fusion = true;
      *fj.mutable_temporal() = ToTemporalSettings(use);
    }
    if (edit) edit(&fj);
    job.set_settings(fj.SerializeAsString());
    for (const auto& b : blobs) job.add_blobs()->set_sha256(net::Sha256Hex(*b));
    return job;
  }

  static std::string Slab(const JobBlobs& blobs, int k0, int k1, JobMemo* memo,
                          bool temporal = false) {
    const auto outputs = RunJob(*DefaultStages(), Job(blobs, k0, k1, temporal), blobs, memo);
    EXPECT_EQ(outputs.size(), 1u);
    return outputs.at(0).data();
  }
};

// The slab jobs of an instant, on one worker or two (a memo each) of one process, prepare
// its tables once (shared_fusion.h), and give the bytes of jobs that prepare their own.
TEST_F(FusionStage, SlabJobsOfOneInstantPrepareOnceAndMatchJobsWithoutAMemo) {
  const JobBlobs blobs = Blobs(1.0);
  DropSharedPreparedFusions();
  const int64_t builds = SharedPreparedFusionBuilds();
  JobMemo memo;
  const int bounds[] = {0, 20, 37, 60};
  for (int s = 0; s < 3; ++s) {
    const std::string with = Slab(blobs, bounds[s], bounds[s + 1], &memo);
    const std::string without = Slab(blobs, bounds[s], bounds[s + 1], nullptr);
    EXPECT_EQ(with, without) << "slab " << s;
    // Not an empty slab: the surface passes through it or the free space before it.
    const fusion::Slab decoded = fusion::DecodeSlab(with, "slab");
    int64_t weighted = 0;
    for (float w : decoded.weight) weighted += w > 0;
    EXPECT_GT(weighted, 1000) << "slab " << s;
  }
  EXPECT_EQ(memo.builds(), 2);  // the parsed rig once, the slab buffers once
  JobMemo other_worker;
  EXPECT_EQ(Slab(blobs, 20, 37, &other_worker), Slab(blobs, 20, 37, nullptr));
  EXPECT_EQ(SharedPreparedFusionBuilds() - builds, 1) << "the tables once for both workers";
  EXPECT_EQ(other_worker.builds(), 1);  // its slab buffers only
}

// A time-aware slab job (FusionJob.temporal) adds its previous slab's evidence where the
// frames did not change (here the same frames at both instants); the instant's slabs
// share their tables whatever their previous slabs; a previous slab of other planes and
// a missing frame are named.
TEST_F(FusionStage, ATimeAwareSlabJobAddsItsPreviousSlabAndNamesWrongInputs) {
  const JobBlobs blobs = Blobs(1.0);
  const take::Take take = take::OpenTake(TakeDir());
  JobBlobs frames;
  for (const auto& rc : take.rig.cameras) {
    frames.push_back(std::make_shared<const std::string>(
        io::ReadFileBytes(take.FramePath(take.instants.front(), rc.model.id))));
  }
  auto with = [&](const std::string& previous, size_t drop_frames) {
    JobBlobs b = blobs;
    b.push_back(std::make_shared<const std::string>(previous));
    for (int t = 0; t < 2; ++t) b.insert(b.end(), frames.begin(), frames.end());
    b.resize(b.size() - drop_frames);
    return b;
  };
  const std::string before0 = Slab(blobs, 0, 30, nullptr), before1 = Slab(blobs, 30, 60, nullptr);
  JobMemo memo;
  const fusion::Slab plain = fusion::DecodeSlab(before0, "plain");
  const fusion::Slab carried =
      fusion::DecodeSlab(Slab(with(before0, 0), 0, 30, &memo, true), "carried");
  ASSERT_EQ(carried.weight.size(), plain.weight.size());
  int64_t observed = 0, doubled = 0;
  for (size_t i = 0; i < plain.weight.size(); ++i) {
    const float w = plain.weight[i];
    if (!(w > 0)) {
      EXPECT_EQ(carried.weight[i], 0.0f);  // unobserved stays unobserved
      continue;
    }
    ++observed;
    // Decay 1: W doubles where carried, the distance stays (the same evidence twice).
    if (carried.weight[i] == 2 * w) {
      ++doubled;
      EXPECT_NEAR(carried.distance_mm[i], plain.distance_mm[i], 1e-3f);
    } else {
      ASSERT_EQ(carried.weight[i], w) << i;
    }
  }
  EXPECT_GT(doubled, observed / 2) << doubled << " of " << observed;
  const int64_t builds = SharedPreparedFusionBuilds();
  Slab(with(before1, 0), 30, 60, &memo, true);
  // The tables once for both slabs whatever their previous slabs (shared_fusion.h).
  EXPECT_EQ(SharedPreparedFusionBuilds(), builds);
  dome::testing::ExpectInputError([&] { Slab(with(before1, 0), 0, 30, nullptr, true); },
                                  {"the previous instant's slab is planes 30..60"});
  dome::testing::ExpectInputError(
      [&] { Slab(with(before0, 1), 0, 30, nullptr, true); },
      {"the previous slab, two frames per camera", "got " + std::to_string(with(before0, 1).size())});
}

// With the hull and its photo-consistency carving, a slab job's blobs end with every
// camera's mask and then every camera's frame: the job fuses with them, and one frame
// short it is refused naming what it expected.
TEST_F(FusionStage, APhotoCarvedSlabJobTakesTheFramesAfterTheMasksAndNamesAMissingOne) {
  const take::Take take = take::OpenTake(TakeDir());
  const std::string instant = take.instants.front();
  JobBlobs with_masks = Blobs(1.0);
  for (const auto& rc : take.rig.cameras) {
    with_masks.push_back(std::make_shared<const std::string>(
        io::ReadFileBytes(take.dir / "truth" / instant / "mask" / (rc.model.id + ".png"))));
  }
  JobBlobs with_frames = with_masks;
  for (const auto& rc : take.rig.cameras) {
    with_frames.push_back(std::make_shared<const std::string>(
        io::ReadFileBytes(take.FramePath(instant, rc.model.id))));
  }
  auto run = [&](const JobBlobs& blobs, bool photo) {
    const runtime::Job job = Job(blobs, 0, 30, false, [&](runtime::FusionJob* fj) {
      fj->set_hull(true);
      fj->set_carve_votes(1);
      fj->set_min_views(2);
      fj->set_hull_surface(true);
      fj->set_photo_carve(photo);
    });
    const auto outputs = RunJob(*DefaultStages(), job, blobs, nullptr);
    EXPECT_EQ(outputs.size(), 1u);
    return fusion::DecodeSlab(outputs.at(0).data(), "slab");
  };
  const fusion::Slab hull = run(with_masks, false), carved = run(with_frames, true);
  ASSERT_EQ(carved.distance_mm.size(), hull.distance_mm.size());
  EXPECT_NE(carved.distance_mm, hull.distance_mm);  // the carving reaches the slab
  JobBlobs short_one = with_frames;
  short_one.pop_back();
  dome::testing::ExpectInputError(
      [&] { run(short_one, true); },
      {"one mask each, one frame each for the photo hull",
       "got " + std::to_string(short_one.size() - 1) + " blobs after the rig"});
}

// An entry of another kind (a stereo job's, between two slab jobs on one worker) leaves
// the slabs' buffers kept, and the instant's tables are not prepared again.
TEST_F(FusionStage, AnEntryOfAnotherKindBetweenSlabJobsLeavesTheirTables) {
  const JobBlobs blobs = Blobs(1.0);
  DropSharedPreparedFusions();
  const int64_t builds = SharedPreparedFusionBuilds();
  JobMemo memo;
  const std::string first = Slab(blobs, 0, 20, &memo);
  memo.Get<std::string>("other", [] { return std::make_unique<std::string>("frames"); });
  EXPECT_EQ(Slab(blobs, 20, 40, &memo), Slab(blobs, 20, 40, nullptr));
  EXPECT_EQ(memo.builds(), 3);  // the rig once, the slab buffers once, the other entry once
  EXPECT_EQ(SharedPreparedFusionBuilds() - builds, 1);
}

TEST_F(FusionStage, OtherInputsArePreparedAgainNotServedStale) {
  const JobBlobs blobs = Blobs(1.0), moved = Blobs(1.05);
  DropSharedPreparedFusions();
  const int64_t builds = SharedPreparedFusionBuilds();
  JobMemo memo;
  const std::string first = Slab(blobs, 10, 30, &memo);
  const std::string other = Slab(moved, 10, 30, &memo);
  EXPECT_EQ(SharedPreparedFusionBuilds() - builds, 2);  // the tables of each
  EXPECT_NE(first, other);
  EXPECT_EQ(other, Slab(moved, 10, 30, nullptr));
  // Both kept (the instant being fused and the next): the first is not prepared again.
  EXPECT_EQ(first, Slab(blobs, 10, 30, &memo));
  EXPECT_EQ(SharedPreparedFusionBuilds() - builds, 2);
}

// The job cuts each range image to the rectangle of its depths before building its
// tables; voxels projecting outside that rectangle had no depth to meet, so the slab is
// the one fusing the whole images (up to float rounding of the shifted image centre).
TEST_F(FusionStage, ImagesCutToTheirDepthsFuseAsTheWholeImages) {
  const JobBlobs blobs = Blobs(1.0);
  const take::Take take = take::OpenTake(TakeDir());
  std::vector<fusion::RangeImage> whole;
  for (const auto& rc : take.rig.cameras) {
    cv::Mat depth = io::ReadDepthTiff(take.TruthDepthPath(take.instants.front(), rc.model.id));
    // Only the middle of each image keeps depths, so the cut is a real one.
    const cv::Rect keep(depth.cols / 4, depth.rows / 4, depth.cols / 2, depth.rows / 2);
    cv::Mat cut = cv::Mat::zeros(depth.size(), CV_32FC1);
    depth(keep).copyTo(cut(keep));
    whole.push_back({rc.model, cut, cv::Mat(), rc.model.id});
  }
  // The same images through the job: stereo outputs of the cut depths.
  JobBlobs cut_blobs{blobs[0]};
  for (size_t c = 0; c < whole.size(); ++c) {
    stereo::StereoResult r;
    r.camera = take.rig.cameras[c].model.id;
    r.range_images.push_back(
        {7, whole[c].depth_mm, cv::Mat::zeros(whole[c].depth_mm.size(), CV_32FC1)});
    cut_blobs.push_back(std::make_shared<const std::string>(EncodeStereoOutput(r)));
  }
  const fusion::Slab job = fusion::DecodeSlab(Slab(cut_blobs, 20, 40, nullptr), "job");
  const fusion::Slab direct = fusion::Integrator(Grid(), whole, Options()).IntegrateSlab(20, 40);
  ASSERT_EQ(job.weight.size(), direct.weight.size());
  int64_t weighted = 0, differ = 0;
  for (size_t i = 0; i < job.weight.size(); ++i) {
    weighted += direct.weight[i] > 0;
    differ += std::abs(job.weight[i] - direct.weight[i]) > 1e-3f ||
              std::abs(job.distance_mm[i] - direct.distance_mm[i]) > 1e-2f;
  }
  EXPECT_GT(weighted, 1000);
  // A voxel on a triangle's edge may fall on the other side after the rounding.
  EXPECT_LE(differ, weighted / 1000) << differ << " of " << weighted << " voxels differ";
}

// The decimate job of `mesh` (the master's surface blob, returned in *blobs) with `dj`.
runtime::Job DecimateJobOf(const io::Mesh& mesh, const runtime::DecimateJob& dj, JobBlobs* blobs) {
  *blobs = {std::make_shared<const std::string>(EncodeMeshPly(mesh))};
  runtime::Job job;
  job.set_id("s/i/decimate");
  job.set_stage("decimate");
  job.add_blobs()->set_sha256(net::Sha256Hex(*(*blobs)[0]));
  job.set_settings(dj.SerializeAsString());
  return job;
}

// A stereo output carries only the rectangle of its depths; decoded, both maps are the
// whole images again, bit for bit (zeros outside), and an output without depths holds
// none. A rectangle that does not fit its image is refused, naming the field.
TEST(StereoOutput, CarriesTheRectangleOfItsDepthsAndDecodesToTheWholeImages) {
  stereo::StereoResult r;
  r.camera = "cam";
  r.num_levels = 50;
  stereo::RangeImage ri;
  ri.window_px = 7;
  ri.depth_mm = cv::Mat(120, 160, CV_32FC1, cv::Scalar(0));
  ri.reliability = cv::Mat(120, 160, CV_32FC1, cv::Scalar(0));
  cv::RNG rng(3);
  rng.fill(ri.depth_mm(cv::Rect(40, 30, 50, 20)), cv::RNG::UNIFORM, 900.0, 1100.0);
  rng.fill(ri.reliability(cv::Rect(40, 30, 50, 20)), cv::RNG::UNIFORM, 0.1, 3.0);
  ri.reliability.at<float>(70, 130) = 0.5f;  // a reliability alone widens the rectangle
  ri.density = 0.05;
  r.range_images.push_back(ri);
  stereo::RangeImage none = ri;
  none.depth_mm = cv::Mat(120, 160, CV_32FC1, cv::Scalar(0));
  none.reliability = none.depth_mm.clone();
  r.range_images.push_back(none);
  const std::string bytes = EncodeStereoOutput(r);
  EXPECT_LT(bytes.size(), size_t(91 * 41 * 8 + 200));  // 40..130 x 30..70, two maps
  const stereo::StereoResult back = DecodeStereoOutput(bytes, "test");
  ASSERT_EQ(back.range_images.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const auto& a = r.range_images[k];
    const auto& b = back.range_images[k];
    ASSERT_EQ(b.depth_mm.size(), cv::Size(160, 120));
    ASSERT_EQ(b.reliability.size(), cv::Size(160, 120));
    EXPECT_EQ(cv::norm(a.depth_mm, b.depth_mm, cv::NORM_INF), 0.0) << k;
    EXPECT_EQ(cv::norm(a.reliability, b.reliability, cv::NORM_INF), 0.0) << k;
  }
  // A result without a reliability map travels whole, as before.
  stereo::StereoResult bare = r;
  bare.range_images.resize(1);
  bare.range_images[0].reliability = cv::Mat();
  const stereo::StereoResult bare_back = DecodeStereoOutput(EncodeStereoOutput(bare), "test");
  EXPECT_EQ(cv::norm(bare_back.range_images.at(0).depth_mm, ri.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_TRUE(bare_back.range_images.at(0).reliability.empty());
  runtime::StereoOutput bad;
  ASSERT_TRUE(bad.ParseFromString(bytes));
  bad.mutable_range_images(0)->set_x0(120);
  dome::testing::ExpectInputError([&] { DecodeStereoOutput(bad.SerializeAsString(), "blob 3"); },
                   {"blob 3: depth_mm",
                    "a 91x41 rectangle at 120, 30 does not fit a 160x120 image"});
  bad.mutable_range_images(0)->set_x0(40);
  bad.mutable_range_images(0)->clear_full_rows();
  dome::testing::ExpectInputError([&] { DecodeStereoOutput(bad.SerializeAsString(), "blob 3"); },
                   {"blob 3: depth_mm", "needs all of full_rows, full_cols, x0 and y0, or none"});
}

// A fusion job makes each range image from the rectangle its stereo output carries
// (CutRangeImage), never the whole map: the same camera and depths as PrepareFusion's
// cut of the whole map, at the image's borders too; a map of another size than the
// camera's, or a bad value, named with the pixel in the whole map.
TEST_F(FusionStage, RangeImagesFromTheRectanglesAreThoseOfTheWholeMaps) {
  const take::Take take = take::OpenTake(TakeDir());
  const geometry::TsaiCamera camera = take.rig.cameras.at(0).model;
  const int W = camera.width_px, H = camera.height_px;
  ASSERT_GE(W, 40);
  ASSERT_GE(H, 30);
  // Depths inside the image, along its left and top border, and at its bottom-right
  // corner: the rectangle grown by a pixel is clipped differently in each.
  for (const cv::Rect depths :
       {cv::Rect(10, 8, 12, 9), cv::Rect(0, 0, 7, 5), cv::Rect(W - 7, H - 6, 7, 6)}) {
    stereo::StereoResult r;
    r.camera = camera.id;
    stereo::RangeImage ri;
    ri.window_px = 7;
    ri.depth_mm = cv::Mat(H, W, CV_32FC1, cv::Scalar(0));
    cv::RNG rng(11);
    rng.fill(ri.depth_mm(depths), cv::RNG::UNIFORM, 950.0, 1050.0);
    ri.depth_mm.at<float>(depths.y + 1, depths.x + 1) = 0.0f;  // a hole
    ri.reliability = cv::Mat(H, W, CV_32FC1, cv::Scalar(0));
    ri.reliability.at<float>(depths.y, std::min(depths.br().x + 2, W - 1)) = 1.0f;  // wider
    r.range_images.push_back(ri);
    std::vector<stereo::MapCut> cuts;
    const std::string bytes = EncodeStereoOutput(r);
    const stereo::StereoResult rects = DecodeStereoRects(bytes, "blob 2", &cuts);
    const std::optional<fusion::RangeImage> cut =
        CutRangeImage(camera, rects.range_images[0].depth_mm, cuts[0], "blob 2");
    ASSERT_TRUE(cut.has_value());
    fusion::FusionOptions options;
    options.num_threads = 1;
    const auto whole = PrepareFusion(Grid(), {{camera, ri.depth_mm, cv::Mat(), "blob 2"}}, options);
    ASSERT_EQ(whole->images.size(), 1u);
    const fusion::RangeImage& w = whole->images[0];
    EXPECT_EQ(cut->camera.cx_px, w.camera.cx_px) << depths;
    EXPECT_EQ(cut->camera.cy_px, w.camera.cy_px) << depths;
    EXPECT_EQ(cut->camera.width_px, w.camera.width_px) << depths;
    EXPECT_EQ(cut->camera.height_px, w.camera.height_px) << depths;
    ASSERT_EQ(cut->depth_mm.size(), w.depth_mm.size()) << depths;
    EXPECT_EQ(cv::norm(cut->depth_mm, w.depth_mm, cv::NORM_INF), 0.0) << depths;
  }
  // No depth: nothing to fuse.
  const cv::Mat empty;
  EXPECT_FALSE(CutRangeImage(camera, empty, {{0, 0}, {W, H}}, "blob 2").has_value());
  const std::string size = std::to_string(W) + "x" + std::to_string(H);
  dome::testing::ExpectInputError(
      [&] {
        CutRangeImage(camera, cv::Mat(3, 3, CV_32FC1, cv::Scalar(1000)), {{5, 5}, {W + 1, H}},
                      "blob 2");
      },
      {"blob 2", "depth map is " + std::to_string(W + 1) + "x" + std::to_string(H) +
                     " but camera " + camera.id + " is " + size});
  cv::Mat bad(3, 3, CV_32FC1, cv::Scalar(1000));
  bad.at<float>(2, 1) = -4.0f;
  dome::testing::ExpectInputError(
      [&] {
        CutRangeImage(camera, bad, {{5, 7}, {W, H}}, "blob 2");
      },
      {"blob 2", "depth at pixel (6, 9)"});
}

TEST(DecimateStage, RatioOneKeepsTheSurfaceAsExtracted) {
  // A wavy 20 x 20 grid of 800 triangles, as the master's surface blob.
  io::Mesh grid;
  for (int y = 0; y <= 20; ++y) {
    for (int x = 0; x <= 20; ++x) {
      grid.vertices.emplace_back(10.0f * x, 10.0f * y, 5.0f * std::sin(0.5f * x));
    }
  }
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 20; ++x) {
      const int v = y * 21 + x;
      grid.faces.emplace_back(v, v + 1, v + 22);
      grid.faces.emplace_back(v, v + 22, v + 21);
    }
  }
  runtime::DecimateJob dj;
  dj.set_ratio(1.0);
  JobBlobs blobs;
  runtime::Job job = DecimateJobOf(grid, dj, &blobs);
  const auto kept = RunJob(*DefaultStages(), job, blobs);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].data(), *blobs[0]);
  EXPECT_EQ(kept[1].name(), kDecimationJson);
  EXPECT_EQ(core::Json::parse(kept[1].data())["triangles_out"], 800);
  dj.set_ratio(0.25);
  job.set_settings(dj.SerializeAsString());
  const auto decimated = RunJob(*DefaultStages(), job, blobs);
  ASSERT_EQ(decimated.size(), 2u);
  EXPECT_EQ(io::ParsePly(decimated[0].data(), "decimated").faces.size(), 200u);
}

// The job's speck rule: a 2 x 2 mm square of 8 triangles floating 50 mm above the
// 200 x 200 mm grid is dropped (0.01 % of its area, 2.8 mm across, under 20 mm), a
// 150 mm thin strip beside it is kept (as long as the grid is wide), and
// decimation.json counts what went.
TEST(DecimateStage, SpecksAreDroppedAndCounted) {
  io::Mesh m;
  auto grid = [&](float x0, float y0, float z, int nx, int ny, float step_x, float step_y) {
    const int base = int(m.vertices.size());
    for (int y = 0; y <= ny; ++y) {
      for (int x = 0; x <= nx; ++x) m.vertices.emplace_back(x0 + step_x * x, y0 + step_y * y, z);
    }
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        const int v = base + y * (nx + 1) + x;
        m.faces.emplace_back(v, v + 1, v + nx + 2);
        m.faces.emplace_back(v, v + nx + 2, v + nx + 1);
      }
    }
  };
  grid(0, 0, 0, 20, 20, 10, 10);     // the surface: 800 triangles
  grid(50, 50, 50, 2, 2, 1, 1);      // a speck: 8
  grid(0, 250, 0, 15, 1, 10, 0.5f);  // a thin strip: 30
  runtime::DecimateJob dj;
  dj.set_ratio(0.5);
  dj.set_speck_area_fraction(0.01);
  dj.set_speck_diagonal_mm(20.0);
  JobBlobs blobs;
  runtime::Job job = DecimateJobOf(m, dj, &blobs);
  const auto out = RunJob(*DefaultStages(), job, blobs);
  ASSERT_EQ(out.size(), 2u);
  const core::Json summary = core::Json::parse(out[1].data());
  EXPECT_EQ(summary["specks_removed"], 1);
  EXPECT_EQ(summary["speck_triangles"], 8);
  EXPECT_EQ(summary["triangles_in"], 838);
  const io::Mesh d = io::ParsePly(out[0].data(), "decimated");
  float z_max = -1, y_max = -1;
  for (const auto& p : d.vertices) z_max = std::max(z_max, p.z()), y_max = std::max(y_max, p.y());
  EXPECT_LT(z_max, 1e-3f);   // the speck (at z = 50 mm) is gone
  EXPECT_GT(y_max, 250.0f);  // the strip stays
  EXPECT_EQ(summary["triangles_out"], int64_t(d.faces.size()));
  // Without the rule (a session's speck_area_fraction 0) nothing is dropped.
  dj.set_speck_area_fraction(0);
  job.set_settings(dj.SerializeAsString());
  EXPECT_EQ(core::Json::parse(RunJob(*DefaultStages(), job, blobs)[1].data())["specks_removed"], 0);
}

// A job names the stage that runs it; a name no stage has is refused, naming the job.
TEST(RunJob, UnknownStageIsRefusedNamingTheJob) {
  runtime::Job job;
  job.set_id("s/i/sharpen");
  job.set_stage("sharpen");
  try {
    RunJob(*DefaultStages(), job, {});
    FAIL() << "no error";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("job s/i/sharpen"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'sharpen'"), std::string::npos) << e.what();
  }
  job.set_stage("surface");  // the master's own stage: no worker runs it
  EXPECT_THROW(RunJob(*DefaultStages(), job, {}), core::InputError);
}

}  // namespace
}  // namespace dome::pipeline
