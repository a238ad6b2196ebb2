#include "geometry/pinhole.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>
#include <vector>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::ExpectInputError;
using testing::TypicalCamera;

// Largest distance over a grid of the image between `tsai`'s pixel and the pixel that
// OpenCV's own cv::projectPoints gives the same ray with `pinhole` (K, k1, k2).
double MaxDisagreementWithOpenCvPx(const TsaiCamera& tsai, const PinholeCamera& pinhole) {
  std::vector<cv::Point3d> rays;
  std::vector<Eigen::Vector2d> pixels;
  for (int j = 0; j <= 40; ++j) {
    for (int i = 0; i <= 40; ++i) {
      const Eigen::Vector2d pixel((tsai.width_px - 1) * i / 40.0, (tsai.height_px - 1) * j / 40.0);
      const Eigen::Vector3d ray = tsai.rotation * tsai.BackProject(pixel);  // camera frame
      rays.emplace_back(ray.x(), ray.y(), ray.z());
      pixels.push_back(pixel);
    }
  }
  cv::Mat k(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      k.at<double>(r, c) = pinhole.K(r, c);
    }
  }
  const std::vector<double> dist = {pinhole.k1, pinhole.k2, 0.0, 0.0};
  std::vector<cv::Point2d> projected;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, dist, projected);
  double worst = 0.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    worst =
        std::max(worst, std::hypot(projected[i].x - pixels[i].x(), projected[i].y - pixels[i].y()));
  }
  return worst;
}

TEST(Pinhole, TsaiToPinholeHandComputed) {
  // f = 20 mm, dx = 0.01 mm, ncx = 800, nfx = 640 -> dpx = 0.0125 mm, sx = 1.1, dy = 0.01:
  //   fx = 20 * 1.1 / 0.0125 = 1760, fy = 20 / 0.01 = 2000.
  TsaiCamera tsai;
  tsai.id = "hand";
  tsai.width_px = 640;
  tsai.height_px = 480;
  tsai.sensor = {800, 640, 0.01, 0.01};
  tsai.focal_mm = 20.0;
  tsai.sx = 1.1;
  tsai.cx_px = 300.0;
  tsai.cy_px = 200.0;
  tsai.translation_mm = Eigen::Vector3d(1, 2, 3);
  RadialFitReport report;
  report.exact = false;
  const PinholeCamera pinhole = PinholeFromTsai(tsai, {}, &report);
  Eigen::Matrix3d expected;
  expected << 1760, 0, 300, 0, 2000, 200, 0, 0, 1;
  EXPECT_LT((pinhole.K - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(pinhole.k1, 0.0);
  EXPECT_EQ(pinhole.k2, 0.0);
  EXPECT_TRUE(report.exact);
  EXPECT_EQ(pinhole.translation_mm, tsai.translation_mm);
  EXPECT_EQ(pinhole.id, "hand");
  EXPECT_EQ(report.BriefReport(), "exact (no distortion)");
}

TEST(Pinhole, PinholeToTsaiHandComputed) {
  // fx = 1760, fy = 2000, pitch 0.01 mm: focal = 2000 * 0.01 = 20 mm, sx = 1760 / 2000
  // = 0.88, ncx = nfx = width, dx = dy = 0.01 mm.
  PinholeCamera pinhole;
  pinhole.id = "p";
  pinhole.width_px = 640;
  pinhole.height_px = 480;
  pinhole.K << 1760, 0, 300, 0, 2000, 200, 0, 0, 1;
  const TsaiCamera tsai = TsaiFromPinhole(pinhole);
  EXPECT_NEAR(tsai.focal_mm, 20.0, 1e-12);
  EXPECT_NEAR(tsai.sx, 0.88, 1e-15);
  EXPECT_EQ(tsai.sensor.ncx, 640);
  EXPECT_EQ(tsai.sensor.nfx, 640);
  EXPECT_EQ(tsai.sensor.dx_mm, 0.01);
  EXPECT_EQ(tsai.sensor.dy_mm, 0.01);
  EXPECT_EQ(tsai.cx_px, 300.0);
  EXPECT_EQ(tsai.cy_px, 200.0);
  EXPECT_EQ(tsai.kappa1_per_mm2, 0.0);
  EXPECT_LT((tsai.K() - pinhole.K).cwiseAbs().maxCoeff(), 1e-12);
  // Another pitch changes the sensor, not the camera.
  PinholeConversionOptions options;
  options.pixel_pitch_mm = 0.0074;
  EXPECT_LT((TsaiFromPinhole(pinhole, options).K() - pinhole.K).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Pinhole, UndistortedRoundTripIsExact) {
  std::mt19937 rng(3);
  const TsaiCamera tsai = TypicalCamera(0.0);
  const TsaiCamera back = TsaiFromPinhole(PinholeFromTsai(tsai));
  std::uniform_real_distribution<double> coordinate(-3000.0, 3000.0);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d world(coordinate(rng), coordinate(rng), coordinate(rng));
    Eigen::Vector2d a, b;
    const bool in_front = tsai.Project(world, &a);
    ASSERT_EQ(back.Project(world, &b), in_front);
    if (in_front) {
      EXPECT_LT((a - b).norm(), 1e-9 * std::max(1.0, a.norm()));
    }
  }
  // pinhole -> Tsai -> pinhole.
  PinholeCamera pinhole = PinholeFromTsai(tsai);
  const PinholeCamera again = PinholeFromTsai(TsaiFromPinhole(pinhole));
  EXPECT_LT((again.K - pinhole.K).cwiseAbs().maxCoeff(), 1e-9 * pinhole.K(0, 0));
  EXPECT_LT((again.rotation - pinhole.rotation).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(again.translation_mm, pinhole.translation_mm);
}

TEST(Pinhole, FittedK1MatchesFirstOrderTheoryAndOpenCv) {
  // To first order Xd = Xu (1 - kappa1 Ru^2), i.e. k1 = -kappa1 f^2 (normalized radius
  // Ru / f, square pixels): kappa1 = 1e-4 /mm^2, f = 20 mm -> k1 = -0.04.
  TsaiCamera tsai = TypicalCamera(1e-4);
  tsai.focal_mm = 20.0;
  tsai.sx = 1.0;
  tsai.sensor = {720, 720, 0.023, 0.023};
  RadialFitReport report;
  const PinholeCamera pinhole = PinholeFromTsai(tsai, {}, &report);
  EXPECT_NEAR(pinhole.k1, -0.04, 0.04 * 0.05);
  EXPECT_EQ(pinhole.k2, 0.0);
  EXPECT_FALSE(report.exact);
  EXPECT_EQ(report.num_samples, 64 * 64);
  EXPECT_GT(report.max_residual_px, 0.0);
  EXPECT_LT(report.max_residual_px, 0.5);
  EXPECT_LE(report.rms_residual_px, report.max_residual_px);
  // OpenCV itself, given K and k1, puts the Tsai camera's rays where the report says.
  EXPECT_NEAR(MaxDisagreementWithOpenCvPx(tsai, pinhole), report.max_residual_px,
              0.05 * report.max_residual_px + 1e-9);

  // With k2, the third-order term 3 kappa1^2 Ru^5 is absorbed: k2 ~ 3 kappa1^2 f^4.
  PinholeConversionOptions options;
  options.fit_k2 = true;
  RadialFitReport report2;
  const PinholeCamera pinhole2 = PinholeFromTsai(tsai, options, &report2);
  EXPECT_NEAR(pinhole2.k2, 3 * 1e-8 * std::pow(20.0, 4), 0.25 * 3 * 1e-8 * std::pow(20.0, 4));
  EXPECT_LT(report2.max_residual_px, report.max_residual_px / 5);
  EXPECT_NEAR(MaxDisagreementWithOpenCvPx(tsai, pinhole2), report2.max_residual_px,
              0.05 * report2.max_residual_px + 1e-9);
}

TEST(Pinhole, FitResidualsForRealisticDistortion) {
  // The EPFL cameras: kappa1 = 5.7e-4 /mm^2 on a 16.6 x 13.2 mm sensor.
  for (const double kappa : {5.720865e-4, -5e-4}) {
    const TsaiCamera tsai = TypicalCamera(kappa);
    for (const bool fit_k2 : {false, true}) {
      PinholeConversionOptions options;
      options.fit_k2 = fit_k2;
      RadialFitReport report;
      const PinholeCamera pinhole = PinholeFromTsai(tsai, options, &report);
      EXPECT_NEAR(MaxDisagreementWithOpenCvPx(tsai, pinhole), report.max_residual_px,
                  0.05 * report.max_residual_px + 1e-9);
      // And back: the pinhole camera's distortion as a Tsai kappa1.
      RadialFitReport back_report;
      const TsaiCamera back = TsaiFromPinhole(pinhole, {}, &back_report);
      EXPECT_NEAR(back.kappa1_per_mm2 * std::pow(0.01 / 0.023, 2) /* pitch */, kappa,
                  0.1 * std::abs(kappa));
      RecordProperty(
          std::string("max_residual_px_") + (kappa > 0 ? "pos" : "neg") + (fit_k2 ? "_k2" : "_k1"),
          report.BriefReport() + " / back: " + back_report.BriefReport());
    }
  }
}

TEST(Pinhole, PinholeToTsaiFitAgreesWithOpenCv) {
  PinholeCamera pinhole;
  pinhole.id = "cv";
  pinhole.width_px = 640;
  pinhole.height_px = 480;
  pinhole.K << 520, 0, 318, 0, 525, 242, 0, 0, 1;
  for (const double k1 : {-0.12, 0.08}) {
    pinhole.k1 = k1;
    RadialFitReport report;
    const TsaiCamera tsai = TsaiFromPinhole(pinhole, {}, &report);
    EXPECT_FALSE(report.exact);
    EXPECT_EQ(report.num_skipped, 0);
    // First order: kappa1 ~ -k1 / f^2 with f = fy * pitch = 5.25 mm.
    EXPECT_NEAR(tsai.kappa1_per_mm2, -k1 / (5.25 * 5.25), 0.2 * std::abs(k1) / (5.25 * 5.25));
    // The same rays, measured by OpenCV: within the reported residual (the report
    // measures Tsai's pixel of OpenCV's ray, this OpenCV's pixel of Tsai's ray; both are
    // the same discrepancy to first order).
    const double opencv = MaxDisagreementWithOpenCvPx(tsai, pinhole);
    EXPECT_LT(opencv, 1.5 * report.max_residual_px + 1e-6);
    EXPECT_GT(opencv, 0.5 * report.max_residual_px);
  }
}

TEST(Pinhole, OpenCvUndistortRadiusInvertsTheForwardModel) {
  for (const auto& [k1, k2] : std::vector<std::pair<double, double>>{
           {-0.3, 0.1}, {0.2, 0.05}, {-0.2, 0.0}, {0.1, 0.0}, {0.05, -0.02}, {0.0, 0.3}}) {
    for (double ru = 0.0; ru <= 1.0; ru += 0.01) {
      const double rd = OpenCvDistortRadius(ru, k1, k2);
      // Only where the forward map still increases.
      const double slope = 1 + 3 * k1 * ru * ru + 5 * k2 * std::pow(ru, 4);
      if (slope <= 0.0) {
        break;
      }
      double back;
      ASSERT_TRUE(OpenCvUndistortRadius(rd, k1, k2, &back)) << k1 << " " << k2 << " " << ru;
      EXPECT_NEAR(back, ru, 1e-12 * std::max(ru, 1e-3)) << k1 << " " << k2;
    }
  }
  double ru;
  // k1 = -0.5, k2 = 0: rd reaches at most 2 / (3 sqrt(1.5)) = 0.544.
  EXPECT_FALSE(OpenCvUndistortRadius(0.6, -0.5, 0.0, &ru));
  EXPECT_TRUE(OpenCvUndistortRadius(0.5, -0.5, 0.0, &ru));
  EXPECT_FALSE(OpenCvUndistortRadius(2.0, -0.3, 0.01, &ru));
}

TEST(Pinhole, CheckNamesTheField) {
  PinholeCamera good;
  good.id = "p";
  good.width_px = 640;
  good.height_px = 480;
  good.K << 500, 0, 320, 0, 500, 240, 0, 0, 1;
  EXPECT_NO_THROW(good.Check("cams.txt"));
  const auto expect = [&](const std::string& fragment, auto mutate) {
    PinholeCamera camera = good;
    mutate(&camera);
    ExpectInputError([&] { camera.Check("cams.txt"); }, {"cams.txt: " + fragment});
    ExpectInputError([&] { TsaiFromPinhole(camera); }, {"camera 'p'", fragment});
  };
  expect("K(0,1) (skew)", [](PinholeCamera* c) { c->K(0, 1) = 0.5; });
  expect("K(0,0) (fx)", [](PinholeCamera* c) { c->K(0, 0) = -500; });
  expect("K(1,1) (fy)", [](PinholeCamera* c) { c->K(1, 1) = 0; });
  expect("K(2,2)", [](PinholeCamera* c) { c->K(2, 2) = 2; });
  expect("K", [](PinholeCamera* c) { c->K(2, 0) = 0.1; });
  expect("K(0,2)", [](PinholeCamera* c) { c->K(0, 2) = std::nan(""); });
  expect("k1", [](PinholeCamera* c) { c->k1 = std::nan(""); });
  expect("k2", [](PinholeCamera* c) { c->k2 = INFINITY; });
  expect("width_px", [](PinholeCamera* c) { c->width_px = 0; });
  expect("rotation", [](PinholeCamera* c) { c->rotation(0, 1) = 0.01; });
  expect("rotation", [](PinholeCamera* c) { c->rotation = -Eigen::Matrix3d::Identity(); });
  expect("translation_mm[1]", [](PinholeCamera* c) { c->translation_mm.y() = std::nan(""); });
}

TEST(Pinhole, OptionsAreChecked) {
  PinholeCamera camera;
  camera.id = "p";
  camera.width_px = 64;
  camera.height_px = 48;
  camera.K << 50, 0, 32, 0, 50, 24, 0, 0, 1;
  PinholeConversionOptions options;
  options.pixel_pitch_mm = 0.0;
  ExpectInputError([&] { TsaiFromPinhole(camera, options); },
                   {"PinholeConversionOptions.pixel_pitch_mm", "positive"});
  options = {};
  options.fit_samples_per_side = 1;
  ExpectInputError([&] { PinholeFromTsai(TypicalCamera(1e-4), options); },
                   {"PinholeConversionOptions.fit_samples_per_side"});
  TsaiCamera bad = TypicalCamera(1e-4);
  bad.sx = -1;
  ExpectInputError([&] { PinholeFromTsai(bad); }, {"camera 'typical': sx"});
}

TEST(Pinhole, DistortionThatFoldsBeforeTheImageEdgeIsSkippedOrRejected) {
  PinholeCamera camera;
  camera.id = "fold";
  camera.width_px = 640;
  camera.height_px = 480;
  camera.K << 300, 0, 320, 0, 300, 240, 0, 0, 1;  // corner at normalized radius 1.33
  camera.k1 = -0.4;  // rd reaches at most 0.61: the corners have no ray
  RadialFitReport report;
  const TsaiCamera tsai = TsaiFromPinhole(camera, {}, &report);
  EXPECT_GT(report.num_skipped, 0);
  EXPECT_EQ(report.num_samples + report.num_skipped, 64 * 64);
  EXPECT_NO_THROW(tsai.Check("fold"));
}

}  // namespace
}  // namespace dome::geometry
