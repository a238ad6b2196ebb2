// The dot detector on the floor marks of cameras of the paper dome: at grazing
// views the far marks shrink to a pixel or two, and the key mark must still be found
// so that the grid is labelled the right way round (the 5 x 5 grid fits equally well
// turned by 90 degrees, so a wrong labelling gives a wrong pose with a small RMS).
#include "calib/detect.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "calib/target.h"
#include "core/error.h"
#include "synth/calib_target.h"
#include "synth/calibration.h"
#include "synth/dome_rig.h"
#include "synth/ray_caster.h"
#include "synth/render.h"
#include "synth/scene.h"

namespace dome::calib {
namespace {

TEST(DetectDotTarget, LabelsTheFloorMarksOfGrazingAndHardPaperCameras) {
  Target target;
  target.path = "floor marks";
  target.frame = "world";
  target.marker_radius_mm = synth::kFloorMarkDotRadiusMm;
  target.key_marker_radius_mm = synth::kFloorMarkKeyDotRadiusMm;
  for (const auto& p : synth::FloorMarkPoints()) target.points.push_back({p.id, p.position_mm});
  const GridLayout layout = InferGridLayout(target);
  const synth::SceneMesh floor = synth::BuildFloorMarkScene();
  const synth::RayCaster caster(floor);
  const synth::Lighting lighting = synth::DomeLighting();
  // c02's key was taken for another corner by a comparison with the mass its row and
  // column extrapolate (the floor marks of `dome synth --seed 1`, whose noise this
  // is); c17, c26, c37 and c46 saw the key missed in an earlier scene; c45-c50 are
  // the lowest ring, the most grazing views.
  const std::vector<int> hard = {2, 17, 26, 37, 45, 46, 47, 48, 49, 50};
  const auto rig = synth::MakeDomeRig(synth::DomeRigOptions());
  ASSERT_EQ(rig.size(), 51u);
  for (const int index : hard) {
    const synth::DomeCamera& cam = rig[index];
    synth::RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.first_field = request.second_field = &caster;
    request.lighting = &lighting;
    request.noise_key = synth::NoiseKey(/*seed=*/1, /*stage-2 images=*/3, 0, index);
    request.depth = false;
    const cv::Mat image = synth::RenderView(request).image;
    const auto truth = synth::TrueImagePoints(cam.rig.model, synth::FloorMarkPoints(),
                                              synth::kFloorMarkDotRadiusMm, caster);
    const std::string& id = cam.rig.model.id;
    DotDetection det;
    try {
      det = DetectDotTarget(image, target, layout, {}, id);
    } catch (const core::InputError& e) {
      ADD_FAILURE() << id << ": " << e.what();
      continue;
    }
    int matched = 0;
    double worst = 0;
    for (const auto& p : det.points) {
      const auto it = std::find_if(truth.begin(), truth.end(),
                                   [&](const synth::ImagePoint& t) { return t.id == p.id; });
      if (it == truth.end()) continue;
      ++matched;
      worst = std::max(worst, (it->pixel - p.pixel).norm());
    }
    // every mark found, under its own id: a labelling turned by 90 degrees is off by
    // a grid pitch, many pixels
    EXPECT_GE(matched, static_cast<int>(truth.size()) - 1) << id << ": " << det.BriefReport();
    EXPECT_LT(worst, 0.5) << id << ": " << det.BriefReport();
  }
}

}  // namespace
}  // namespace dome::calib
