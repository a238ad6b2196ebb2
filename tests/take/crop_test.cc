// Cropping a take to a world box (take/crop.h): every box point keeps its
// image content, the frames shrink, bad boxes and takes with truth are refused.
#include "take/crop.h"

#include <gtest/gtest.h>

#include <random>

#include "io/image_io.h"
#include "take/take.h"
#include "take_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::take {
namespace {

using dome::testing::ExpectInputError;
using dome::testing::TempDir;

CropBox SmallBox() {
  CropBox box;
  box.min_mm = Eigen::Vector3d(-150, -100, -120);
  box.max_mm = Eigen::Vector3d(150, 100, 180);
  box.margin_px = 5;
  return box;
}

TEST(TakeCrop, BoxPointsKeepTheirPixels) {
  TempDir dir;
  const auto rig = take::testing::MakeRingRig(4, 320, 240);  // kappa1 = 0.01 per mm^2
  const auto path = take::testing::WriteTake(dir / "take", rig, 1);
  const take::Take before = take::OpenTake(path);
  const std::string instant = before.instants.front();
  std::vector<cv::Mat> images;
  for (const auto& c : before.rig.cameras) {
    images.push_back(
        io::ReadImage(before.FramePath(instant, c.model.id), io::ImageMode::kUnchanged));
  }
  const CropBox box = SmallBox();
  const CropSummary summary = CropTakeToBox(path, box);
  const take::Take after = take::OpenTake(path);
  EXPECT_EQ(summary.cameras_cropped, 4);
  double kept = 0;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (size_t k = 0; k < after.rig.cameras.size(); ++k) {
    const auto& orig = before.rig.cameras[k].model;
    const auto& cut = after.rig.cameras[k].model;
    const cv::Mat image =
        io::ReadImage(after.FramePath(instant, cut.id), io::ImageMode::kUnchanged);
    ASSERT_EQ(image.cols, cut.width_px);
    ASSERT_EQ(image.rows, cut.height_px);
    EXPECT_LT(cut.width_px * cut.height_px, orig.width_px * orig.height_px);
    kept += double(cut.width_px) * cut.height_px / (orig.width_px * orig.height_px) / 4;
    const double x0 = orig.cx_px - cut.cx_px, y0 = orig.cy_px - cut.cy_px;
    EXPECT_EQ(x0, std::round(x0));
    EXPECT_EQ(y0, std::round(y0));
    for (int i = 0; i < 500; ++i) {
      Eigen::Vector3d p;
      for (int a = 0; a < 3; ++a) p[a] = box.min_mm[a] + u(rng) * (box.max_mm[a] - box.min_mm[a]);
      Eigen::Vector2d a, b;
      ASSERT_TRUE(orig.Project(p, &a));
      ASSERT_TRUE(cut.Project(p, &b));
      EXPECT_NEAR(b.x(), a.x() - x0, 1e-9);
      EXPECT_NEAR(b.y(), a.y() - y0, 1e-9);
      if (a.x() < 0 || a.y() < 0 || a.x() > orig.width_px - 1 || a.y() > orig.height_px - 1) {
        continue;  // outside the original image: nothing to keep
      }
      // The margin: box points stay that far inside the cut unless the image ends first.
      EXPECT_TRUE(b.x() >= box.margin_px - 1e-9 || x0 == 0);
      EXPECT_TRUE(b.y() >= box.margin_px - 1e-9 || y0 == 0);
      EXPECT_TRUE(b.x() <= cut.width_px - 1 - box.margin_px + 1e-9 ||
                  x0 + cut.width_px == orig.width_px);
      EXPECT_TRUE(b.y() <= cut.height_px - 1 - box.margin_px + 1e-9 ||
                  y0 + cut.height_px == orig.height_px);
      const int ua = int(std::lround(a.x())), va = int(std::lround(a.y()));
      EXPECT_EQ(image.at<uint8_t>(va - int(y0), ua - int(x0)), images[k].at<uint8_t>(va, ua));
    }
  }
  EXPECT_NEAR(summary.pixel_fraction, kept, 1e-12);
  EXPECT_LT(summary.pixel_fraction, 0.8);
}

TEST(TakeCrop, RectIsEmptyWhenTheBoxIsOutOfView) {
  const auto rig = take::testing::MakeRingRig(1, 320, 240);
  CropBox box;
  box.min_mm = Eigen::Vector3d(50000, 50000, 50000);
  box.max_mm = Eigen::Vector3d(50010, 50010, 50010);
  EXPECT_TRUE(BoxImageRect(rig.cameras[0].model, box).empty());
  // A box around the whole scene keeps the whole image.
  box.min_mm = Eigen::Vector3d(-2000, -2000, -2000);
  box.max_mm = Eigen::Vector3d(2000, 2000, 2000);
  EXPECT_EQ(BoxImageRect(rig.cameras[0].model, box), cv::Rect(0, 0, 320, 240));
}

TEST(TakeCrop, BadInputIsRefused) {
  TempDir dir;
  const auto path =
      take::testing::WriteTake(dir / "take", take::testing::MakeRingRig(2, 64, 48), 1);
  CropBox box = SmallBox();
  box.max_mm.x() = box.min_mm.x();
  ExpectInputError([&] { CropTakeToBox(path, box); }, {"crop box", "exceed"});
  box = SmallBox();
  box.margin_px = -1;
  ExpectInputError([&] { CropTakeToBox(path, box); }, {"crop box", "margin"});
  std::filesystem::create_directories(path / "truth");
  ExpectInputError([&] { CropTakeToBox(path, SmallBox()); }, {"truth", "ground truth"});
}

}  // namespace
}  // namespace dome::take
