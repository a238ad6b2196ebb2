#include "geometry/undistort.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::ExpectInputError;
using testing::TypicalCamera;

constexpr double kSigmaPx = 1.5;  // dot radius (Gaussian sigma), pixels
constexpr int kWindowPx = 6;      // half-size of the centroid window, pixels

// Float image of Gaussian dots centred at `centres`.
cv::Mat RenderDots(int width, int height, const std::vector<Eigen::Vector2d>& centres) {
  cv::Mat image(height, width, CV_32FC1, cv::Scalar(0));
  for (const Eigen::Vector2d& c : centres) {
    const int x0 = static_cast<int>(std::floor(c.x())), y0 = static_cast<int>(std::floor(c.y()));
    for (int y = y0 - 8; y <= y0 + 8; ++y) {
      for (int x = x0 - 8; x <= x0 + 8; ++x) {
        if (x < 0 || y < 0 || x >= width || y >= height) {
          continue;
        }
        const double d2 = (x - c.x()) * (x - c.x()) + (y - c.y()) * (y - c.y());
        image.at<float>(y, x) +=
            static_cast<float>(1000.0 * std::exp(-d2 / (2 * kSigmaPx * kSigmaPx)));
      }
    }
  }
  return image;
}

// Intensity centroid in a (2 kWindowPx + 1)^2 window around `guess`.
Eigen::Vector2d Centroid(const cv::Mat& image, const Eigen::Vector2d& guess) {
  const int gx = static_cast<int>(std::lround(guess.x())),
            gy = static_cast<int>(std::lround(guess.y()));
  double sum = 0, sx = 0, sy = 0;
  for (int y = gy - kWindowPx; y <= gy + kWindowPx; ++y) {
    for (int x = gx - kWindowPx; x <= gx + kWindowPx; ++x) {
      const double v = image.at<float>(y, x);
      sum += v;
      sx += v * x;
      sy += v * y;
    }
  }
  return {sx / sum, sy / sum};
}

bool Inside(const TsaiCamera& camera, const Eigen::Vector2d& p, double margin) {
  return p.x() >= margin && p.y() >= margin && p.x() <= camera.width_px - 1 - margin &&
         p.y() <= camera.height_px - 1 - margin;
}

// Dots on a 40 px grid with fractional offsets, kept where both ends of the mapping are
// well inside the image. `map` sends a dot of the rendered image to the other image.
template <typename Map>
void CheckDotsMove(const TsaiCamera& camera, bool undistort, const Map& map) {
  std::vector<Eigen::Vector2d> rendered, expected;
  for (double y = 14.3; y < camera.height_px; y += 40.0) {
    for (double x = 12.7; x < camera.width_px; x += 40.0) {
      const Eigen::Vector2d p(x, y);
      const Eigen::Vector2d q = map(p);
      if (Inside(camera, p, 12) && Inside(camera, q, 12)) {
        rendered.push_back(p);
        expected.push_back(q);
      }
    }
  }
  ASSERT_GT(rendered.size(), 150u);
  const cv::Mat source = RenderDots(camera.width_px, camera.height_px, rendered);
  const cv::Mat result = undistort ? UndistortImage(camera, source) : DistortImage(camera, source);
  ASSERT_EQ(result.type(), CV_32FC1);
  double worst = 0.0, largest_move = 0.0;
  for (size_t i = 0; i < rendered.size(); ++i) {
    const Eigen::Vector2d found = Centroid(result, expected[i]);
    worst = std::max(worst, (found - expected[i]).norm());
    largest_move = std::max(largest_move, (expected[i] - rendered[i]).norm());
    EXPECT_LT((found - expected[i]).norm(), 0.1)
        << "dot at " << rendered[i].transpose() << " expected at " << expected[i].transpose()
        << " found at " << found.transpose();
  }
  // The test means something only if the dots actually move by many pixels.
  EXPECT_GT(largest_move, 10.0);
  std::printf("%s: %zu dots, worst %.4f px, largest move %.1f px\n",
              undistort ? "undistort" : "distort", rendered.size(), worst, largest_move);
}

TEST(Undistort, DotsMoveWhereUndistortPixelSays) {
  for (const double kappa : {5.720865e-4, -1e-3}) {
    SCOPED_TRACE(kappa);
    const TsaiCamera camera = TypicalCamera(kappa);
    CheckDotsMove(camera, true, [&](const Eigen::Vector2d& p) { return camera.UndistortPixel(p); });
  }
}

TEST(Undistort, DotsMoveWhereDistortPixelSays) {
  for (const double kappa : {5.720865e-4, -1e-3}) {
    SCOPED_TRACE(kappa);
    const TsaiCamera camera = TypicalCamera(kappa);
    CheckDotsMove(camera, false, [&](const Eigen::Vector2d& p) { return camera.DistortPixel(p); });
  }
}

TEST(Undistort, TablesHoldTheExactMapping) {
  const TsaiCamera camera = TypicalCamera(5.720865e-4);
  const RemapTables undistort = BuildUndistortTables(camera);
  const RemapTables distort = BuildDistortTables(camera);
  ASSERT_EQ(undistort.map_x.type(), CV_32FC1);
  ASSERT_EQ(undistort.map_x.rows, camera.height_px);
  ASSERT_EQ(undistort.map_x.cols, camera.width_px);
  // What the tables cover: an all-255 image through them, kept with them.
  const cv::Mat all(camera.height_px, camera.width_px, CV_8UC1, cv::Scalar(255));
  ASSERT_EQ(undistort.covered.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(undistort.covered, Remap(all, undistort), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(distort.covered, Remap(all, distort), cv::NORM_INF), 0.0);
  EXPECT_EQ(undistort.covered.at<uint8_t>(camera.height_px / 2, camera.width_px / 2), 255);
  for (int y = 0; y < camera.height_px; y += 17) {
    for (int x = 0; x < camera.width_px; x += 13) {
      const Eigen::Vector2d d = camera.DistortPixel(Eigen::Vector2d(x, y));
      EXPECT_NEAR(undistort.map_x.at<float>(y, x), d.x(), 1e-4);
      EXPECT_NEAR(undistort.map_y.at<float>(y, x), d.y(), 1e-4);
      const Eigen::Vector2d u = camera.UndistortPixel(Eigen::Vector2d(x, y));
      EXPECT_NEAR(distort.map_x.at<float>(y, x), u.x(), 1e-4);
      EXPECT_NEAR(distort.map_y.at<float>(y, x), u.y(), 1e-4);
    }
  }
}

TEST(Undistort, SharedTablesAreKeyedByTheIntrinsicsAlone) {
  TsaiCamera camera = TypicalCamera(5.720865e-4);
  const auto shared = SharedUndistortTables(camera);
  const RemapTables built = BuildUndistortTables(camera);
  EXPECT_EQ(cv::norm(shared->map_x, built.map_x, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(shared->map_y, built.map_y, cv::NORM_INF), 0.0);
  // Another pose of the same intrinsics: the same tables, not built again.
  camera.translation_mm += Eigen::Vector3d(100, 0, 0);
  camera.id = "moved";
  EXPECT_EQ(SharedUndistortTables(camera).get(), shared.get());
  // Another kappa1: other tables, matching their own camera.
  camera.kappa1_per_mm2 = -1e-3;
  const auto other = SharedUndistortTables(camera);
  EXPECT_NE(other.get(), shared.get());
  EXPECT_EQ(cv::norm(other->map_x, BuildUndistortTables(camera).map_x, cv::NORM_INF), 0.0);
}

TEST(Undistort, NoDistortionIsTheIdentity) {
  const TsaiCamera camera = TypicalCamera(0.0);
  cv::Mat image(camera.height_px, camera.width_px, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(256));
  const cv::Mat out = UndistortImage(camera, image);
  EXPECT_EQ(cv::norm(out, image, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(DistortImage(camera, image), image, cv::NORM_INF), 0.0);
}

TEST(Undistort, KeepsTheImageType) {
  const TsaiCamera camera = TypicalCamera(5e-4);
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16SC2, CV_32FC3, CV_64FC1}) {
    const cv::Mat image(camera.height_px, camera.width_px, type, cv::Scalar::all(7));
    const cv::Mat out = UndistortImage(camera, image);
    EXPECT_EQ(out.type(), type) << cv::typeToString(type);
    EXPECT_EQ(out.size(), image.size());
    // The centre keeps its value (a constant image stays constant where data exists).
    EXPECT_EQ(
        cv::norm(out(cv::Rect(300, 250, 50, 50)), image(cv::Rect(300, 250, 50, 50)), cv::NORM_INF),
        0.0);
  }
}

TEST(Undistort, FoldedRegionIsBlack) {
  // kappa1 so negative that the image corners lie beyond the fold: no source there.
  const TsaiCamera camera = TypicalCamera(-4e-3);  // Rd_max = 9.1 mm < corner 10.9 mm
  const RemapTables tables = BuildUndistortTables(camera);
  EXPECT_EQ(tables.map_x.at<float>(0, 0), -1.0f);
  const cv::Mat image(camera.height_px, camera.width_px, CV_8UC1, cv::Scalar(200));
  const cv::Mat out = Remap(image, tables);
  EXPECT_EQ(out.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(out.at<uint8_t>(camera.height_px / 2, camera.width_px / 2), 200);
}

TEST(Undistort, BadInput) {
  const TsaiCamera camera = TypicalCamera(5e-4);
  ExpectInputError([&] { UndistortImage(camera, cv::Mat(10, 10, CV_8UC1)); },
                   {"camera 'typical'", "10x10", "720x576"});
  ExpectInputError([&] { DistortImage(camera, cv::Mat()); }, {"camera 'typical'", "empty"});
  TsaiCamera broken = camera;
  broken.focal_mm = -1.0;
  ExpectInputError([&] { BuildUndistortTables(broken); }, {"focal_mm"});
  const RemapTables tables = BuildUndistortTables(camera);
  ExpectInputError([&] { Remap(cv::Mat(5, 5, CV_8UC1), tables); }, {"5x5", "720x576"});
}

}  // namespace
}  // namespace dome::geometry
