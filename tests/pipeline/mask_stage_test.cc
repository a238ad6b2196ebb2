// The masks stage's job (pipeline/jobs.h) on the small synthetic take (masks from its
// background plates): it makes the mask the derivation's silhouette::TakeMasks makes, and
// takes a mask the derivation handed over for the same inputs (frame_handoff.h) instead
// of making it again, once; a handed mask of another size is not used.
#include <gtest/gtest.h>

#include "io/file_util.h"
#include "io/image_io.h"
#include "net/content_hash.h"
#include "pipeline/frame_handoff.h"
#include "pipeline/jobs.h"
#include "pipeline/small_take_suite.h"
#include "pipeline/stage.h"
#include "silhouette/take_masks.h"
#include "take/take.h"

namespace dome::pipeline {
namespace {

class MaskStage : public SmallTakeSuite {
 protected:
  // The mask job of camera `id` at the first instant, as a worker runs it: the decoded
  // mask. `key`: the handoff key of its inputs.
  static cv::Mat RunMaskJob(const std::string& id, std::string* key = nullptr) {
    const take::Take take = take::OpenTake(TakeDir());
    const silhouette::TakeMasks masks(take, silhouette::MaskOptions{});
    const std::string instant = take.instants.front();
    runtime::Job job;
    job.set_id("s/" + instant + "/masks/" + id);
    job.set_instant(instant);
    job.set_threads(2);
    job.set_stage("masks");
    runtime::MaskJob mj;
    mj.set_camera(id);
    mj.set_source(silhouette::MaskSourceName(masks.Source(id)));
    JobBlobs blobs;
    std::vector<std::string> shas;
    std::vector<std::filesystem::path> paths = {take.dir / "rig.json"};
    for (const auto& p : masks.InputPaths(instant, id)) paths.push_back(p);
    for (const auto& p : paths) {
      const std::string bytes = io::ReadFileBytes(p);
      blobs.push_back(std::make_shared<const std::string>(bytes));
      auto* b = job.add_blobs();
      b->set_name(p.string());
      b->set_sha256(net::Sha256Hex(bytes));
      if (blobs.size() > 1) shas.push_back(b->sha256());
    }
    if (key) *key = MaskHandoffKey(id, mj.source(), shas);
    job.set_settings(mj.SerializeAsString());
    return io::DecodeImage(RunJob(*DefaultStages(), job, blobs).at(0).data(),
                           io::ImageMode::kUnchanged, "mask");
  }
};

TEST_F(MaskStage, TheJobMakesTheDerivationsMaskAndTakesAHandedOneOnce) {
  const take::Take take = take::OpenTake(TakeDir());
  silhouette::TakeMasks masks(take, silhouette::MaskOptions{});
  ASSERT_EQ(masks.Source("c00"), silhouette::MaskSource::kPlate);
  std::string key;
  const cv::Mat made = RunMaskJob("c00", &key);
  const cv::Mat derived = masks.Mask(take.instants.front(), "c00");
  ASSERT_EQ(made.size(), derived.size());
  ASSERT_GT(cv::countNonZero(derived), 0);
  EXPECT_EQ(cv::countNonZero(made != derived), 0);

  // A handed mask (here every pixel foreground, to tell it apart) is what the job gives.
  const cv::Mat all(derived.size(), CV_8UC1, cv::Scalar(255));
  OfferMask(key, all);
  EXPECT_EQ(cv::countNonZero(RunMaskJob("c00") != all), 0);
  EXPECT_EQ(cv::countNonZero(RunMaskJob("c00") != derived), 0);  // taken once
  // One of another size is not used.
  OfferMask(key, cv::Mat(3, 3, CV_8UC1, cv::Scalar(255)));
  EXPECT_EQ(cv::countNonZero(RunMaskJob("c00") != derived), 0);
}

}  // namespace
}  // namespace dome::pipeline
