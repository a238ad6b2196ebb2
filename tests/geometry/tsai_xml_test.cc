#include "geometry/tsai_xml.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::DataDir;
using testing::ExpectInputError;
using testing::Replace;
using testing::ScratchDir;
using testing::TypicalCamera;
using testing::WriteFile;

const std::string kGoodXml = R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- a comment with <Camera> inside -->
<Camera name="camera0">
  <Geometry width="720" height="576" ncx="576"
            nfx="576" dx="2.3000000000e-02"
            dy="2.3000000000e-02" dpx="2.3000000000e-02"
            dpy="2.3000000000e-02"/>
  <Intrinsic focal="20.161920" kappa1="5.720865e-04"
	cx="366.514507" cy="305.832552"
	sx="1"/>
  <Extrinsic tx="-4.8441913843e+03" ty="5.5109448682e+02"
	tz="4.9667438357e+03" rx="1.9007833770e+00"
	ry="4.9730769727e-01" rz="1.8415452559e-01"/>
 </Camera>
)";

TEST(TsaiXml, ReadsTheFields) {
  ScratchDir dir;
  WriteFile(dir.File("c0.xml"), kGoodXml);
  const TsaiCamera camera = ReadTsaiXml(dir.File("c0.xml"));
  EXPECT_EQ(camera.id, "camera0");
  EXPECT_EQ(camera.width_px, 720);
  EXPECT_EQ(camera.height_px, 576);
  EXPECT_EQ(camera.sensor.ncx, 576);
  EXPECT_EQ(camera.sensor.nfx, 576);
  EXPECT_EQ(camera.sensor.dx_mm, 0.023);
  EXPECT_EQ(camera.sensor.dy_mm, 0.023);
  EXPECT_EQ(camera.focal_mm, 20.161920);
  EXPECT_EQ(camera.kappa1_per_mm2, 5.720865e-04);
  EXPECT_EQ(camera.cx_px, 366.514507);
  EXPECT_EQ(camera.cy_px, 305.832552);
  EXPECT_EQ(camera.sx, 1.0);
  EXPECT_EQ(camera.translation_mm, Eigen::Vector3d(-4844.1913843, 551.09448682, 4966.7438357));
  EXPECT_LT((camera.rotation - RotationFromTsaiAngles(1.9007833770, 0.49730769727, 0.18415452559))
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
}

TEST(TsaiXml, WriteReadRoundTrip) {
  ScratchDir dir;
  for (const double kappa : {5.720865e-4, -3e-4, 0.0}) {
    TsaiCamera camera = TypicalCamera(kappa);
    camera.id = "cam <\"&> 1";
    WriteTsaiXml(dir.File("c.xml"), camera);
    const TsaiCamera back = ReadTsaiXml(dir.File("c.xml"));
    EXPECT_EQ(back.id, camera.id);
    EXPECT_EQ(back.width_px, camera.width_px);
    EXPECT_EQ(back.height_px, camera.height_px);
    EXPECT_EQ(back.sensor.ncx, camera.sensor.ncx);
    EXPECT_EQ(back.sensor.nfx, camera.sensor.nfx);
    EXPECT_EQ(back.sensor.dx_mm, camera.sensor.dx_mm);
    EXPECT_EQ(back.sensor.dy_mm, camera.sensor.dy_mm);
    EXPECT_EQ(back.focal_mm, camera.focal_mm);
    EXPECT_EQ(back.kappa1_per_mm2, camera.kappa1_per_mm2);
    EXPECT_EQ(back.cx_px, camera.cx_px);
    EXPECT_EQ(back.cy_px, camera.cy_px);
    EXPECT_EQ(back.sx, camera.sx);
    EXPECT_EQ(back.translation_mm, camera.translation_mm);
    EXPECT_LT((back.rotation - camera.rotation).cwiseAbs().maxCoeff(), 1e-15);
  }
}

TEST(TsaiXml, ReproducesTheEpflProjections) {
  const std::string folder = DataDir() + "/epfl-terrace";
  DOME_SKIP_WITHOUT(folder);
  double worst_px = 0.0, worst_depth_mm = 0.0;
  int rows = 0;
  for (int n = 0; n < 4; ++n) {
    const std::string suffix = "c" + std::to_string(n);
    const TsaiCamera camera =
        ReadTsaiXml(std::string(folder).append("/terrace-tsai-").append(suffix).append(".xml"));
    EXPECT_EQ(camera.id, "camera" + std::to_string(n));
    EXPECT_EQ(camera.width_px, 720);
    std::ifstream in(std::string(folder).append("/projections-").append(suffix).append(".txt"));
    ASSERT_TRUE(in.good());
    std::string line;
    int camera_rows = 0;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') {
        continue;
      }
      std::istringstream fields(line);
      Eigen::Vector3d world;
      Eigen::Vector2d expected;
      double zc;
      ASSERT_TRUE(fields >> world.x() >> world.y() >> world.z() >> expected.x() >> expected.y() >>
                  zc)
          << line;
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.Project(world, &pixel)) << line;
      const double error = (pixel - expected).norm();
      EXPECT_LT(error, 1e-6) << suffix << ": " << line;
      // Zc is printed with 6 decimals.
      EXPECT_NEAR(camera.WorldToCamera(world).z(), zc, 1e-6) << suffix << ": " << line;
      worst_px = std::max(worst_px, error);
      worst_depth_mm = std::max(worst_depth_mm, std::abs(camera.WorldToCamera(world).z() - zc));
      ++camera_rows;
    }
    EXPECT_EQ(camera_rows, 200) << suffix;
    rows += camera_rows;
  }
  std::printf("EPFL terrace: %d projections, max error %.3g px, max depth error %.3g mm\n", rows,
              worst_px, worst_depth_mm);
  RecordProperty("max_error_px", std::to_string(worst_px));
}

TEST(TsaiXml, MissingFile) {
  ExpectInputError([] { ReadTsaiXml("/nonexistent/cam.xml"); },
                   {"/nonexistent/cam.xml", "cannot open"});
}

TEST(TsaiXml, EveryMissingAttributeIsNamed) {
  ScratchDir dir;
  const std::string path = dir.File("c.xml");
  const struct {
    const char* element;
    const char* attribute;
    const char* text;
  } cases[] = {
      {"Camera", "name", "name=\"camera0\""},
      {"Geometry", "width", "width=\"720\""},
      {"Geometry", "height", "height=\"576\""},
      {"Geometry", "ncx", "ncx=\"576\""},
      {"Geometry", "nfx", "nfx=\"576\""},
      {"Geometry", "dx", "dx=\"2.3000000000e-02\""},
      {"Geometry", "dy", "dy=\"2.3000000000e-02\""},
      {"Geometry", "dpx", "dpx=\"2.3000000000e-02\""},
      {"Geometry", "dpy", "dpy=\"2.3000000000e-02\""},
      {"Intrinsic", "focal", "focal=\"20.161920\""},
      {"Intrinsic", "kappa1", "kappa1=\"5.720865e-04\""},
      {"Intrinsic", "cx", "cx=\"366.514507\""},
      {"Intrinsic", "cy", "cy=\"305.832552\""},
      {"Intrinsic", "sx", "sx=\"1\""},
      {"Extrinsic", "tx", "tx=\"-4.8441913843e+03\""},
      {"Extrinsic", "ty", "ty=\"5.5109448682e+02\""},
      {"Extrinsic", "tz", "tz=\"4.9667438357e+03\""},
      {"Extrinsic", "rx", "rx=\"1.9007833770e+00\""},
      {"Extrinsic", "ry", "ry=\"4.9730769727e-01\""},
      {"Extrinsic", "rz", "rz=\"1.8415452559e-01\""},
  };
  for (const auto& c : cases) {
    WriteFile(path, Replace(kGoodXml, c.text, ""));
    std::string where = path;
    where.append(": ").append(c.element).append(".").append(c.attribute);
    ExpectInputError([&] { ReadTsaiXml(path); }, {where, "missing attribute"});
    // And a value that is not a number.
    if (std::string(c.attribute) != "name") {
      WriteFile(path, Replace(kGoodXml, c.text, std::string(c.attribute).append("=\"nan\"")));
      ExpectInputError([&] { ReadTsaiXml(path); }, {where, "got 'nan'"});
      WriteFile(path, Replace(kGoodXml, c.text, std::string(c.attribute).append("=\"12abc\"")));
      ExpectInputError([&] { ReadTsaiXml(path); }, {where, "12abc"});
    }
  }
}

TEST(TsaiXml, BadValuesAreNamed) {
  ScratchDir dir;
  const std::string path = dir.File("c.xml");
  const auto expect = [&](const std::string& from, const std::string& to,
                          std::initializer_list<std::string> fragments) {
    WriteFile(path, Replace(kGoodXml, from, to));
    ExpectInputError([&] { ReadTsaiXml(path); }, fragments);
  };
  expect("focal=\"20.161920\"", "focal=\"0\"", {path + ": Intrinsic.focal", "positive"});
  expect("focal=\"20.161920\"", "focal=\"-20\"", {path + ": Intrinsic.focal", "positive"});
  expect("sx=\"1\"", "sx=\"-1\"", {path + ": Intrinsic.sx", "positive"});
  expect("width=\"720\"", "width=\"720.5\"", {path + ": Geometry.width", "integer"});
  expect("height=\"576\"", "height=\"0\"", {path + ": Geometry.height", "positive"});
  expect("dx=\"2.3000000000e-02\"", "dx=\"-2.3e-02\"", {path + ": Geometry.dx", "positive"});
  expect("kappa1=\"5.720865e-04\"", "kappa1=\"inf\"", {path + ": Intrinsic.kappa1", "finite"});
  expect("tz=\"4.9667438357e+03\"", "tz=\"1e999\"", {path + ": Extrinsic.tz", "finite"});
  // dpx must equal dx * ncx / nfx, dpy = dy.
  expect("dpx=\"2.3000000000e-02\"", "dpx=\"2.4e-02\"",
         {path + ": Geometry.dpx", "0.024", "dx * ncx / nfx", "0.023"});
  expect("nfx=\"576\"", "nfx=\"720\"", {path + ": Geometry.dpx", "dx * ncx / nfx"});
  expect("dpy=\"2.3000000000e-02\"", "dpy=\"2.2e-02\"", {path + ": Geometry.dpy", "dy"});
  // Elements.
  expect("<Intrinsic", "<Intrinsics", {path + ": Intrinsic", "missing element"});
  expect("<Camera name=\"camera0\">", "<Camera name=\"camera0\"><Geometry width=\"1\"/>",
         {path + ": Geometry", "twice"});
  // Malformed XML.
  expect("cx=\"366.514507\"", "cx=\"366.514507", {path, "line"});
  expect("sx=\"1\"/>", "sx=\"1\"", {path, "line"});
  expect("cy=\"305.832552\"", "cy 305.832552", {path, "Intrinsic.cy", "'='"});
  // An empty file.
  WriteFile(path, "");
  ExpectInputError([&] { ReadTsaiXml(path); }, {path + ": Camera", "missing element"});
}

TEST(TsaiXml, NotAFilePointsAtTheLine) {
  ScratchDir dir;
  const std::string path = dir.File("c.xml");
  WriteFile(path, "<?xml version=\"1.0\"?>\n\n<Camera name=\"x\">\n  <Geometry width=\"720\n");
  ExpectInputError([&] { ReadTsaiXml(path); }, {path + ": line 4", "not closed"});
}

TEST(TsaiXml, WriterRejectsInvalidCamerasAndUnwritablePaths) {
  ScratchDir dir;
  TsaiCamera camera = TypicalCamera(1e-4);
  camera.focal_mm = std::nan("");
  ExpectInputError([&] { WriteTsaiXml(dir.File("c.xml"), camera); },
                   {dir.File("c.xml"), "camera 'typical'", "focal_mm"});
  ExpectInputError([&] { WriteTsaiXml("/nonexistent/dir/c.xml", TypicalCamera(0)); },
                   {"/nonexistent/dir/c.xml", "cannot open"});
}

}  // namespace
}  // namespace dome::geometry
