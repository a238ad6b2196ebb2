// The stereo job (pipeline/jobs.h) with the session's opt-in coarse-to-fine
// block (runtime.proto CoarseToFineSettings) on the small synthetic take: depths close
// to the full-range search's, the clip box bounds each camera's depth range, and bad
// fields are refused naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <tuple>
#include <vector>

#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "net/content_hash.h"
#include "pipeline/frame_handoff.h"
#include "pipeline/ideal_greys.h"
#include "pipeline/jobs.h"
#include "pipeline/session.h"
#include "pipeline/settings.h"
#include "pipeline/small_take_suite.h"
#include "pipeline/stage.h"
#include "pipeline/stages.h"
#include "stereo/take_stereo.h"
#include "take/crop.h"
#include "take/take.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {
namespace {

using dome::testing::ExpectInputError;
using dome::testing::TempDir;

class StereoStage : public SmallTakeSuite {
 protected:
  // The stereo job of camera `id` at the first instant with `settings`, run as a worker
  // runs it; returns the first window's depth (mm, 0 = none).
  // `edit`, when given, changes the job's settings message before it is sent.
  static cv::Mat RunStereoJob(const std::string& id, const runtime::StereoSettings& settings,
                              JobMemo* memo = nullptr, std::string* stereo_blob = nullptr,
                              const std::function<void(runtime::StereoJob*)>& edit = {}) {
    const take::Take take = take::OpenTake(TakeDir());
    const std::string instant = take.instants.front();
    const stereo::TakeStereoOptions options = FromStereoSettings(settings, "test");
    const stereo::StereoInput input = stereo::LoadStereoInput(take, instant, id, options.cluster);
    runtime::Job job;
    job.set_id("s/" + instant + "/stereo/" + id);
    job.set_instant(instant);
    job.set_threads(2);
    job.set_stage("stereo");
    runtime::StereoJob stereo_job;
    auto* sj = &stereo_job;
    sj->set_camera(id);
    *sj->mutable_stereo() = settings;
    JobBlobs blobs;
    auto add = [&](const std::filesystem::path& path) {
      blobs.push_back(std::make_shared<const std::string>(io::ReadFileBytes(path)));
      job.add_blobs()->set_name(path.string());
    };
    add(take.dir / "rig.json");
    add(take.FramePath(instant, id));
    for (const auto& v : input.neighbours) {
      sj->add_neighbours(v.camera.id);
      add(take.FramePath(instant, v.camera.id));
    }
    if (edit) edit(sj);
    job.set_settings(stereo_job.SerializeAsString());
    for (int i = 0; i < job.blobs_size(); ++i)
      job.mutable_blobs(i)->set_sha256(net::Sha256Hex(*blobs[size_t(i)]));
    const auto outputs = RunJob(*DefaultStages(), job, blobs, memo);
    if (stereo_blob) *stereo_blob = outputs.at(0).data();
    // The stereo blob, then the result's files (depth and reliability; no previews).
    EXPECT_EQ(outputs.size(), 3u);
    const stereo::StereoResult result = DecodeStereoOutput(outputs.at(0).data(), "test");
    std::vector<stereo::StereoFile> files;
    for (size_t i = 1; i < outputs.size(); ++i) {
      files.push_back({outputs[i].name(), outputs[i].data()});
    }
    EXPECT_EQ(files.at(0).path, "depth/" + id + ".tiff");
    stereo::CheckStereoFiles(result, false, files, "test");
    return result.range_images.at(0).depth_mm;
  }

  static runtime::StereoSettings DefaultSettings() {
    runtime::Session session;
    session.mutable_stereo()->add_window_sizes_px(7);
    return ToStereoSettings(ResolveSessionOptions(session, "session").stereo);
  }

  // c00's job keeps at least its three greys; c01's, whose cluster shares frames with
  // c00's, adds fewer than as many again; each job's outputs are the bytes of the job
  // run with no grey kept.
  static void ExpectKeptGreysGiveTheSameOutputs(const runtime::StereoSettings& settings) {
    DropIdealGreys();
    std::string first, second, alone;
    RunStereoJob("c00", settings, nullptr, &first);
    const size_t after_first = HeldIdealGreys();
    EXPECT_GE(after_first, 3u);  // the reference and its neighbours
    RunStereoJob("c01", settings, nullptr, &second);
    EXPECT_LT(HeldIdealGreys(), 2 * after_first) << "c01 shares frames with c00's cluster";
    DropIdealGreys();
    RunStereoJob("c01", settings, nullptr, &alone);
    EXPECT_EQ(second, alone);
    DropIdealGreys();
    RunStereoJob("c00", settings, nullptr, &alone);
    EXPECT_EQ(first, alone);
    DropIdealGreys();
  }

  // Coarse to fine clipped to a box around the middle half (per axis) of the surface
  // that `depth` (camera `cam`'s full-range depths, mm) sees; the box in lo, hi.
  static runtime::StereoSettings MiddleBoxSettings(const geometry::TsaiCamera& cam,
                                                   const cv::Mat& depth, Eigen::Vector3d* lo,
                                                   Eigen::Vector3d* hi) {
    std::vector<Eigen::Vector3d> points;
    for (int y = 0; y < depth.rows; ++y)
      for (int x = 0; x < depth.cols; ++x)
        if (depth.at<float>(y, x) > 0)
          points.push_back(cam.BackProjectAtDepth(Eigen::Vector2d(x, y), depth.at<float>(y, x)));
    EXPECT_GT(points.size(), size_t(1000));
    for (int i = 0; i < 3; ++i) {
      std::vector<double> v;
      for (const auto& p : points) v.push_back(p[i]);
      std::sort(v.begin(), v.end());
      (*lo)[i] = v[v.size() / 4];
      (*hi)[i] = v[v.size() * 3 / 4];
    }
    runtime::StereoSettings c2f = DefaultSettings();
    auto* block = c2f.mutable_coarse_to_fine();
    block->set_coarse_factor(2);
    block->set_coarse_window_px(5);
    block->set_tile_px(32);
    block->set_clip_pad_mm(1);
    for (int i = 0; i < 3; ++i) {
      block->add_clip_min_mm((*lo)[i]);
      block->add_clip_max_mm((*hi)[i]);
    }
    return c2f;
  }
};

// Frames decoded before the session (dome run's derivation, frame_handoff.h) are taken
// by the first job with a memo that needs them, once: the real frame gives the bytes of
// a job that decodes it, a different image under its address is what the job uses (so
// the handoff is not bypassed), and a job without a memo leaves the frame held.
TEST_F(StereoStage, FramesDecodedBeforeTheSessionAreTakenOnceByAJobWithAMemo) {
  DropKeptFrames();  // else a frame kept by an earlier test's job is found first
  const runtime::StereoSettings settings = DefaultSettings();
  const take::Take take = take::OpenTake(TakeDir());
  const std::string bytes = io::ReadFileBytes(take.FramePath(take.instants.front(), "c00"));
  const std::string sha256 = net::Sha256Hex(bytes);
  const cv::Mat frame = stereo::DecodeFrame(bytes, "c00");
  ASSERT_EQ(HeldDecodedFrames(), 0u);
  std::string plain, handed, poisoned;
  RunStereoJob("c00", settings, nullptr, &plain);

  OfferDecodedFrame(sha256, frame);
  RunStereoJob("c00", settings, nullptr, &handed);  // no memo: not taken
  EXPECT_EQ(HeldDecodedFrames(), 1u);
  JobMemo memo;
  RunStereoJob("c00", settings, &memo, &handed);
  EXPECT_EQ(HeldDecodedFrames(), 0u);
  EXPECT_EQ(handed, plain);

  OfferDecodedFrame(sha256, cv::Mat(frame.size(), frame.type(), cv::Scalar::all(255)));
  DropIdealGreys();  // else the real frame's grey, kept under its address, is used
  DropKeptFrames();  // else the real frame, kept for the process, is used
  JobMemo fresh;
  RunStereoJob("c00", settings, &fresh, &poisoned);
  DropIdealGreys();  // the poisoned grey and frame must not reach other tests
  DropKeptFrames();
  EXPECT_EQ(HeldDecodedFrames(), 0u);
  EXPECT_NE(poisoned, plain);
}

// Each frame's ideal grey is made once for the process's stereo jobs (ideal_greys.h): a
// job whose frames were seen by an earlier one adds only its new greys, and its outputs
// are the bytes of the job run with none kept.
// A stereo job bounded by the hull whose rule is out of range (a master of another
// release, a corrupted message) is refused naming the job and the field.
TEST_F(StereoStage, HullRuleOutOfRangeIsNamedWithTheJob) {
  const runtime::StereoSettings settings = DefaultSettings();
  for (const auto& [votes, views, field] :
       {std::tuple{0, 2, "carve_votes: expected at least 1 camera, got 0"},
        std::tuple{1, 0, "min_views: expected at least 2 cameras, got 0"}}) {
    ExpectInputError(
        [&] {
          RunStereoJob("c00", settings, nullptr, nullptr, [&](runtime::StereoJob* sj) {
            sj->set_hull_bounds(true);
            sj->set_carve_votes(votes);
            sj->set_min_views(views);
          });
        },
        {"job s/", "/stereo/c00", field});
  }
}

// A stereo job bounded by the hull whose masks are not all there (or are followed by
// blobs it has no use for) is refused naming the job and what was expected.
TEST_F(StereoStage, HullWithoutEveryCamerasMaskIsNamedWithTheJob) {
  ExpectInputError(
      [&] {
        RunStereoJob("c00", DefaultSettings(), nullptr, nullptr, [&](runtime::StereoJob* sj) {
          sj->set_hull_bounds(true);
          sj->set_carve_votes(1);
          sj->set_min_views(2);
        });
      },
      {"job s/", "/stereo/c00", "expected one mask per rig camera (6)", "got 0 blobs from there"});
}

TEST_F(StereoStage, IdealGreysKeptForTheProcessGiveTheSameOutputs) {
  ExpectKeptGreysGiveTheSameOutputs(DefaultSettings());
}

// A worker's jobs keep the decoded frames of an instant for the process's next jobs (a
// frame is the reference of one stereo job and a neighbour of others; another worker's
// jobs find them too): the outputs are the bytes of jobs run without them, a second
// worker's job of the same cluster decodes nothing new, and the memo's own entry (the
// parsed rig) is built once for all the jobs.
TEST_F(StereoStage, FramesKeptBetweenJobsGiveTheSameOutputs) {
  const runtime::StereoSettings settings = DefaultSettings();
  DropKeptFrames();
  JobMemo memo;
  for (const std::string id : {"c00", "c01", "c00"}) {
    std::string with, without;
    RunStereoJob(id, settings, &memo, &with);
    RunStereoJob(id, settings, nullptr, &without);
    EXPECT_EQ(with, without) << id;
  }
  EXPECT_EQ(memo.builds(), 1);
  const size_t kept = KeptFrames();
  EXPECT_GE(kept, 3u);  // c00 and its neighbours at least
  JobMemo other_worker;
  std::string again, alone;
  RunStereoJob("c01", settings, &other_worker, &again);
  RunStereoJob("c01", settings, nullptr, &alone);
  EXPECT_EQ(again, alone);
  EXPECT_EQ(KeptFrames(), kept) << "c01's frames were kept by the first worker's jobs";
  DropKeptFrames();
}

TEST_F(StereoStage, CoarseToFineDepthsMatchTheFullRangeSearch) {
  const runtime::StereoSettings full = DefaultSettings();
  runtime::StereoSettings c2f = full;
  auto* block = c2f.mutable_coarse_to_fine();
  block->set_coarse_factor(2);
  block->set_coarse_window_px(5);
  block->set_tile_px(32);
  // A box holding the whole dome: the clip leaves the session's range as it is.
  for (int i = 0; i < 3; ++i) {
    block->add_clip_min_mm(-50000);
    block->add_clip_max_mm(50000);
  }
  // The block survives the master's round trip (session options -> job settings).
  ASSERT_TRUE(ToStereoSettings(FromStereoSettings(c2f, "test")).has_coarse_to_fine());

  const cv::Mat a = RunStereoJob("c00", full);
  const cv::Mat b = RunStereoJob("c00", c2f);
  ASSERT_EQ(a.size(), b.size());
  std::vector<double> diffs;
  int valid_a = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float da = a.at<float>(y, x), db = b.at<float>(y, x);
      valid_a += da > 0;
      if (da > 0 && db > 0) diffs.push_back(std::abs(db - da) / da);
    }
  }
  ASSERT_GT(valid_a, a.rows * a.cols / 10);
  // Most of the full-range depths are found again, and agree to well under 1 %.
  EXPECT_GT(diffs.size(), 0.7 * valid_a);
  std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
  EXPECT_LT(diffs[diffs.size() / 2], 0.005);

  // The default path is untouched by the block's absence: same depths again.
  const cv::Mat again = RunStereoJob("c00", full);
  EXPECT_EQ(cv::norm(a, again, cv::NORM_INF), 0.0);
}

// With a clip box each view is cut to where the box projects: no depth outside the
// box's image rectangle in the reference, and inside it the depths of points in the box
// are those of the full-range search (found again, agreeing to well under 1 %).
TEST_F(StereoStage, AClipBoxCutsEachViewToWhereTheBoxProjects) {
  const take::Take take = take::OpenTake(TakeDir());
  ASSERT_GE(take.rig.Find("c00"), 0);
  const geometry::TsaiCamera cam = take.rig.cameras[size_t(take.rig.Find("c00"))].model;
  const runtime::StereoSettings full = DefaultSettings();
  const cv::Mat a = RunStereoJob("c00", full);
  Eigen::Vector3d lo, hi;
  const runtime::StereoSettings c2f = MiddleBoxSettings(cam, a, &lo, &hi);
  const cv::Mat b = RunStereoJob("c00", c2f);
  ASSERT_EQ(b.size(), a.size());
  take::CropBox box;
  box.min_mm = lo.array() - 1.0;
  box.max_mm = hi.array() + 1.0;
  box.margin_px = 16;  // the cut's margin: the default, more than half a window + a tile
  const cv::Rect rect = take::BoxImageRect(cam, box);
  ASSERT_FALSE(rect.empty());
  ASSERT_LT(rect.area(), a.rows * a.cols * 4 / 5);  // a cut, not the whole image
  std::vector<double> diffs;
  int in_box = 0, outside = 0;
  for (int y = 0; y < a.rows; ++y) {
    for (int x = 0; x < a.cols; ++x) {
      const float da = a.at<float>(y, x), db = b.at<float>(y, x);
      if (db > 0 && !rect.contains(cv::Point(x, y))) ++outside;
      if (!(da > 0)) continue;
      const Eigen::Vector3d p = cam.BackProjectAtDepth(Eigen::Vector2d(x, y), da);
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      ++in_box;
      if (db > 0) diffs.push_back(std::abs(db - da) / da);
    }
  }
  EXPECT_EQ(outside, 0);
  ASSERT_GT(in_box, 100);
  EXPECT_GT(diffs.size(), 0.7 * in_box);
  std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
  EXPECT_LT(diffs[diffs.size() / 2], 0.005);
}

// The views a clip box cuts are cut the same way in every job of a session: their
// ideal greys are made once for the process (pipeline/stages.h Stereo's grey keys). A
// job whose frames an earlier job cut adds only its new greys, and its outputs are the
// bytes of the job run with none kept.
TEST_F(StereoStage, CutGreysKeptForTheProcessGiveTheSameOutputs) {
  const take::Take take = take::OpenTake(TakeDir());
  const geometry::TsaiCamera cam = take.rig.cameras[size_t(take.rig.Find("c00"))].model;
  Eigen::Vector3d lo, hi;
  ExpectKeptGreysGiveTheSameOutputs(
      MiddleBoxSettings(cam, RunStereoJob("c00", DefaultSettings()), &lo, &hi));
}

TEST_F(StereoStage, ClipBoxBoundsTheDepthRange) {
  const take::Take take = take::OpenTake(TakeDir());
  const geometry::TsaiCamera& cam = take.rig.cameras.front().model;
  // A cube of half side h on the optical axis at depth z: its corners span
  // z +- h (|r20| + |r21| + |r22|) along the axis (r2: the third row of world -> camera).
  const double z = 3000, h = 200, pad = 5;
  const Eigen::Vector3d centre =
      cam.CentreWorld() + z * cam.rotation.transpose() * Eigen::Vector3d::UnitZ();
  runtime::CoarseToFineSettings s;
  for (int i = 0; i < 3; ++i) {
    s.add_clip_min_mm(centre[i] - h);
    s.add_clip_max_mm(centre[i] + h);
  }
  s.set_clip_pad_mm(pad);
  const double half = h * cam.rotation.row(2).cwiseAbs().sum();
  stereo::StereoOptions o;
  o.z_min_mm = 100;
  o.z_max_mm = 10000;
  const stereo::CoarseToFineOptions c2f = FromCoarseToFineSettings(s, "job");
  stereo::ClipDepthRange(c2f, cam, "job", &o);
  EXPECT_NEAR(o.z_min_mm, z - half - pad, 1e-6);
  EXPECT_NEAR(o.z_max_mm, z + half + pad, 1e-6);
  // Clipped, never widened.
  o.z_min_mm = 2950;
  o.z_max_mm = 10000;
  stereo::ClipDepthRange(c2f, cam, "job", &o);
  EXPECT_DOUBLE_EQ(o.z_min_mm, 2950);
  EXPECT_NEAR(o.z_max_mm, z + half + pad, 1e-6);
  // A range that misses the box.
  o.z_min_mm = 100;
  o.z_max_mm = 1000;
  ExpectInputError([&] { stereo::ClipDepthRange(c2f, cam, "job", &o); },
                   {"job: coarse_to_fine.clip_min_mm", "sees no depth of the clip box"});
}

TEST_F(StereoStage, BadCoarseToFineFieldsAreRefusedNamingTheField) {
  runtime::Session session;
  session.mutable_stereo()->mutable_coarse_to_fine()->set_tile_px(4);
  ExpectInputError([&] { ResolveSessionOptions(session, "session.json"); },
                   {"session.json: stereo.coarse_to_fine.tile_px", "at least 8"});
  session.mutable_stereo()->mutable_coarse_to_fine()->clear_tile_px();
  session.mutable_stereo()->mutable_coarse_to_fine()->set_fill_min_neighbours(-1);
  ExpectInputError([&] { ResolveSessionOptions(session, "session.json"); },
                   {"session.json: stereo.coarse_to_fine.fill_min_neighbours", "0..8"});
  session.mutable_stereo()->mutable_coarse_to_fine()->clear_fill_min_neighbours();
  session.mutable_stereo()->mutable_coarse_to_fine()->add_clip_min_mm(0);
  ExpectInputError([&] { ResolveSessionOptions(session, "session.json"); },
                   {"session.json: stereo.coarse_to_fine.clip_min_mm", "3 numbers"});
  auto* c = session.mutable_stereo()->mutable_coarse_to_fine();
  c->clear_clip_min_mm();
  for (double v : {0.0, 0.0, 0.0}) c->add_clip_min_mm(v);
  for (double v : {1.0, -1.0, 1.0}) c->add_clip_max_mm(v);
  ExpectInputError([&] { ResolveSessionOptions(session, "session.json"); },
                   {"session.json: stereo.coarse_to_fine.clip_max_mm", "axis 1"});
  // A session file with the block parses through protobuf's JSON mapping.
  TempDir dir;
  io::WriteFileAtomically(dir / "session.json",
                          R"({"take": "t", "stereo": {"coarse_to_fine": {"tile_px": 48,)"
                          R"( "fill_min_neighbours": 2,)"
                          R"( "clip_min_mm": [0, 0, 0], "clip_max_mm": [1, 2, 3]}}})");
  const runtime::Session read = ReadSessionJson(dir / "session.json");
  EXPECT_EQ(read.stereo().coarse_to_fine().tile_px(), 48);
  EXPECT_EQ(FromCoarseToFineSettings(read.stereo().coarse_to_fine(), "s").fill_min_neighbours, 2);
  EXPECT_EQ(stereo::CoarseToFineOptions{}.fill_min_neighbours, 0);  // off unless asked for
  EXPECT_EQ(read.stereo().coarse_to_fine().clip_max_mm(2), 3.0);
}

TEST(SessionOptions, SmoothingAndSpeckleFieldsReadAndAreChecked) {
  TempDir dir;
  io::WriteFileAtomically(dir / "session.json",
                          R"({"take": "t", "smooth_iterations": 6, "smooth_mu": -0.6,)"
                          R"( "stereo": {"speckle_area_px": 400, "speckle_step_mm": 0.5,)"
                          R"( "sqrt_greys": true}})");
  const SessionOptions o = ResolveSessionOptions(ReadSessionJson(dir / "session.json"), "s.json");
  EXPECT_EQ(o.smooth.iterations, 6);
  EXPECT_EQ(o.smooth.lambda, mesh::SmoothOptions{}.lambda);
  EXPECT_EQ(o.smooth.mu, -0.6);
  EXPECT_EQ(o.stereo.stereo.speckle.min_area_px, 400);
  EXPECT_EQ(o.stereo.stereo.speckle.max_step_mm, 0.5);
  EXPECT_TRUE(o.stereo.stereo.sqrt_greys);
  EXPECT_FALSE(stereo::StereoOptions{}.sqrt_greys);  // off unless asked for
  EXPECT_EQ(SessionOptions{}.smooth.iterations, 0);  // off unless asked for
  runtime::Session session;
  session.set_smooth_iterations(-1);
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); },
                   {"s.json: smooth_iterations", ">= 0"});
  session.set_smooth_iterations(3);
  session.set_smooth_mu(-0.2);
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); }, {"s.json: smooth_mu"});
  session.clear_smooth_mu();
  session.mutable_stereo()->set_speckle_area_px(100);
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); },
                   {"s.json: stereo.speckle_step_mm", "positive"});
}

// The master checks a result's files against the rectangles the stereo output carries
// (DecodeStereoRects), without placing them in whole maps: the same verdicts as against
// the whole maps, a value outside the rectangle included.
TEST(StereoFiles, AreCheckedAgainstTheRectanglesAsPlaced) {
  stereo::StereoResult result;
  result.camera = "c03";
  stereo::RangeImage r;
  r.window_px = 7;
  r.depth_mm = cv::Mat(20, 24, CV_32FC1, cv::Scalar(0));
  r.reliability = cv::Mat(20, 24, CV_32FC1, cv::Scalar(0));
  for (int y = 4; y < 15; ++y) {
    for (int x = 6; x < 20; ++x) {
      r.depth_mm.at<float>(y, x) = 900.0f + 1.5f * x - 0.25f * y;
      r.reliability.at<float>(y, x) = 0.25f * x;
    }
  }
  result.range_images.push_back(r);
  stereo::RangeImage none = r;  // no depth: an empty rectangle
  none.window_px = 11;
  none.depth_mm = cv::Mat(20, 24, CV_32FC1, cv::Scalar(0));
  none.reliability = none.depth_mm.clone();
  result.range_images.push_back(none);
  std::vector<stereo::MapCut> cuts;
  const stereo::StereoResult rects = DecodeStereoRects(EncodeStereoOutput(result), "blob", &cuts);
  ASSERT_EQ(cuts.size(), 2u);
  EXPECT_EQ(cuts[0].at, cv::Point(6, 4));
  EXPECT_EQ(cuts[0].full, cv::Size(24, 20));
  EXPECT_EQ(rects.range_images[0].depth_mm.size(), cv::Size(14, 11));
  EXPECT_TRUE(rects.range_images[1].depth_mm.empty());
  for (bool previews : {false, true}) {
    const std::vector<stereo::StereoFile> files = stereo::EncodeStereoFiles(result, previews);
    stereo::CheckStereoFiles(rects, previews, files, "worker w2", cuts);
    // A value outside the rectangle, and one inside it, are both refused.
    for (const cv::Point at :
         {cv::Point(2, 1), cv::Point(23, 10), cv::Point(10, 17), cv::Point(8, 8)}) {
      stereo::StereoResult other = result;
      other.range_images[0].depth_mm = result.range_images[0].depth_mm.clone();
      other.range_images[0].depth_mm.at<float>(at) += 0.5f;
      auto tampered = files;
      tampered[0] = stereo::EncodeStereoFiles(other, previews)[0];
      ExpectInputError(
          [&] { stereo::CheckStereoFiles(rects, previews, tampered, "worker w2", cuts); },
          {"depth/c03.tiff", "is not the result's depth map"});
    }
    // A file of another size is refused too.
    stereo::StereoResult smaller = result;
    for (auto& m : smaller.range_images) {
      m.depth_mm = m.depth_mm(cv::Rect(0, 0, 22, 20)).clone();
      m.reliability = m.reliability(cv::Rect(0, 0, 22, 20)).clone();
    }
    auto resized = files;
    resized[1] = stereo::EncodeStereoFiles(smaller, previews)[1];
    ExpectInputError([&] { stereo::CheckStereoFiles(rects, previews, resized, "worker w2", cuts); },
                     {"reliability/c03.tiff", "is not the result's reliability map"});
  }
}

// The clean-output rule's session fields: read, turned into the decimation's mm by the
// voxel, and checked.
TEST(SessionOptions, SpeckFieldsReadScaleByTheVoxelAndAreChecked) {
  TempDir dir;
  io::WriteFileAtomically(dir / "session.json",
                          R"({"take": "t", "speck_area_fraction": 0.02,)"
                          R"( "speck_diagonal_voxels": 12, "speck_gap_voxels": 3,)"
                          R"( "volume": {"voxel_size_mm": 5}})");
  const SessionOptions o = ResolveSessionOptions(ReadSessionJson(dir / "session.json"), "s.json");
  const mesh::DecimationOptions d = DecimationFor(o);
  EXPECT_EQ(d.speck_area_fraction, 0.02);
  EXPECT_EQ(d.speck_diagonal_mm, 60.0);
  EXPECT_EQ(d.speck_gap_mm, 15.0);
  EXPECT_EQ(d.target_ratio, o.decimate_ratio);
  EXPECT_EQ(SessionOptions{}.speck_area_fraction, 0.01);  // on unless turned off
  runtime::Session session;
  session.set_speck_area_fraction(1.0);
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); },
                   {"s.json: speck_area_fraction", "[0, 1)"});
  session.set_speck_area_fraction(0);
  session.set_speck_diagonal_voxels(-3);
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); },
                   {"s.json: speck_diagonal_voxels", ">= 0"});
  session.set_speck_diagonal_voxels(3);
  session.set_speck_gap_voxels(std::nan(""));
  ExpectInputError([&] { ResolveSessionOptions(session, "s.json"); }, {"s.json: speck_gap_voxels"});
}

// The files a worker returns with a stereo result are checked against the result before
// the master writes them: every file there, at its path, decoding to the result's maps.
TEST(StereoFiles, AreCheckedAgainstTheResult) {
  stereo::StereoResult result;
  result.camera = "c07";
  for (int window : {7, 11}) {
    stereo::RangeImage r;
    r.window_px = window;
    r.depth_mm = cv::Mat(12, 16, CV_32FC1, cv::Scalar(0));
    r.reliability = cv::Mat(12, 16, CV_32FC1, cv::Scalar(0));
    for (int y = 2; y < 10; ++y) {
      for (int x = 3; x < 13; ++x) {
        r.depth_mm.at<float>(y, x) = 1800.0f + 3.25f * x + window;
        r.reliability.at<float>(y, x) = 0.5f * y;
      }
    }
    result.range_images.push_back(r);
  }
  for (bool previews : {false, true}) {
    const std::vector<stereo::StereoFile> files = stereo::EncodeStereoFiles(result, previews);
    ASSERT_EQ(files.size(), previews ? 6u : 4u);
    EXPECT_EQ(files[0].path, "depth/c07.tiff");
    EXPECT_EQ(files[previews ? 3 : 2].path, "depth-w11/c07.tiff");
    stereo::CheckStereoFiles(result, previews, files, "worker w1 result of s/j");
    // The same files as `dome stereo` writes.
    const testing::TempDir dir;
    stereo::WriteStereoResult(result, "00-00-00-00", dir.path(), previews);
    for (const auto& f : files) {
      EXPECT_EQ(io::ReadFileBytes(dir.path() / "00-00-00-00" / f.path), f.bytes) << f.path;
    }
    auto missing = files;
    missing.pop_back();
    ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, missing, "worker w1"); },
                     {"worker w1", "expected " + std::to_string(files.size()) + " stereo files"});
    auto renamed = files;
    renamed[1].path = "../../etc/passwd";
    ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, renamed, "worker w1"); },
                     {"worker w1", "'../../etc/passwd'", "expected 'reliability/c07.tiff'"});
    auto garbage = files;
    garbage[0].bytes = "II*\0 not really a TIFF";
    ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, garbage, "worker w1"); },
                     {"worker w1 depth/c07.tiff"});
    // A depth map one value off is refused.
    stereo::StereoResult other = result;
    other.range_images[0].depth_mm = result.range_images[0].depth_mm.clone();
    other.range_images[0].depth_mm.at<float>(5, 5) += 0.001f;
    auto tampered = files;
    tampered[0] = stereo::EncodeStereoFiles(other, previews)[0];
    ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, tampered, "worker w1"); },
                     {"depth/c07.tiff", "is not the result's depth map"});
    if (previews) {
      auto swapped = files;
      std::swap(swapped[1].bytes, swapped[2].bytes);  // reliability <-> preview
      ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, swapped, "worker w1"); },
                       {"reliability/c07.tiff", "is not the result's reliability map"});
      // The preview is a palette PNG of the map's size: a BGR picture of it, or a palette
      // PNG of another size, is refused.
      const cv::Mat& depth = result.range_images[0].depth_mm;
      auto bgr = files;
      bgr[2].bytes = io::EncodePng(io::DepthPreview(depth), io::PngEncoding::kFast);
      ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, bgr, "worker w1"); },
                       {"worker w1 preview/c07.png", "is not an 8-bit palette preview"});
      auto small = files;
      small[2].bytes = io::EncodeDepthPreviewPng(depth(cv::Rect(0, 0, 8, 8)), "small");
      ExpectInputError([&] { stereo::CheckStereoFiles(result, previews, small, "worker w1"); },
                       {"worker w1 preview/c07.png", "of the depth map's size"});
    }
  }
}

}  // namespace
}  // namespace dome::pipeline
