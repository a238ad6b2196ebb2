#include "synth/render.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "brute_force_ray.h"
#include "synth/batter.h"
#include "synth/noise.h"
#include "synth/scene.h"
#include "synth/synth.h"

namespace dome::synth {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

bool BruteForce(const SceneMesh& mesh, const Vector3d& o, const Vector3d& d, double* t_best,
                int* face_best, double* u_best, double* v_best) {
  const dome::testing::BruteForceHit hit = dome::testing::BruteForceIntersect(mesh, o, d);
  *t_best = hit.t;
  *face_best = hit.face;
  *u_best = hit.u;
  *v_best = hit.v;
  return hit.hit();
}

struct Fixture {
  double time_s = InstantTimeS(5);  // mid-swing: the bat is fastest
  std::vector<DomeCamera> cameras;
  SceneMesh first, second;
  Lighting lighting = DomeLighting();
  Fixture() : first(BuildDomeScene(time_s)), second(BuildDomeScene(time_s + kFieldDelayS)) {
    DomeRigOptions options;
    options.width_px = 80;
    options.height_px = 60;
    cameras = MakeDomeRig(options);
  }
};

const Fixture& Shared() {
  static const Fixture fixture;
  return fixture;
}

TEST(Render, RaysRoundTripThroughTheTsaiModel) {
  for (const auto& cam : Shared().cameras) {
    const auto& m = cam.rig.model;
    const CameraRays rays(m);
    EXPECT_LT((rays.origin() - m.CentreWorld()).norm(), 1e-9);
    for (double x = -0.5; x < m.width_px; x += 13.7) {
      for (double y = -0.5; y < m.height_px; y += 11.3) {
        const Vector3d d = rays.Direction(x, y);
        EXPECT_NEAR((m.rotation * d).z(), 1.0, 1e-12);  // t is the z-depth
        Vector2d px;
        ASSERT_TRUE(m.Project(rays.origin() + 1234.5 * d, &px));
        EXPECT_NEAR(px.x(), x, 1e-9);
        EXPECT_NEAR(px.y(), y, 1e-9);
        const Vector3d back = m.BackProject(Vector2d(x, y));
        EXPECT_NEAR(back.dot(d.normalized()), 1.0, 1e-12);
      }
    }
  }
}

// The truth depth at a pixel is the z-depth of the closest mesh triangle along the
// pixel's ray, found by brute force over the mesh.
TEST(Render, TruthDepthAgreesWithTheMesh) {
  const Fixture& fx = Shared();
  const RayCaster caster(fx.first);
  Rng rng(5);
  int checked = 0, person = 0;
  for (int c = 0; c < static_cast<int>(fx.cameras.size()); c += 7) {
    const auto& m = fx.cameras[c].rig.model;
    const cv::Mat depth = TruthDepth(m, caster);
    const CameraRays rays(m);
    for (int i = 0; i < 40; ++i) {
      const int x = static_cast<int>(rng.Uniform(0, m.width_px));
      const int y = static_cast<int>(rng.Uniform(0, m.height_px));
      double t, u, v;
      int face;
      const Vector3d d = rays.Direction(x, y);
      const bool hit = BruteForce(fx.first, rays.origin(), d, &t, &face, &u, &v);
      const float z = depth.at<float>(y, x);
      if (!hit) {
        EXPECT_EQ(z, 0.0f);
        continue;
      }
      const double z_ref = m.WorldToCamera(rays.origin() + t * d).z();
      EXPECT_NEAR(z, z_ref, 1e-4 * z_ref) << "camera " << m.id << " pixel " << x << "," << y;
      ++checked;
      if (fx.first.parts[fx.first.face_part[face]].on_person) ++person;
    }
  }
  EXPECT_GT(checked, 200);
  EXPECT_GT(person, 5);
}

// A noise-free image pixel is the average of its two frame samples, each the
// quantized Lambertian shading of the surface texture at the point its ray meets --
// computed here independently of the renderer's ray caster.
TEST(Render, PixelsAgreeWithTheSurfaceTexture) {
  const Fixture& fx = Shared();
  const RayCaster first(fx.first), second(fx.second);
  int compared = 0, on_person = 0;
  for (int c = 0; c < static_cast<int>(fx.cameras.size()); c += 5) {
    const auto& cam = fx.cameras[c];
    RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.response.noise_sigma = 0.0;
    request.first_field = &first;
    request.second_field = &second;
    request.lighting = &fx.lighting;
    request.depth = false;
    const RenderedView view = RenderView(request);
    const CameraRays rays(cam.rig.model);
    Rng rng(c);
    for (int i = 0; i < 30; ++i) {
      const int x = static_cast<int>(rng.Uniform(0, cam.rig.model.width_px));
      const int y = static_cast<int>(rng.Uniform(0, cam.rig.model.height_px));
      int expected_sum = 0;
      bool person = false;
      for (int s = 0; s < 2; ++s) {
        const Vector2d p = FrameSampleToImage(2 * x + s, 2 * y);
        const Vector3d d = rays.Direction(p.x(), p.y());
        double t, u, v;
        int face;
        double radiance = fx.lighting.sky_radiance;
        if (BruteForce(fx.first, rays.origin(), d, &t, &face, &u, &v)) {
          RayHit hit;
          hit.t = static_cast<float>(t);
          hit.face = static_cast<uint32_t>(face);
          hit.u = static_cast<float>(u);
          hit.v = static_cast<float>(v);
          radiance = HitRadiance(fx.first, fx.lighting, rays.origin(), d, hit);
          person |= fx.first.parts[fx.first.face_part[face]].on_person;
          // Same as evaluating the part's albedo at the point by hand.
          const Part& part = fx.first.parts[fx.first.face_part[face]];
          const double albedo = Albedo(part.material, part.ToLocal(rays.origin() + t * d));
          EXPECT_GE(radiance, albedo * fx.lighting.ambient - 1e-9);
        }
        const int sample = SensorValue(cam.response, radiance, 0.0);
        EXPECT_NEAR(view.frame.at<uint8_t>(2 * y, 2 * x + s), sample, 1) << cam.rig.model.id;
        expected_sum += sample;
      }
      EXPECT_NEAR(view.image.at<uint8_t>(y, x), (expected_sum + 1) / 2, 1);
      ++compared;
      on_person += person;
    }
  }
  EXPECT_GT(compared, 250);
  EXPECT_GT(on_person, 3);
}

// The two fields of a frame: identical on the static background, different where
// the person (the bat) moved in the 1/60 s between them (seed Figure 10).
TEST(Render, FieldsDifferWhereThePersonMovesOnly) {
  const Fixture& fx = Shared();
  const RayCaster first(fx.first), second(fx.second);
  int moving_differs = 0;
  for (const auto& cam : fx.cameras) {
    RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.first_field = &first;
    request.second_field = &second;
    request.lighting = &fx.lighting;
    request.noise_key = NoiseKey(1, 1, 5, 0);
    request.depth = false;
    request.person_mask = true;
    const RenderedView interlaced = RenderView(request);
    request.second_field = &first;  // a frame without motion, same noise
    const RenderedView still = RenderView(request);
    for (int r = 0; r < interlaced.frame.rows; ++r) {
      for (int j = 0; j < interlaced.frame.cols; ++j) {
        const bool same = interlaced.frame.at<uint8_t>(r, j) == still.frame.at<uint8_t>(r, j);
        const bool person =
            interlaced.on_person.at<uint8_t>(r, j) || still.on_person.at<uint8_t>(r, j);
        if (r % 2 == 0 || !person) {
          ASSERT_TRUE(same) << cam.rig.model.id << " sample " << j << "," << r;
        } else if (!same) {
          ++moving_differs;
        }
      }
    }
    // The take image is the first field only: motion does not reach it.
    EXPECT_EQ(cv::countNonZero(interlaced.image != still.image), 0);
  }
  EXPECT_GT(moving_differs, 100);
}

TEST(Render, NoiseHasTheCamerasSigmaAndDependsOnlyOnTheKey) {
  const Fixture& fx = Shared();
  const RayCaster first(fx.first);
  const auto& cam = fx.cameras[10];
  RenderRequest request;
  request.camera = &cam.rig.model;
  request.response = cam.response;
  request.response.noise_sigma = 3.0;
  request.response.offset = 20.0;  // keep clear of 0 and 255
  request.response.gain = 150.0;
  request.first_field = request.second_field = &first;
  request.lighting = &fx.lighting;
  request.noise_key = 77;
  const RenderedView a = RenderView(request);
  const RenderedView b = RenderView(request);
  EXPECT_EQ(cv::countNonZero(a.frame != b.frame), 0);
  request.noise_key = 78;
  const RenderedView c = RenderView(request);
  EXPECT_GT(cv::countNonZero(a.frame != c.frame), a.frame.total() / 2);
  request.response.noise_sigma = 0.0;
  const RenderedView clean = RenderView(request);
  cv::Mat diff;
  a.frame.convertTo(diff, CV_64F);
  cv::Mat clean64;
  clean.frame.convertTo(clean64, CV_64F);
  diff -= clean64;
  cv::Scalar mean, sd;
  cv::meanStdDev(diff, mean, sd);
  EXPECT_NEAR(mean[0], 0.0, 0.1);
  EXPECT_NEAR(sd[0], std::sqrt(9.0 + 1.0 / 12.0), 0.15);  // sigma and rounding
  // Depth does not depend on noise.
  EXPECT_EQ(cv::countNonZero(a.depth_mm != clean.depth_mm), 0);
}

}  // namespace
}  // namespace dome::synth
