// Time-aware stereo jobs (pipeline/jobs.h, stereo/temporal_bounds.h) on a two-instant
// small synthetic take: a job given the previous instant's result and frame finds the
// depths the same search over the whole range finds; a previous result of another camera is refused
// naming the blob; a session plans temporal stereo for a sequence when told, never for
// one instant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "io/file_util.h"
#include "net/content_hash.h"
#include "pipeline/ideal_greys.h"
#include "pipeline/jobs.h"
#include "pipeline/session.h"
#include "pipeline/settings.h"
#include "pipeline/small_take_suite.h"
#include "pipeline/stage.h"
#include "stereo/take_stereo.h"
#include "take/take.h"
#include "testing/expect_error.h"

namespace dome::pipeline {
namespace {

class TemporalStereo : public SmallTakeSuiteOf<2> {
 protected:
  static runtime::StereoSettings Settings() {
    runtime::Session session;
    session.mutable_stereo()->add_window_sizes_px(7);
    return ToStereoSettings(ResolveSessionOptions(session, "session").stereo);
  }

  // The stereo job of camera `id` at instant `t`, as a worker runs it; with `previous`
  // (an earlier stereo blob of `previous_camera` at instant t - 1), bounded by it.
  static std::string RunStereo(const std::string& id, int t, const std::string* previous = nullptr,
                            const std::string& previous_camera = "") {
    const take::Take take = take::OpenTake(TakeDir());
    const std::string instant = take.instants.at(size_t(t));
    const stereo::TakeStereoOptions options = FromStereoSettings(Settings(), "test");
    const stereo::StereoInput input = stereo::LoadStereoInput(take, instant, id, options.cluster);
    runtime::Job job;
    job.set_id("s/" + instant + "/stereo/" + id);
    job.set_instant(instant);
    job.set_threads(2);
    job.set_stage("stereo");
    runtime::StereoJob sj;
    sj.set_camera(id);
    *sj.mutable_stereo() = Settings();
    JobBlobs blobs;
    auto add = [&](const std::string& bytes, const std::string& name) {
      blobs.push_back(std::make_shared<const std::string>(bytes));
      auto* b = job.add_blobs();
      b->set_name(name);
      b->set_sha256(net::Sha256Hex(bytes));
    };
    auto add_file = [&](const std::filesystem::path& p) { add(io::ReadFileBytes(p), p.string()); };
    add_file(take.dir / "rig.json");
    add_file(take.FramePath(instant, id));
    for (const auto& v : input.neighbours) {
      sj.add_neighbours(v.camera.id);
      add_file(take.FramePath(instant, v.camera.id));
    }
    if (previous) {
      TemporalUse use;
      use.stereo = true;
      *sj.mutable_temporal() = ToTemporalSettings(use);
      add(*previous, "previous stereo");
      add_file(take.FramePath(take.instants.at(size_t(t - 1)),
                              previous_camera.empty() ? id : previous_camera));
    }
    job.set_settings(sj.SerializeAsString());
    return RunJob(*DefaultStages(), job, blobs).at(0).data();
  }

};

// Against the same search over every tile's whole range (a previous result with no
// depth: every tile unknown), the bounded one finds about as many depths (within 5 %),
// and where both find one it is the same.
TEST_F(TemporalStereo, BoundedByThePreviousInstantTheDepthsAreThoseOfTheWholeRange) {
  for (const std::string id : {"c00", "c03"}) {
    const std::string before = RunStereo(id, 0);
    stereo::StereoResult none = DecodeStereoOutput(before, "before");
    for (auto& r : none.range_images) r.depth_mm.setTo(0);
    const std::string nothing_before = EncodeStereoOutput(none);
    const stereo::StereoResult whole =
        DecodeStereoOutput(RunStereo(id, 1, &nothing_before), "whole");
    const stereo::StereoResult bounded = DecodeStereoOutput(RunStereo(id, 1, &before), "bounded");
    const cv::Mat a = whole.range_images.at(0).depth_mm, b = bounded.range_images.at(0).depth_mm;
    ASSERT_EQ(a.size(), b.size());
    int valid_a = 0, valid_b = 0;
    std::vector<double> diffs;
    for (int y = 0; y < a.rows; ++y) {
      for (int x = 0; x < a.cols; ++x) {
        const float da = a.at<float>(y, x), db = b.at<float>(y, x);
        valid_a += da > 0;
        valid_b += db > 0;
        if (da > 0 && db > 0) diffs.push_back(std::abs(db - da) / da);
      }
    }
    ASSERT_GT(valid_a, a.rows * a.cols / 10) << id;
    EXPECT_NEAR(valid_b, valid_a, 0.05 * valid_a) << id;
    ASSERT_GT(diffs.size(), 0.7 * valid_a) << id << ": " << valid_a << " " << valid_b;
    std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
    EXPECT_LT(diffs[diffs.size() / 2], 0.005) << id;
    // And the same depth where both found one at 90 % of the pixels (1 %).
    const double within = double(std::count_if(diffs.begin(), diffs.end(),
                                               [](double d) { return d < 0.01; })) /
                          double(diffs.size());
    EXPECT_GT(within, 0.9) << id;
  }
}

TEST_F(TemporalStereo, APreviousResultOfAnotherCameraIsNamed) {
  const std::string other = RunStereo("c01", 0);
  dome::testing::ExpectInputError([&] { RunStereo("c00", 1, &other); },
                                  {"previous stereo", "camera 'c01'", "expected 'c00'"});
}

TEST_F(TemporalStereo, ASequenceIsPlannedTemporalWhenToldAndOneInstantNever) {
  runtime::Session spec;
  spec.set_take(TakeDir().string());
  spec.set_out((TakeDir().parent_path() / "out").string());
  auto plan = [&] {
    return PlanSession(spec, [](const std::filesystem::path& p, const std::string& name) {
      runtime::BlobRef b;
      b.set_name(name);
      b.set_size(std::filesystem::file_size(p));
      return b;
    });
  };
  EXPECT_FALSE(plan().options.temporal.stereo);
  spec.mutable_temporal()->set_stereo(true);
  EXPECT_TRUE(plan().options.temporal.stereo);
  const take::Take take = take::OpenTake(TakeDir());
  spec.add_instants(take.instants.at(1));
  EXPECT_FALSE(plan().options.temporal.stereo);
  spec.mutable_temporal()->set_fusion(true);
  EXPECT_FALSE(plan().options.temporal.fusion);  // one instant: nothing before it
  spec.clear_instants();
  EXPECT_TRUE(plan().options.temporal.fusion);
  // A bad field is named as the session file names it.
  spec.mutable_temporal()->set_fusion_decay(0);
  dome::testing::ExpectInputError([&] { plan(); }, {"session", "temporal.fusion_decay"});
  spec.mutable_temporal()->clear_fusion_decay();
  spec.mutable_temporal()->set_margin_levels(0.5);
  dome::testing::ExpectInputError([&] { plan(); }, {"session", "temporal.margin_levels"});
}

}  // namespace
}  // namespace dome::pipeline
