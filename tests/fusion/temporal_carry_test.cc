#include "fusion/temporal_carry.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "fusion_test_util.h"

namespace dome::fusion {
namespace {

// A 40^3 grid of 10 mm voxels centred on the origin, seen by one camera 1 m away on -y
// (the grid about 150..220 px across in its 320x240 image).
struct Scene {
  VolumeGrid grid;
  geometry::TsaiCamera camera;
  Scene() {
    grid.origin_mm = Eigen::Vector3d(-200, -200, -200);
    grid.voxel_size_mm = 10;
    grid.nx = grid.ny = grid.nz = 40;
    camera = testing::LookAtCamera("c0", Eigen::Vector3d(0, -1000, 0), Eigen::Vector3d::Zero(),
                                   320, 240, 40.0);
  }
  Slab Filled(int k0, int k1, float distance, float weight) const {
    Slab s;
    s.k0 = k0;
    s.k1 = k1;
    s.nx = grid.nx;
    s.ny = grid.ny;
    s.distance_mm.assign(size_t(k1 - k0) * grid.nx * grid.ny, distance);
    s.weight.assign(s.distance_mm.size(), weight);
    return s;
  }
  ChangeView Still() const {
    return {camera, cv::Mat::zeros((240 + 31) / 32, (320 + 31) / 32, CV_8UC1), 32};
  }
  size_t Index(const Slab& s, int i, int j, int k) const {
    return (size_t(k - s.k0) * s.ny + j) * s.nx + i;
  }
};

TEST(TemporalCarry, StillBlocksAddThePreviousEvidenceScaledByTheDecay) {
  const Scene sc;
  const Slab previous = sc.Filled(0, 40, 1.0f, 2.0f);
  Slab slab = sc.Filled(0, 40, 3.0f, 1.0f);
  // One voxel unobserved now, one never observed before.
  slab.weight[sc.Index(slab, 5, 5, 5)] = 0;
  slab.distance_mm[sc.Index(slab, 5, 5, 5)] = 0;
  Slab prev = previous;
  prev.weight[sc.Index(prev, 30, 30, 30)] = 0;
  TemporalCarryOptions o;
  o.decay = 0.5;
  TemporalCarryStats st;
  CarryStill(sc.grid, prev, {sc.Still()}, o, "test", &slab, &st);
  // W = 1 + 0.5 x 2 = 2, D = (1 x 3 + 1 x 1) / 2 = 2.
  EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 20, 20, 20)], 2.0f);
  EXPECT_FLOAT_EQ(slab.distance_mm[sc.Index(slab, 20, 20, 20)], 2.0f);
  // Unobserved now: left unobserved.
  EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 5, 5, 5)], 0.0f);
  EXPECT_FLOAT_EQ(slab.distance_mm[sc.Index(slab, 5, 5, 5)], 0.0f);
  // Nothing before: as it was.
  EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 30, 30, 30)], 1.0f);
  EXPECT_FLOAT_EQ(slab.distance_mm[sc.Index(slab, 30, 30, 30)], 3.0f);
  EXPECT_EQ(st.blocks, 125);
  EXPECT_EQ(st.still_blocks, 125);
  EXPECT_EQ(st.voxels_carried, 40 * 40 * 40 - 2);
}

TEST(TemporalCarry, BlocksWhereTheImageChangedKeepOnlyThisInstant) {
  const Scene sc;
  const Slab previous = sc.Filled(0, 40, 1.0f, 2.0f);
  Slab slab = sc.Filled(0, 40, 3.0f, 1.0f);
  ChangeView view = sc.Still();
  // The tile the volume's centre projects to changed.
  Eigen::Vector2d p;
  ASSERT_TRUE(sc.camera.Project(Eigen::Vector3d::Zero(), &p));
  view.changed_tiles.at<uint8_t>(int(p.y()) / 32, int(p.x()) / 32) = 1;
  TemporalCarryStats st;
  CarryStill(sc.grid, previous, {view}, {}, "test", &slab, &st);
  // Every block along the line of sight through the centre projects onto that tile.
  for (int j = 0; j < 40; ++j) {
    EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 20, j, 20)], 1.0f) << "j " << j;
    EXPECT_FLOAT_EQ(slab.distance_mm[sc.Index(slab, 20, j, 20)], 3.0f) << "j " << j;
  }
  // A corner of the volume projects far from it: carried (decay 1: W 3, D 5/3).
  EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 0, 0, 0)], 3.0f);
  EXPECT_FLOAT_EQ(slab.distance_mm[sc.Index(slab, 0, 0, 0)], 5.0f / 3.0f);
  EXPECT_GT(st.still_blocks, 0);
  EXPECT_LT(st.still_blocks, st.blocks);
}

TEST(TemporalCarry, ABlockChangedWhenItsFractionOfTheCamerasSeeingItSawAChange) {
  const Scene sc;
  const Slab previous = sc.Filled(0, 40, 1.0f, 2.0f);
  // A second camera on -x sees every block too; only the first saw a change, everywhere.
  ChangeView changed = sc.Still();
  changed.changed_tiles.setTo(1);
  ChangeView still = sc.Still();
  still.camera = testing::LookAtCamera("c1", Eigen::Vector3d(-1000, 0, 0),
                                       Eigen::Vector3d::Zero(), 320, 240, 40.0);
  for (const auto& [fraction, carried] : {std::pair{0.5, false}, std::pair{0.6, true}}) {
    Slab slab = sc.Filled(0, 40, 3.0f, 1.0f);
    TemporalCarryOptions o;
    o.changed_fraction = fraction;
    TemporalCarryStats st;
    CarryStill(sc.grid, previous, {changed, still}, o, "test", &slab, &st);
    EXPECT_EQ(st.still_blocks, carried ? st.blocks : 0) << fraction;
    EXPECT_FLOAT_EQ(slab.weight[sc.Index(slab, 20, 20, 20)], carried ? 3.0f : 1.0f) << fraction;
  }
}

TEST(TemporalCarry, BlocksNoCameraSeesAreLeftAsTheyAre) {
  Scene sc;
  // The camera looks away from the volume.
  sc.camera = testing::LookAtCamera("c0", Eigen::Vector3d(0, -2000, 0),
                                    Eigen::Vector3d(0, -4000, 0), 320, 240, 40.0);
  const Slab previous = sc.Filled(0, 40, 1.0f, 2.0f);
  Slab slab = sc.Filled(0, 40, 3.0f, 1.0f);
  const Slab before = slab;
  TemporalCarryStats st;
  CarryStill(sc.grid, previous, {sc.Still()}, {}, "test", &slab, &st);
  EXPECT_EQ(st.still_blocks, 0);
  EXPECT_EQ(slab.weight, before.weight);
  EXPECT_EQ(slab.distance_mm, before.distance_mm);
}

TEST(TemporalCarry, TheResultDoesNotDependOnTheSlabs) {
  const Scene sc;
  ChangeView view = sc.Still();
  view.changed_tiles.at<uint8_t>(3, 4) = 1;
  auto ramp = [&](int k0, int k1, float scale) {
    Slab s = sc.Filled(k0, k1, 0, 0);
    for (int k = k0; k < k1; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
          s.distance_mm[sc.Index(s, i, j, k)] = scale * float(i - j + k);
          s.weight[sc.Index(s, i, j, k)] = float((i + j + k) % 3);
        }
    return s;
  };
  Slab whole = ramp(0, 40, 1.0f);
  CarryStill(sc.grid, ramp(0, 40, 2.0f), {view}, {}, "test", &whole);
  for (auto [k0, k1] : {std::pair{0, 13}, std::pair{13, 40}}) {
    Slab part = ramp(k0, k1, 1.0f);
    CarryStill(sc.grid, ramp(k0, k1, 2.0f), {view}, {}, "test", &part);
    for (int k = k0; k < k1; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) {
          ASSERT_EQ(part.weight[sc.Index(part, i, j, k)], whole.weight[sc.Index(whole, i, j, k)]);
          ASSERT_EQ(part.distance_mm[sc.Index(part, i, j, k)],
                    whole.distance_mm[sc.Index(whole, i, j, k)]);
        }
  }
}

TEST(TemporalCarry, BadInputIsNamed) {
  const Scene sc;
  Slab slab = sc.Filled(0, 40, 3.0f, 1.0f);
  auto message = [&](const Slab& previous, const ChangeView& view,
                     const TemporalCarryOptions& o) {
    try {
      Slab s = slab;
      CarryStill(sc.grid, previous, {view}, o, "fusion job x", &s);
    } catch (const core::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(sc.Filled(0, 20, 1, 1), sc.Still(), {}).find(
                "fusion job x: the previous instant's slab is planes 0..20"),
            std::string::npos);
  ChangeView wrong = sc.Still();
  wrong.changed_tiles = cv::Mat::zeros(3, 3, CV_8UC1);
  EXPECT_NE(message(sc.Filled(0, 40, 1, 1), wrong, {}).find(
                "camera 'c0': its changed tiles do not cut its 320x240 image"),
            std::string::npos);
  TemporalCarryOptions o;
  o.decay = 0;
  EXPECT_NE(message(sc.Filled(0, 40, 1, 1), sc.Still(), o).find("temporal.fusion_decay"),
            std::string::npos);
  o.decay = 1.5;
  EXPECT_NE(message(sc.Filled(0, 40, 1, 1), sc.Still(), o).find("temporal.fusion_decay"),
            std::string::npos);
  o = {};
  o.block_voxels = 0;
  EXPECT_NE(message(sc.Filled(0, 40, 1, 1), sc.Still(), o).find("temporal.fusion_block_voxels"),
            std::string::npos);
  o = {};
  o.changed_fraction = 0;
  EXPECT_NE(
      message(sc.Filled(0, 40, 1, 1), sc.Still(), o).find("temporal.fusion_changed_fraction"),
      std::string::npos);
}

}  // namespace
}  // namespace dome::fusion
