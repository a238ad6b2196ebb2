// Session values derived from a take (pipeline/derive.h) on the small synthetic dome:
// the volume found from the images holds the truth mesh (used here only to judge) and
// is not much larger; given values are kept; --box replaces the volume; the derived
// session resolves.
#include "pipeline/derive.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>

#include "io/file_util.h"
#include "io/ply.h"
#include "net/content_hash.h"
#include "pipeline/frame_handoff.h"
#include "pipeline/session.h"
#include "pipeline/small_take_suite.h"
#include "silhouette/hull.h"
#include "silhouette/take_masks.h"
#include "stereo/scene_extent.h"
#include "stereo/take_stereo.h"
#include "take/import.h"
#include "take/take.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {
namespace {

// The person of a synthetic take's instant: the box of its truth mesh above the floor
// (z = 0) and inside the dome's shell (radius 6 m), used here only to judge.
std::pair<Eigen::Vector3d, Eigen::Vector3d> PersonBox(const take::Take& take,
                                                      const std::string& instant) {
  const io::Mesh truth = io::ReadPly(take.TruthMeshPath(instant));
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = -lo;
  for (const auto& v : truth.vertices) {
    if (v.z() < 50 || v.z() > 3000 || std::hypot(v.x(), v.y()) > 3000) continue;
    lo = lo.cwiseMin(v.cast<double>());
    hi = hi.cwiseMax(v.cast<double>());
  }
  return {lo, hi};
}

// The grid's box, world mm.
std::pair<Eigen::Vector3d, Eigen::Vector3d> GridBox(const fusion::VolumeGrid& g) {
  return {g.origin_mm, g.origin_mm + g.voxel_size_mm * Eigen::Vector3d(g.nx, g.ny, g.nz)};
}

class Derive : public SmallTakeSuite {
 protected:
  static runtime::Session Fresh() {
    runtime::Session s;
    s.set_take(TakeDir().string());
    s.set_out("/nonexistent/out");
    return s;
  }
  static fusion::VolumeGrid Grid(const runtime::Session& s) {
    return ResolveSessionOptions(s, "derived").grid;
  }
};

TEST_F(Derive, VolumeHoldsTheSceneAndLittleElse) {
  runtime::Session s = Fresh();
  const Derivation d = DeriveSession({}, &s);
  const fusion::VolumeGrid g = Grid(s);
  const auto [lo, hi] = GridBox(g);
  const take::Take take = take::OpenTake(TakeDir());
  const auto [tlo, thi] = PersonBox(take, take.instants.front());
  ASSERT_LT(tlo.z(), thi.z());
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(lo(a), tlo(a)) << "axis " << a;
    EXPECT_GE(hi(a), thi(a)) << "axis " << a;
  }
  // Far smaller than the seed's 6 m cube, and the voxel one pixel's footprint or more.
  EXPECT_LT((hi - lo).prod(), 0.5 * 6000.0 * 6000.0 * 6000.0);
  EXPECT_GT(g.voxel_size_mm, 0);
  // Every derived value says how it was found.
  bool volume_note = false;
  for (const auto& n : d.notes) volume_note |= n.rfind("volume: ", 0) == 0;
  EXPECT_TRUE(volume_note);
  EXPECT_TRUE(s.stereo().has_z_min_mm() && s.stereo().has_z_max_mm());
  EXPECT_LT(s.stereo().z_min_mm(), s.stereo().z_max_mm());
}

// Six cameras of the synthetic dome at 640x490 (a sparse rig, masks from its plates):
// coarse stereo at a third of the size matches too little of the raised bat for the
// scene's box to hold its top at the first instant, so the volume also takes the hull
// beyond that box where every camera sees it in its foreground (HullVolume, derive.cc).
// The person's truth mesh, used here only to judge, lies inside the volume at both
// instants (before: its top 100 mm above it, and the bat missing from the mesh).
TEST(DeriveSparse, VolumeHoldsWhatEveryCameraSeesBeyondTheScenesBox) {
  dome::testing::TempDir dir;
  const auto synth = dome::testing::RunDomeBinary(
      "synth --preset paper --cameras 6 --instants 2 --width 640 --height 490 --out " +
      (dir / "take").string());
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  runtime::Session s;
  s.set_take((dir / "take").string());
  s.set_out("/nonexistent/out");
  const Derivation d = DeriveSession({}, &s);
  const auto [lo, hi] = GridBox(ResolveSessionOptions(s, "derived").grid);
  const take::Take take = take::OpenTake(dir / "take");
  for (const std::string& instant : take.instants) {
    const auto [tlo, thi] = PersonBox(take, instant);
    ASSERT_LT(tlo.z(), thi.z());
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(lo(a), tlo(a)) << instant << " axis " << a;
      EXPECT_GE(hi(a), thi(a)) << instant << " axis " << a;
    }
  }
  // Still the person's neighbourhood, not the dome.
  EXPECT_LT((hi - lo).prod(), 0.1 * 6000.0 * 6000.0 * 6000.0);
  // The volume's note says where it came from.
  bool past = false;
  for (const auto& n : d.notes)
    past |= n.find("; past the scene's box where every camera sees it in its foreground") !=
            std::string::npos;
  EXPECT_TRUE(past);
}

// Panoptic's five cameras (../shared/data) reconstructed at one of their three instants
// (masks from the median of all three): coarse stereo of one instant finds too few
// points, and the scene's box is the view sphere's, which ended 1 m short of the third
// person (the mesh held two of the three). Beyond such a box the masks' hull holds by its
// own rule: the derived volume holds the hull's box looked for over the whole dome.
TEST(DerivePanoptic, OneInstantsVolumeHoldsTheHullPastTheViewSphere) {
  const std::filesystem::path data = std::filesystem::path(DOME_SHARED_DIR) / "data/panoptic";
  if (!std::filesystem::exists(data / "camera_parameters.json")) {
    GTEST_SKIP() << data << " is missing";
  }
  dome::testing::TempDir dir;
  const auto imported = dome::testing::RunDomeBinary("import panoptic " + data.string() +
                                                     " --out " + (dir / "take").string());
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  runtime::Session s;
  s.set_take((dir / "take").string());
  s.set_out("/nonexistent/out");
  s.add_instants("00-03-03-24");
  const Derivation d = DeriveSession({}, &s);
  bool guess = false;
  for (const auto& n : d.notes)
    guess |= n.find("the view sphere at 1 instant") != std::string::npos;
  ASSERT_TRUE(guess) << "coarse stereo found enough points: the case is not tested";
  const auto [lo, hi] = GridBox(ResolveSessionOptions(s, "derived").grid);
  // The hull by the session's rule over a 6 m box about the dome's centre.
  const take::Take take = take::OpenTake(dir / "take");
  silhouette::TakeMasks masks(take, silhouette::MaskOptions{});
  std::vector<geometry::TsaiCamera> cameras;
  std::vector<cv::Mat> m;
  for (const auto& rc : take.rig.cameras) {
    cameras.push_back(rc.model);
    m.push_back(masks.Mask("00-03-03-24", rc.model.id));
  }
  silhouette::HullOptions ho;
  ho.carve_votes = s.silhouettes().carve_votes();
  ho.min_views = s.silhouettes().min_views();
  ho.ray_block_px = 1;
  const silhouette::VisualHull hull(cameras, m, ho);
  Eigen::Vector3d h_lo, h_hi;
  ASSERT_TRUE(hull.BoundingBox(Eigen::Vector3d(-3000, -3000, -3000),
                               Eigen::Vector3d(3000, 3000, 3000), 96, &h_lo, &h_hi));
  // Within a cell of that coarser search (62.5 mm).
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(lo(a), h_lo(a) + 62.5) << "axis " << a;
    EXPECT_GE(hi(a), h_hi(a) - 62.5) << "axis " << a;
  }
}

// dome run's derivation hands the frames it decoded to the in-process workers' jobs
// (frame_handoff.h), under the addresses of the files' bytes; without the request it
// holds none.
TEST_F(Derive, OffersTheFramesItReadOnlyWhenAsked) {
  runtime::Session s = Fresh();
  ASSERT_EQ(HeldDecodedFrames(), 0u);
  DeriveSession({}, &s);
  EXPECT_EQ(HeldDecodedFrames(), 0u);
  runtime::Session t = Fresh();
  DeriveRequest r;
  r.offer_frames = true;
  DeriveSession(r, &t);
  const take::Take take = take::OpenTake(TakeDir());
  const std::string middle = take.instants[take.instants.size() / 2];
  // The middle instant's frames (the greys' statistics) and, where masks are made from
  // the frames, those of every instant the masks' hull looks at: each one decoded as a
  // job would decode it. Nothing else is held.
  EXPECT_GE(HeldDecodedFrames(), take.rig.cameras.size());
  size_t taken = 0;
  for (const auto& instant : take.instants) {
    for (const auto& c : take.rig.cameras) {
      const std::string bytes = io::ReadFileBytes(take.FramePath(instant, c.model.id));
      const cv::Mat held = TakeDecodedFrame(net::Sha256Hex(bytes));
      if (instant == middle) {
        ASSERT_FALSE(held.empty()) << c.model.id;
      }
      if (held.empty()) continue;
      ++taken;
      const cv::Mat decoded = stereo::DecodeFrame(bytes, c.model.id);
      EXPECT_EQ(cv::norm(held, decoded, cv::NORM_INF), 0.0) << instant << " " << c.model.id;
    }
  }
  EXPECT_GE(taken, take.rig.cameras.size());
  EXPECT_EQ(HeldDecodedFrames(), 0u);
}

// The small dome's six cameras are a sparse rig (median nearest axis angle 70 degrees):
// with masks from its plates, the hull's surface stands in where stereo saw nothing,
// one background vote carves and a point needs five foreground views (all cameras but
// one), the hull is carved by photo-consistency and small parts are specks wherever they
// are; given values win (photo carving and the specks' gap follow a given hull
// surface), and counts out of range are named.
TEST_F(Derive, SparseRigGetsTheHullSurfaceOneCarvingVoteAndAllViewsButOne) {
  runtime::Session s = Fresh();
  const Derivation d = DeriveSession({}, &s);
  EXPECT_TRUE(s.silhouettes().fusion());
  EXPECT_TRUE(s.silhouettes().hull_surface());
  EXPECT_TRUE(s.silhouettes().photo_carve());
  // Every part under 2 % of the largest part's area is a speck, of any size, anywhere.
  EXPECT_TRUE(s.has_speck_gap_voxels());
  EXPECT_EQ(s.speck_gap_voxels(), 0.0);
  EXPECT_EQ(s.speck_area_fraction(), 0.02);
  const auto& dims = s.volume().dims();
  ASSERT_EQ(dims.size(), 3);
  EXPECT_EQ(s.speck_diagonal_voxels(),
            std::ceil(std::sqrt(double(dims[0]) * dims[0] + double(dims[1]) * dims[1] +
                                double(dims[2]) * dims[2])));
  EXPECT_EQ(s.silhouettes().carve_votes(), 1);
  EXPECT_EQ(s.silhouettes().min_views(), 5);
  bool note = false;
  for (const auto& n : d.notes)
    note |=
        n.find(
            "hull surface true, photo carving true, carve votes 1, min views 5 (masks: 6 plate; "
            "the "
            "cameras' median nearest axis angle 70.4 deg, sparse above 30)") != std::string::npos;
  EXPECT_TRUE(note);
  runtime::Session t = Fresh();
  t.mutable_silhouettes()->set_hull_surface(false);
  t.mutable_silhouettes()->set_carve_votes(3);
  t.mutable_silhouettes()->set_min_views(2);
  DeriveSession({}, &t);
  EXPECT_FALSE(t.silhouettes().hull_surface());
  EXPECT_FALSE(t.silhouettes().photo_carve());
  // The session's defaults (pipeline/session.h).
  EXPECT_FALSE(t.has_speck_gap_voxels());
  EXPECT_FALSE(t.has_speck_area_fraction());
  EXPECT_FALSE(t.has_speck_diagonal_voxels());
  EXPECT_EQ(t.silhouettes().carve_votes(), 3);
  EXPECT_EQ(t.silhouettes().min_views(), 2);
  EXPECT_EQ(ResolveSessionOptions(t, "session").silhouettes.carve_votes, 3);
  EXPECT_EQ(ResolveSessionOptions(t, "session").silhouettes.min_views, 2);
  t.mutable_silhouettes()->set_carve_votes(0);
  dome::testing::ExpectInputError([&] { ResolveSessionOptions(t, "session"); },
                                  {"session: silhouettes.carve_votes", "at least 1 camera, got 0"});
  t.mutable_silhouettes()->set_carve_votes(1);
  t.mutable_silhouettes()->set_min_views(1);
  dome::testing::ExpectInputError([&] { ResolveSessionOptions(t, "session"); },
                                  {"session: silhouettes.min_views", "at least 2 cameras, got 1"});
}

TEST_F(Derive, GivenValuesAndTheBoxWin) {
  runtime::Session s = Fresh();
  s.mutable_volume()->set_voxel_size_mm(50);
  s.mutable_stereo()->set_normalize_contrast(true);
  s.mutable_fusion()->set_truncation_mm(123);
  DeriveRequest r;
  r.box = {{-1000, -1000, 0}, {1000, 500, 2000}};
  DeriveSession(r, &s);
  const fusion::VolumeGrid g = Grid(s);
  EXPECT_EQ(g.voxel_size_mm, 50);
  EXPECT_EQ(g.origin_mm, Eigen::Vector3d(-1000, -1000, 0));
  EXPECT_EQ(g.nx, 40);
  EXPECT_EQ(g.ny, 30);
  EXPECT_EQ(g.nz, 40);
  EXPECT_TRUE(s.stereo().normalize_contrast());
  EXPECT_EQ(s.fusion().truncation_mm(), 123);
  // A session that names its volume keeps it.
  runtime::Session again = s;
  DeriveSession({}, &again);
  EXPECT_EQ(Grid(again).origin_mm, g.origin_mm);
  EXPECT_EQ(Grid(again).nx, g.nx);
}

// Time-aware fusion is derived from the take: on for several instants whose fusion
// has no masks (the still parts are fused, and steadied), off with fusion masks (the
// still parts are free space) and for one instant; a given value wins.
class DeriveSequence : public SmallTakeSuiteOf<2> {};

TEST_F(DeriveSequence, TemporalFusionIsOnForSeveralInstantsWithoutFusionMasks) {
  auto derive = [](const std::function<void(runtime::Session*)>& given, std::string* note) {
    runtime::Session s;
    s.set_take(TakeDir().string());
    s.set_out("/nonexistent/out");
    given(&s);
    const Derivation d = DeriveSession({}, &s);
    note->clear();
    for (const auto& n : d.notes)
      if (n.rfind("temporal.fusion", 0) == 0) *note = n;
    return s;
  };
  std::string note;
  // The small dome's plates give masks: fusion masks, no time-aware fusion.
  runtime::Session s = derive([](runtime::Session*) {}, &note);
  EXPECT_TRUE(s.silhouettes().fusion());
  EXPECT_FALSE(s.temporal().fusion());
  EXPECT_EQ(note, "temporal.fusion: false (fusion masks: the still parts are free space)");
  EXPECT_FALSE(ResolveSessionOptions(s, "session").temporal.fusion);
  // Without fusion masks: on, and the session resolves to it.
  s = derive([](runtime::Session* g) { g->mutable_silhouettes()->set_fusion(false); }, &note);
  EXPECT_TRUE(s.temporal().fusion());
  EXPECT_EQ(note,
            "temporal.fusion: true (several instants without fusion masks: the still parts "
            "steadied)");
  EXPECT_TRUE(ResolveSessionOptions(s, "session").temporal.fusion);
  EXPECT_FALSE(s.temporal().stereo());  // time-aware stereo stays as given (off)
  // A given value wins, and is not noted as derived.
  s = derive(
      [](runtime::Session* g) {
        g->mutable_silhouettes()->set_fusion(false);
        g->mutable_temporal()->set_fusion(false);
      },
      &note);
  EXPECT_FALSE(s.temporal().fusion());
  EXPECT_EQ(note, "");
  // One instant of the two: nothing before it to carry.
  s = derive(
      [](runtime::Session* g) {
        g->mutable_silhouettes()->set_fusion(false);
        g->add_instants(take::OpenTake(TakeDir()).instants.at(0));
      },
      &note);
  EXPECT_FALSE(s.temporal().fusion());
  EXPECT_EQ(note, "temporal.fusion: false (one instant)");
}

TEST_F(Derive, VoxelThatOverflowsTheGridIsNamed) {
  runtime::Session s = Fresh();
  s.mutable_volume()->set_voxel_size_mm(1.4e-6);
  dome::testing::ExpectInputError([&] { DeriveSession({}, &s); },
                                  {"session: volume.voxel_size_mm",
                                   "voxels along an axis of the volume derived from the take"});
}

TEST_F(Derive, BadBoxIsNamed) {
  runtime::Session s = Fresh();
  DeriveRequest r;
  r.box = {{0, 0, 0}, {100, -5, 100}};
  dome::testing::ExpectInputError([&] { DeriveSession(r, &s); }, {"--box", "YMIN < YMAX"});
}

// Megapixel frames of a real rig (Robovision 17_43_02, when ../shared is there): the
// speckle filter's depth step follows the pixel footprint at the scene (five of them),
// not the voxel, which the voxel budget sets on these scenes.
TEST(DeriveLarge, SpeckleStepIsFivePixelFootprintsAtTheScene) {
  const std::filesystem::path scene =
      std::filesystem::path(DOME_SHARED_DIR) / "data/robovision/2016_10_24__17_43_02";
  if (!std::filesystem::exists(scene)) GTEST_SKIP() << "no shared data at " << scene;
  const dome::testing::TempDir tmp;
  const take::Take take = take::ImportHalconScene(scene, tmp.path() / "take");
  runtime::Session s;
  s.set_take((tmp.path() / "take").string());
  s.set_out((tmp.path() / "out").string());
  const Derivation d = DeriveSession({}, &s);
  const fusion::VolumeGrid g = ResolveSessionOptions(s, "derived").grid;
  const Eigen::Vector3d centre =
      g.origin_mm + 0.5 * g.voxel_size_mm * Eigen::Vector3d(g.nx, g.ny, g.nz);
  const double footprint = stereo::PixelFootprintMm(take.rig, centre);
  EXPECT_NEAR(footprint, 0.060, 0.005);  // 1280 px frames about 200 mm from the object
  EXPECT_GT(s.stereo().speckle_area_px(), 0);
  EXPECT_NEAR(s.stereo().speckle_step_mm(), 5 * footprint, 1e-3 * footprint);
  bool note = false;
  for (const auto& n : d.notes) note |= n.find("five pixel footprints at the scene") != n.npos;
  EXPECT_TRUE(note);
  // A given step wins.
  runtime::Session given;
  given.set_take(s.take());
  given.set_out(s.out());
  given.mutable_stereo()->set_speckle_step_mm(0.7);
  DeriveSession({}, &given);
  EXPECT_EQ(given.stereo().speckle_step_mm(), 0.7);
}

}  // namespace
}  // namespace dome::pipeline
