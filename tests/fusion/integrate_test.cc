#include "fusion/integrate.h"

#include <gtest/gtest.h>
#include <zstd.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "fusion/fusion_test_util.h"
#include "fusion/volume.h"
#include "testing/expect_error.h"

namespace dome::fusion {
namespace {

// A zstd frame of `raw` (content size declared), and the content of one.
std::string Zstd(const std::string& raw) {
  std::string out(ZSTD_compressBound(raw.size()), '\0');
  const size_t size = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 1);
  out.resize(size);
  return out;
}
// A slab of planes [k0, k1) of nx x ny voxels, without voxels yet.
Slab SlabOf(int k0, int k1, int nx, int ny) {
  Slab s;
  s.k0 = k0;
  s.k1 = k1;
  s.nx = nx;
  s.ny = ny;
  return s;
}
std::string Unzstd(const std::string& frame) {
  std::string out(size_t(ZSTD_getFrameContentSize(frame.data(), frame.size())), '\0');
  out.resize(ZSTD_decompress(out.data(), out.size(), frame.data(), frame.size()));
  return out;
}

using testing::ExpectInputError;

// A camera at the origin looking along world +z (identity pose), no distortion.
geometry::TsaiCamera AxisCamera(int w = 64, int h = 48) {
  geometry::TsaiCamera cam;
  cam.id = "axis";
  cam.width_px = w;
  cam.height_px = h;
  cam.sensor = {double(w), double(w), 0.01, 0.01};
  cam.focal_mm = 0.64;
  cam.cx_px = 0.5 * (w - 1);
  cam.cy_px = 0.5 * (h - 1);
  return cam;
}

// A grid of nx x ny x nz voxels of `size` mm from the min corner `origin`.
VolumeGrid Grid(double size, int nx, int ny, int nz, const Eigen::Vector3d& origin) {
  VolumeGrid g;
  g.voxel_size_mm = size;
  g.nx = nx;
  g.ny = ny;
  g.nz = nz;
  g.origin_mm = origin;
  return g;
}

// A single-voxel grid whose voxel centre is `p`.
VolumeGrid OneVoxel(const Eigen::Vector3d& p, double size = 1.0) {
  return Grid(size, 1, 1, 1, p - Eigen::Vector3d::Constant(0.5 * size));
}

RangeImage Flat(double depth, int w = 64, int h = 48) {
  RangeImage image;
  image.camera = AxisCamera(w, h);
  image.depth_mm = cv::Mat(h, w, CV_32FC1, cv::Scalar(depth));
  image.where = "flat.tiff";
  return image;
}

Slab Fuse(const VolumeGrid& g, const std::vector<RangeImage>& images, FusionOptions o = {}) {
  Integrator integrator(g, images, o);
  return integrator.IntegrateSlab(0, g.nz);
}

// The point on the optical axis of AxisCamera at depth z has ray scale 1.
TEST(Integrate, SignedDistanceAlongRayTruncationAndFreeSpaceClamp) {
  FusionOptions o;
  o.truncation_mm = 50;
  o.front_clamp_mm = 40;
  const std::vector<RangeImage> images = {Flat(1000)};
  // In front, within the clamp: d = 1000 - 970.
  Slab s = Fuse(OneVoxel({0, 0, 970}), images, o);
  EXPECT_FLOAT_EQ(s.weight[0], 1.0f);
  EXPECT_NEAR(s.distance_mm[0], 30.0f, 1e-3);
  // Far in front (free space): updated, clamped to front_clamp_mm.
  s = Fuse(OneVoxel({0, 0, 300}), images, o);
  EXPECT_FLOAT_EQ(s.weight[0], 1.0f);
  EXPECT_FLOAT_EQ(s.distance_mm[0], 40.0f);
  // Behind within the truncation: negative.
  s = Fuse(OneVoxel({0, 0, 1030}), images, o);
  EXPECT_FLOAT_EQ(s.weight[0], 1.0f);
  EXPECT_NEAR(s.distance_mm[0], -30.0f, 1e-3);
  // Far behind: untouched.
  s = Fuse(OneVoxel({0, 0, 1080}), images, o);
  EXPECT_EQ(s.weight[0], 0.0f);
  EXPECT_EQ(s.distance_mm[0], 0.0f);
  // Off axis the distance is measured along the ray: (D - z) * |(x/z, y/z, 1)|.
  const Eigen::Vector3d p(200, 0, 980);
  s = Fuse(OneVoxel(p), images, o);
  EXPECT_NEAR(s.distance_mm[0], 20.0 * std::sqrt(1 + std::pow(200.0 / 980, 2)), 2e-3);
}

TEST(Integrate, NoInterpolationAcrossDepthJump) {
  RangeImage step = Flat(1000);
  step.depth_mm.colRange(32, 64).setTo(2000);  // a jump between columns 31 and 32
  const geometry::TsaiCamera& cam = step.camera;
  // A voxel that projects between columns 31 and 32 (u = 31.5) is not updated.
  const Eigen::Vector3d between = cam.BackProjectAtDepth(Eigen::Vector2d(31.5, 20.3), 900);
  EXPECT_EQ(Fuse(OneVoxel(between), {step}).weight[0], 0.0f);
  // Inside either flat part it is.
  const Eigen::Vector3d left = cam.BackProjectAtDepth(Eigen::Vector2d(20.4, 20.3), 980);
  Slab s = Fuse(OneVoxel(left), {step});
  EXPECT_EQ(s.weight[0], 1.0f);
  const Eigen::Vector3d right = cam.BackProjectAtDepth(Eigen::Vector2d(40.4, 20.3), 1980);
  EXPECT_EQ(Fuse(OneVoxel(right), {step}).weight[0], 1.0f);
  // An invalid pixel (0) breaks every triangle it touches.
  RangeImage hole = Flat(1000);
  hole.depth_mm.at<float>(20, 20) = 0;
  EXPECT_EQ(Fuse(OneVoxel(cam.BackProjectAtDepth({20.2, 20.6}, 900)), {hole}).weight[0], 0.0f);
  // Outside the image: not observed.
  EXPECT_EQ(Fuse(OneVoxel({5000, 0, 900}), {Flat(1000)}).weight[0], 0.0f);
  // Behind the camera: not observed.
  EXPECT_EQ(Fuse(OneVoxel({0, 0, -900}), {Flat(1000)}).weight[0], 0.0f);
}

TEST(Integrate, WeightsAverageCameras) {
  RangeImage a = Flat(1000), b = Flat(1040);
  b.weight = cv::Mat(48, 64, CV_32FC1, cv::Scalar(3.0f));
  const Slab s = Fuse(OneVoxel({0, 0, 1000}), {a, b});
  EXPECT_FLOAT_EQ(s.weight[0], 4.0f);
  EXPECT_NEAR(s.distance_mm[0], (0 * 1 + 40 * 3) / 4.0, 1e-3);
}

TEST(Integrate, SphereZeroCrossingIsTheSurface) {
  // Strong distortion (the kernel's table) and a real lens's (its polynomial).
  for (double kappa : {0.05, 0.003}) {
    SCOPED_TRACE("kappa " + std::to_string(kappa));
    const std::vector<testing::Sphere> spheres = {{Eigen::Vector3d(0, 0, 500), 200}};
    const auto images = testing::RingImages(spheres, 8, 96, 72, {300, 500, 700}, kappa);
    const VolumeGrid g = Grid(10, 60, 60, 60, Eigen::Vector3d(-300, -300, 200));
    const Slab s = Fuse(g, images);
    // Along the x axis through the centre, the zero crossing is near x = +-200.
    const int j = 30, k = 30;  // voxel centres at y = 5, z = 505
    for (int i = 0; i + 1 < g.nx; ++i) {
      const size_t idx = (size_t(k) * g.ny + j) * g.nx + i;
      const float a = s.distance_mm[idx], b = s.distance_mm[idx + 1];
      if (s.weight[idx] > 0 && s.weight[idx + 1] > 0 && (a < 0) != (b < 0)) {
        const double x = g.VoxelCentreMm(i + a / (a - b), j, k).x();
        EXPECT_NEAR(std::abs(x), std::sqrt(200.0 * 200 - 5 * 5 - 5 * 5), 3.0) << x;
      }
    }
    // The centre is inside (negative, or beyond truncation: unobserved); the corner
    // is free space seen by some camera.
    const size_t centre = (size_t(30) * g.ny + 30) * g.nx + 30;
    EXPECT_TRUE(s.weight[centre] == 0 || s.distance_mm[centre] < 0);
    const size_t corner = (size_t(30) * g.ny + 0) * g.nx + 0;
    EXPECT_GT(s.weight[corner], 0);
    EXPECT_GT(s.distance_mm[corner], 0);
  }
}

// Stereo's depth maps are on the ideal camera's pixels (it undistorts every image
// first): fused through the ideal camera, a sphere filling most of strongly distorted
// images comes out where it is; projected through the lens instead, the same maps put
// it millimetres off.
TEST(Integrate, IdealPixelDepthMapsOfDistortedCamerasAreFusedInTheIdealFrame) {
  const std::vector<testing::Sphere> spheres = {{Eigen::Vector3d(0, 0, 500), 500}};
  // The largest distance from the sphere of the zero crossings along x in one-plane
  // grids at three heights, 4 mm voxels (a third of a pixel at the sphere).
  const auto worst_error = [&](const std::vector<RangeImage>& images) {
    double worst = 0;
    int crossings = 0;
    for (double z : {205.0, 505.0, 705.0}) {
      const VolumeGrid g = Grid(4, 300, 300, 1, Eigen::Vector3d(-600, -600, z - 2));
      const Slab s = Fuse(g, images);
      for (int j = 0; j < g.ny; j += 10) {
        for (int i = 0; i + 1 < g.nx; ++i) {
          const size_t idx = size_t(j) * g.nx + i;
          const float a = s.distance_mm[idx], b = s.distance_mm[idx + 1];
          if (!(s.weight[idx] > 0 && s.weight[idx + 1] > 0 && (a < 0) != (b < 0))) continue;
          const Eigen::Vector3d p = g.VoxelCentreMm(i + a / (a - b), j, 0);
          worst = std::max(worst, std::abs((p - spheres[0].centre_mm).norm() - 500.0));
          ++crossings;
        }
      }
    }
    EXPECT_GT(crossings, 50);
    return worst;
  };
  std::vector<RangeImage> ideal = testing::RingImages(spheres, 8, 320, 240, {300, 500, 700}, 0.05,
                                                      /*ideal_pixels=*/true);
  const double right = worst_error(ideal);
  for (auto& image : ideal) image.distorted_pixels = true;  // the wrong frame
  const double wrong = worst_error(ideal);
  std::printf("ideal frame: %.2f mm, through the lens: %.2f mm\n", right, wrong);
  EXPECT_LT(right, 2.0);
  EXPECT_GT(wrong, 3 * right);
}

TEST(Integrate, AnySlabPartitionAndThreadCountIsBitIdentical) {
  const auto images = testing::RingImages(testing::StackedSpheres(), 8, 64, 48, {500, 1500, 2500});
  const VolumeGrid g = Grid(10, 32, 32, 300, Eigen::Vector3d(-160, -160, 0));
  FusionOptions one_thread;
  one_thread.num_threads = 1;
  const Slab whole = Integrator(g, images, one_thread).IntegrateSlab(0, g.nz);
  double weight_sum = 0;
  for (float w : whole.weight) weight_sum += w;
  EXPECT_GT(weight_sum, 0);
  for (int threads : {1, 2, 3}) {
    FusionOptions o;
    o.num_threads = threads;
    Integrator integrator(g, images, o);
    for (int slabs : {1, 7, 300}) {
      std::vector<float> d, w;
      for (int s = 0; s < slabs; ++s) {
        const int k0 = g.nz * s / slabs, k1 = g.nz * (s + 1) / slabs;
        const Slab part = integrator.IntegrateSlab(k0, k1);
        d.insert(d.end(), part.distance_mm.begin(), part.distance_mm.end());
        w.insert(w.end(), part.weight.begin(), part.weight.end());
      }
      ASSERT_EQ(d.size(), whole.distance_mm.size());
      EXPECT_EQ(std::memcmp(d.data(), whole.distance_mm.data(), d.size() * 4), 0)
          << threads << " threads, " << slabs << " slabs";
      EXPECT_EQ(std::memcmp(w.data(), whole.weight.data(), w.size() * 4), 0);
    }
  }
}

// An integrator's table memory is handed on to the next one (integrate.cc): results must
// not depend on what an earlier integrator, of another scene or size, left there, nor on
// several being alive at once.
TEST(Integrate, ReusedTableMemoryChangesNothing) {
  const auto spheres = testing::RingImages(testing::StackedSpheres(), 6, 64, 48, {500, 1500});
  // Another scene of the same sizes (a flat wall behind everything) and a larger one.
  std::vector<RangeImage> wall = spheres;
  for (auto& im : wall) im.depth_mm = cv::Mat(im.depth_mm.size(), CV_32FC1, cv::Scalar(1400.0f));
  const auto larger = testing::RingImages(testing::StackedSpheres(), 9, 96, 72, {500, 1500});
  const VolumeGrid g = Grid(10, 41, 33, 120, Eigen::Vector3d(-200, -160, 100));
  const FusionOptions o;
  const Slab first = Integrator(g, spheres, o).IntegrateSlab(0, g.nz);
  size_t observed = 0;
  for (float w : first.weight) observed += w > 0;
  EXPECT_GT(observed, first.weight.size() / 10);
  auto same = [&](const Slab& s) {
    return s.distance_mm.size() == first.distance_mm.size() &&
           std::memcmp(s.distance_mm.data(), first.distance_mm.data(), s.distance_mm.size() * 4) ==
               0 &&
           std::memcmp(s.weight.data(), first.weight.data(), s.weight.size() * 4) == 0;
  };
  for (const std::vector<RangeImage>* other :
       std::initializer_list<const std::vector<RangeImage>*>{&wall, &larger}) {
    const Slab o_slab = Integrator(g, *other, o).IntegrateSlab(0, g.nz);
    EXPECT_FALSE(same(o_slab));  // the other scene fills the tables differently
    EXPECT_TRUE(same(Integrator(g, spheres, o).IntegrateSlab(0, g.nz)));
  }
  // Two alive at once, built in either order.
  Integrator a(g, wall, o);
  Integrator b(g, spheres, o);
  EXPECT_TRUE(same(b.IntegrateSlab(0, g.nz)));
  EXPECT_FALSE(same(a.IntegrateSlab(0, g.nz)));
}

// An instant where no camera found a depth (a person in the frames of too few of a
// sparse rig's cameras: the fusion stage leaves every empty map out) fuses to a volume
// no camera observed, not to an error. A table memory of no bytes once failed to map
// (std::bad_alloc from the fusion job).
TEST(Integrate, NoRangeImageLeavesEveryVoxelUnobserved) {
  const VolumeGrid g = Grid(10, 20, 16, 12, Eigen::Vector3d(-100, -80, 400));
  const Slab slab = Integrator(g, {}, FusionOptions{}).IntegrateSlab(0, g.nz);
  ASSERT_EQ(slab.weight.size(), size_t(g.nx) * g.ny * g.nz);
  for (size_t i = 0; i < slab.weight.size(); ++i) {
    ASSERT_EQ(slab.weight[i], 0.0f) << i;
    ASSERT_EQ(slab.distance_mm[i], 0.0f) << i;
  }
}

TEST(Integrate, SlabRoundTripsThroughBytes) {
  Slab s = SlabOf(3, 5, 2, 3);
  for (int m = 0; m < 12; ++m) {
    s.distance_mm.push_back(m * 0.5f - 2);
    s.weight.push_back(float(m));
  }
  const Slab back = DecodeSlab(EncodeSlab(s), "slab.bin");
  EXPECT_EQ(back.k0, 3);
  EXPECT_EQ(back.k1, 5);
  EXPECT_EQ(back.distance_mm, s.distance_mm);
  EXPECT_EQ(back.weight, s.weight);
  std::string bytes = EncodeSlab(s);
  bytes.pop_back();
  ExpectInputError([&] { DecodeSlab(bytes, "slab.bin"); }, {"slab.bin", "bytes"});
  ExpectInputError([&] { DecodeSlab("garbage", "slab.bin"); }, {"slab.bin", "DOMESLAB"});
}

// The encoders are reused (volume.cc keeps their buffers and compressor): a slab's bytes
// depend on the slab alone, whatever was encoded before and on however many threads at
// once (a slab's bytes are its content address in the journal).
TEST(Integrate, ASlabsBytesDoNotDependOnWhatWasEncodedBefore) {
  auto make = [](int k0, int nx, float value) {
    Slab s;
    s.k0 = k0;
    s.k1 = k0 + 4;
    s.nx = nx;
    s.ny = 50;
    const size_t n = size_t(4) * 50 * nx;
    for (size_t m = 0; m < n; ++m) {
      s.distance_mm.push_back(m % 7 == 0 ? value : 0.0f);
      s.weight.push_back(float(m % 5));
    }
    return s;
  };
  const Slab small = make(0, 40, 1.5f), large = make(8, 400, -2.25f);
  const std::string first = EncodeSlab(small);
  const std::string large_bytes = EncodeSlab(large);
  EXPECT_EQ(EncodeSlab(small), first);  // after a larger slab in the same encoder
  std::vector<std::string> at_once(8);
  std::vector<std::thread> threads;
  for (size_t t = 0; t < at_once.size(); ++t)
    threads.emplace_back([&, t] { at_once[t] = EncodeSlab(t % 2 ? small : large); });
  for (auto& t : threads) t.join();
  for (size_t t = 0; t < at_once.size(); ++t) EXPECT_EQ(at_once[t], t % 2 ? first : large_bytes);
  const Slab back = DecodeSlab(large_bytes, "slab.bin");
  EXPECT_EQ(back.distance_mm, large.distance_mm);
  EXPECT_EQ(back.weight, large.weight);
}

TEST(Integrate, SlabsTravelCompressedAndVersionOneStillReads) {
  // A slab like fusion's: mostly unobserved voxels (0, 0), a band of free space at the
  // truncation distance, a few surface crossings.
  Slab s;
  s.k0 = 16;
  s.k1 = 32;
  s.nx = 100;
  s.ny = 100;
  const size_t n = size_t(16) * 100 * 100;
  s.distance_mm.assign(n, 0.0f);
  s.weight.assign(n, 0.0f);
  for (size_t m = n / 4; m < n / 2; ++m) {
    s.distance_mm[m] = (m % 100 == 50) ? -3.25f : 60.0f;
    s.weight[m] = float(1 + m % 3);
  }
  const std::string bytes = EncodeSlab(s);
  EXPECT_LT(bytes.size(), n * 8 / 20) << "8 bytes a voxel raw";
  const Slab back = DecodeSlab(bytes, "slab.bin");
  EXPECT_EQ(back.k0, 16);
  EXPECT_EQ(back.k1, 32);
  EXPECT_EQ(back.distance_mm, s.distance_mm);
  EXPECT_EQ(back.weight, s.weight);
  uint32_t version;
  std::memcpy(&version, bytes.data() + 8, 4);
  EXPECT_EQ(version, 3u);
  // Version 2: distances then weights, one zstd frame.
  std::string raw(reinterpret_cast<const char*>(s.distance_mm.data()), n * 4);
  raw.append(reinterpret_cast<const char*>(s.weight.data()), n * 4);
  std::string v2(bytes.substr(0, 28));
  const uint32_t two = 2;
  std::memcpy(v2.data() + 8, &two, 4);
  v2.append(Zstd(raw));
  const Slab second = DecodeSlab(v2, "v2.bin");
  EXPECT_EQ(second.distance_mm, s.distance_mm);
  EXPECT_EQ(second.weight, s.weight);
  // Version 1: the floats as they are.
  std::string v1(bytes.substr(0, 28));
  const uint32_t one = 1;
  std::memcpy(v1.data() + 8, &one, 4);
  v1.append(reinterpret_cast<const char*>(s.distance_mm.data()), n * 4);
  v1.append(reinterpret_cast<const char*>(s.weight.data()), n * 4);
  const Slab old = DecodeSlab(v1, "old.bin");
  EXPECT_EQ(old.distance_mm, s.distance_mm);
  EXPECT_EQ(old.weight, s.weight);
  // A corrupt payload and a header naming a huge slab are input errors, not crashes.
  std::string corrupt = bytes;
  corrupt[corrupt.size() / 2] ^= 0x5a;
  corrupt[corrupt.size() / 2 + 1] ^= 0x5a;
  ExpectInputError([&] { DecodeSlab(corrupt, "corrupt.bin"); }, {"corrupt.bin"});
  std::string huge = bytes;
  const int32_t big = 1 << 30;
  std::memcpy(huge.data() + 16, &big, 4);
  ExpectInputError([&] { DecodeSlab(huge, "huge.bin"); }, {"huge.bin", "voxels"});
}

// Version 3's records: runs of three identical voxels or more as one pair, the rest as
// they are, bit for bit (a negative zero, a NaN's payload); records that do not code the
// slab's voxels are named.
TEST(Integrate, SlabRunsAreTheRecordsTheFormatStates) {
  Slab s = SlabOf(0, 1, 12, 1);
  uint32_t nan_bits = 0x7fc01234u;
  float nan;
  std::memcpy(&nan, &nan_bits, 4);
  s.distance_mm = {0, 0, 0, 0, 0, 1.5f, -0.0f, 0, 0, 0, nan, 2};
  s.weight = {0, 0, 0, 0, 0, 2, 3, 0, 0, 0, 1, 1};
  const std::string bytes = EncodeSlab(s);
  const std::string runs = Unzstd(bytes.substr(28));
  // run 5 x (0, 0); literal 2: (1.5, 2) (-0, 3); run 3 x (0, 0); literal 2: (nan, 1) (2, 1)
  std::string expected;
  const auto tag = [&](uint32_t t) { expected.append(reinterpret_cast<const char*>(&t), 4); };
  const auto pair = [&](size_t i) {
    expected.append(reinterpret_cast<const char*>(&s.distance_mm[i]), 4);
    expected.append(reinterpret_cast<const char*>(&s.weight[i]), 4);
  };
  tag(0x80000000u | 5), pair(0), tag(2), pair(5), pair(6), tag(0x80000000u | 3), pair(7), tag(2),
      pair(10), pair(11);
  EXPECT_EQ(runs, expected);
  const Slab back = DecodeSlab(bytes, "slab.bin");
  ASSERT_EQ(back.distance_mm.size(), 12u);
  EXPECT_EQ(std::memcmp(back.distance_mm.data(), s.distance_mm.data(), 48), 0);
  EXPECT_EQ(std::memcmp(back.weight.data(), s.weight.data(), 48), 0);
  // Records that code too few or too many voxels, a count of 0, a pair cut short.
  const auto with_runs = [&](const std::string& r) { return bytes.substr(0, 28) + Zstd(r); };
  for (const std::string& bad : {expected.substr(0, 44),                             // 10 voxels
                                 expected + expected.substr(0, 12),                  // 17
                                 std::string("\0\0\0\x80", 4) + expected.substr(4),  // a run of 0
                                 expected.substr(0, expected.size() - 3)}) {
    ExpectInputError([&] { DecodeSlab(with_runs(bad), "bad.bin"); },
                     {"bad.bin", "do not code the slab's 12 voxels"});
  }
}

TEST(Integrate, BadInputGivesClearErrors) {
  const VolumeGrid ok = OneVoxel({0, 0, 900});
  // Depth map size not matching its camera.
  RangeImage wrong = Flat(1000);
  wrong.depth_mm = cv::Mat(40, 64, CV_32FC1, cv::Scalar(1000));
  ExpectInputError([&] { Integrator(ok, {wrong}, {}); },
                   {"flat.tiff", "64x40", "camera axis is 64x48"});
  // NaN depth.
  RangeImage nan = Flat(1000);
  nan.depth_mm.at<float>(5, 7) = std::numeric_limits<float>::quiet_NaN();
  ExpectInputError([&] { Integrator(ok, {nan}, {}); }, {"flat.tiff", "(7, 5)"});
  // Negative depth.
  RangeImage negative = Flat(1000);
  negative.depth_mm.at<float>(1, 2) = -5;
  ExpectInputError([&] { Integrator(ok, {negative}, {}); }, {"flat.tiff", "(2, 1)"});
  // Weight map of the wrong size.
  RangeImage weighted = Flat(1000);
  weighted.weight = cv::Mat(3, 3, CV_32FC1, cv::Scalar(1));
  ExpectInputError([&] { Integrator(ok, {weighted}, {}); }, {"flat.tiff: weight"});
  // Volume with zero or negative size.
  VolumeGrid zero = ok;
  zero.nx = 0;
  ExpectInputError([&] { Integrator(zero, {Flat(1000)}, {}); }, {"volume: nx", "positive"});
  VolumeGrid negative_size = ok;
  negative_size.nz = -3;
  ExpectInputError([&] { Integrator(negative_size, {Flat(1000)}, {}); }, {"volume: nz"});
  VolumeGrid no_voxel = ok;
  no_voxel.voxel_size_mm = 0;
  ExpectInputError([&] { Integrator(no_voxel, {Flat(1000)}, {}); }, {"volume: voxel_size_mm"});
  VolumeGrid nan_origin = ok;
  nan_origin.origin_mm.x() = std::nan("");
  ExpectInputError([&] { Integrator(nan_origin, {Flat(1000)}, {}); }, {"volume: origin_mm"});
  // Slab outside the volume.
  Integrator integrator(ok, {Flat(1000)}, {});
  ExpectInputError([&] { integrator.IntegrateSlab(0, 2); }, {"slab", "[0, 2)", "[0, 1)"});
  ExpectInputError([&] { integrator.IntegrateSlab(-1, 1); }, {"slab", "[-1, 1)"});
  ExpectInputError([&] { integrator.IntegrateSlab(1, 1); }, {"slab", "[1, 1)"});
  // Options out of range.
  FusionOptions bad;
  bad.truncation_mm = 0;
  ExpectInputError([&] { Integrator(ok, {Flat(1000)}, bad); }, {"fusion: truncation_mm"});
  bad = {};
  bad.max_depth_jump_ratio = std::nan("");
  ExpectInputError([&] { Integrator(ok, {Flat(1000)}, bad); }, {"fusion: max_depth_jump_ratio"});
  ExpectInputError([&] { FuseVolume(ok, {Flat(1000)}, {}, 0, [](const Slab&) {}); },
                   {"planes_per_slab"});
}

}  // namespace
}  // namespace dome::fusion

namespace dome::fusion {
namespace {

// Scenes that exercise every shortcut of the kernel, and the volume they fill: stacked
// spheres seen by a ring of 8 cameras; the same with a far wall behind them (free space
// everywhere); with a slanted wall through the volume (voxels near it, in front and
// behind, are decided per voxel); and that with weight maps.
struct KernelScenes {
  std::vector<std::vector<RangeImage>> sets;
  VolumeGrid grid;
};
KernelScenes MakeKernelScenes() {
  const std::vector<RangeImage> images =
      testing::RingImages(testing::StackedSpheres(), 8, 64, 48, {500, 1500, 2500});
  // A backdrop: every pixel has a surface (a far wall), so free space is everywhere.
  std::vector<RangeImage> walled = images;
  for (auto& im : walled) {
    im.depth_mm = im.depth_mm.clone();  // cv::Mat copies share pixels
    for (int y = 0; y < im.depth_mm.rows; ++y)
      for (int x = 0; x < im.depth_mm.cols; ++x)
        if (im.depth_mm.at<float>(y, x) == 0) im.depth_mm.at<float>(y, x) = 2900.0f + x;
  }
  // A slanted wall through the volume (about 1.6 m from each camera, the spheres' far
  // side): voxels near it, in front and behind, are decided per voxel.
  std::vector<RangeImage> near_wall = images;
  for (auto& im : near_wall) {
    im.depth_mm = im.depth_mm.clone();
    for (int y = 0; y < im.depth_mm.rows; ++y)
      for (int x = 0; x < im.depth_mm.cols; ++x)
        if (im.depth_mm.at<float>(y, x) == 0) im.depth_mm.at<float>(y, x) = 1580.0f + 1.5f * x;
  }
  // Weight maps that vary across the image: the far-behind shortcuts still apply.
  std::vector<RangeImage> weighted = near_wall;
  for (auto& im : weighted) {
    im.weight = cv::Mat(im.depth_mm.size(), CV_32FC1);
    for (int y = 0; y < im.weight.rows; ++y)
      for (int x = 0; x < im.weight.cols; ++x) im.weight.at<float>(y, x) = 0.5f + (x + 2 * y) % 3;
  }
  KernelScenes k;
  k.grid = Grid(10, 45, 37, 300, Eigen::Vector3d(-230, -190, 0));
  // A real lens's distortion: the kernel evaluates its polynomial, not the table.
  std::vector<RangeImage> real_lens = near_wall;
  for (auto& im : real_lens) im.camera.kappa1_per_mm2 = 0.003;
  k.sets = {images, walled, near_wall, weighted, real_lens};
  return k;
}

// Block culling is a pure shortcut: with it off every voxel takes the full per-voxel
// computation (no block, tile or quad shortcut), with uniform weights and with weight maps.
TEST(Integrate, BlockCullingChangesNothing) {
  const KernelScenes scenes = MakeKernelScenes();
  const VolumeGrid& g = scenes.grid;
  for (const auto& images : scenes.sets) {
    const std::vector<RangeImage>* set = &images;
    FusionOptions on, off;
    off.block_culling = false;
    const Slab a = Integrator(g, *set, on).IntegrateSlab(0, g.nz);
    const Slab b = Integrator(g, *set, off).IntegrateSlab(0, g.nz);
    // The scene is seen: many voxels are updated, and free space is clamped.
    size_t observed = 0, clamped = 0;
    for (size_t n = 0; n < a.weight.size(); ++n) {
      observed += a.weight[n] > 0;
      clamped += a.weight[n] > 0 && a.distance_mm[n] == float(on.front_clamp_mm);
    }
    EXPECT_GT(observed, a.weight.size() / 10);
    EXPECT_GT(clamped, a.weight.size() / 20);
    EXPECT_EQ(std::memcmp(a.distance_mm.data(), b.distance_mm.data(), a.distance_mm.size() * 4), 0);
    EXPECT_EQ(std::memcmp(a.weight.data(), b.weight.data(), a.weight.size() * 4), 0);
    // And slabs that cut blocks (7 planes) agree too.
    Integrator integrator(g, *set, on);
    const Slab part = integrator.IntegrateSlab(13, 20);
    EXPECT_EQ(std::memcmp(part.distance_mm.data(), a.distance_mm.data() + size_t(13) * 45 * 37,
                          part.distance_mm.size() * 4),
              0);
  }
}

// The 8-lane kernel's two ways to read its tables (the CPU's gathers, scalar loads) give
// the same bits, on every scene.
TEST(Integrate, GathersAndScalarLoadsGiveTheSameBits) {
  const KernelScenes scenes = MakeKernelScenes();
  for (const auto& set : scenes.sets) {
    std::vector<Slab> slabs;
    for (TableLookups mode : {TableLookups::kGathers, TableLookups::kLoads, TableLookups::kAuto}) {
      SetTableLookups(mode);
      slabs.push_back(Integrator(scenes.grid, set, {}).IntegrateSlab(0, scenes.grid.nz));
    }
    SetTableLookups(TableLookups::kAuto);
    size_t observed = 0;
    for (float w : slabs[0].weight) observed += w > 0;
    EXPECT_GT(observed, slabs[0].weight.size() / 10);
    for (size_t m = 1; m < slabs.size(); ++m) {
      EXPECT_EQ(std::memcmp(slabs[m].distance_mm.data(), slabs[0].distance_mm.data(),
                            slabs[0].distance_mm.size() * 4),
                0);
      EXPECT_EQ(
          std::memcmp(slabs[m].weight.data(), slabs[0].weight.data(), slabs[0].weight.size() * 4),
          0);
    }
  }
}

// The distortion factor as the kernel evaluates it: a polynomial within 3e-7 of the
// exact factor for the barrel and pincushion distortions of real lenses (|kappa1 r^2| up
// to about 2 % at the corners; the paper dome's cameras have under 1 %); where it cannot
// be fitted that well the table is kept.
TEST(Integrate, DistortionPolynomialFitsTheExactFactor) {
  for (double kappa : {0.0, 0.005, -0.005, 0.0017, -0.002}) {
    const geometry::TsaiCamera cam = testing::LookAtCamera(
        "c", Eigen::Vector3d(0, -2000, 0), Eigen::Vector3d::Zero(), 320, 245, 60.0, kappa);
    // rn^2 of the image corner, as the integrator tabulates it (with 2 % to spare).
    const double rn2_max =
        1.02 * (std::pow(std::tan(M_PI / 6), 2) * (1.0 + std::pow(245.0 / 320, 2)));
    const DistortionPolynomial p = FitDistortionPolynomial(cam, rn2_max);
    EXPECT_TRUE(p.usable) << "kappa " << kappa << " error " << p.max_error;
    EXPECT_LT(p.max_error, 3e-7) << "kappa " << kappa;
    if (kappa == 0.0) {
      EXPECT_EQ(p.c[0], 1.0f);
      for (int k = 1; k < 5; ++k) EXPECT_EQ(p.c[k], 0.0f);
    }
    // Spot check against the camera model: a point at rn^2 = rn2_max / 2 on the diagonal.
    const double r = std::sqrt(0.5 * rn2_max), f = cam.focal_mm;
    double rd = 0;
    ASSERT_TRUE(geometry::DistortedRadiusMm(f * r, kappa, &rd));
    float v = p.c[4];
    for (int k = 3; k >= 0; --k) v = std::fma(v, 0.5f, p.c[k]);
    EXPECT_NEAR(v, rd / (f * r), 3e-7) << "kappa " << kappa;
  }
  // The test scenes' strong distortion (20 % at the corners) keeps the table.
  const geometry::TsaiCamera strong = testing::LookAtCamera(
      "s", Eigen::Vector3d(0, -2000, 0), Eigen::Vector3d::Zero(), 320, 245, 60.0, 0.05);
  EXPECT_FALSE(FitDistortionPolynomial(strong, 1.02 * (std::pow(std::tan(M_PI / 6), 2) *
                                                       (1.0 + std::pow(245.0 / 320, 2))))
                   .usable);
  // A distortion so strong that the radius has no distorted root inside the range: no
  // polynomial either.
  const geometry::TsaiCamera wild = testing::LookAtCamera(
      "w", Eigen::Vector3d(0, -2000, 0), Eigen::Vector3d::Zero(), 320, 245, 100.0, -3.0);
  EXPECT_FALSE(FitDistortionPolynomial(wild, 3.0).usable);
}

}  // namespace
}  // namespace dome::fusion
