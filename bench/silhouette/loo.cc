// silhouette_loo: scores leave-one-camera-out reconstructions (issue 23's Panoptic
// evaluation; bench/silhouette/panoptic_loo.sh makes them and calls this).
//
//   silhouette_loo --take TAKE --work WORK [--preview DIR] [--hull-voxels N]
//
// TAKE is the take of every camera; WORK/out_<c>/<instant>/ holds `dome run`'s output
// of the take without camera c (mesh_decimated.ply, textured.obj + .png) and
// WORK/out_<c>/report.json its volume. For every camera c and instant, c's mask comes
// from TAKE (silhouette/take_masks.h: given > plate > the median over the instants) and:
//   IoU    the decimated mesh rendered into c (silhouette/render.h, c's exact lens)
//          against c's mask;
//   inside the fraction of the rendered pixels inside c's mask (debris outside the
//          people lowers it; a mesh in the wrong place would put it near the mask's
//          share of the image);
//   PSNR   the textured mesh (the atlas; the per-vertex colours when no OBJ was
//          written) rendered into c against c's image, over the pixels inside both the
//          mask and the rendering (what the rendering misses of the mask counts in
//          IoU), dB;
//   parts  connected components of mesh_decimated.ply (the goal: one per person);
//   hull   for scale, the plain visual hull of the other cameras' masks: voxels of the
//          run's volume (report.json) whose centre projects into every other camera's
//          image inside its mask, rendered into c as cubes; its IoU with c's mask. The
//          voxel edge is the volume's longest side / --hull-voxels (default 200: 18 mm
//          for Panoptic's derived volume, 3.6 m long: a fifth of an arm's width).
// Prints a table per instant and camera, then the means; with --preview writes
// DIR/<instant>/<c>.png: c's image beside the rendering, each darkened outside c's mask and
// with its outline (silhouette::MaskPreview), 960 px wide in all.
#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "silhouette/render.h"
#include "silhouette/take_masks.h"
#include "take/take.h"

namespace {

namespace fs = std::filesystem;
using namespace dome;

// dome's own textured OBJ (mesh/texture.h EncodeTexturedObj): "v x y z", "vt u v" and
// "f a/ta b/tb c/tc" lines; other lines are skipped. Texture coordinates per face corner.
struct TexturedObj {
  io::Mesh mesh;
  std::vector<Eigen::Vector2f> uv;
};

TexturedObj ReadTexturedObj(const fs::path& path) {
  std::ifstream in(path);
  core::Require(in.good(), path.string(), "cannot read");
  TexturedObj obj;
  std::vector<Eigen::Vector2f> vt;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    const std::string where = path.string() + ":" + std::to_string(number);
    if (tag == "v") {
      Eigen::Vector3f v;
      core::Require(bool(s >> v.x() >> v.y() >> v.z()), where, "expected v x y z");
      obj.mesh.vertices.push_back(v);
    } else if (tag == "vt") {
      Eigen::Vector2f t;
      core::Require(bool(s >> t.x() >> t.y()), where, "expected vt u v");
      vt.push_back(t);
    } else if (tag == "f") {
      Eigen::Vector3i face;
      for (int k = 0; k < 3; ++k) {
        std::string corner;
        core::Require(bool(s >> corner), where, "expected a triangle f a/t b/t c/t");
        const size_t slash = corner.find('/');
        core::Require(slash != std::string::npos, where, "expected texture coordinates a/t");
        const int v = std::atoi(corner.c_str()) - 1, t = std::atoi(corner.c_str() + slash + 1) - 1;
        core::Require(v >= 0 && v < int(obj.mesh.vertices.size()) && t >= 0 && t < int(vt.size()),
                      where, "index out of range");
        face[k] = v;
        obj.uv.push_back(vt[t]);
      }
      obj.mesh.faces.push_back(face);
    }
  }
  return obj;
}

// The run's volume from report.json: origin, voxel edge and dims (pipeline's grid).
struct Box {
  Eigen::Vector3d min, max;
};
Box ReadVolume(const fs::path& report) {
  const core::Json j = core::Json::parse(io::ReadFileBytes(report));
  const auto& v = j.at("volume");
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = v.at("origin_mm")[a].get<double>();
    box.max[a] = box.min[a] + v.at("voxel_size_mm").get<double>() * v.at("dims")[a].get<double>();
  }
  return box;
}

// The visual hull of `masks` (one per camera of `cameras`) over `box`, as the faces of
// its occupied voxels that border an empty one (what a camera outside it can see).
io::Mesh VisualHull(const std::vector<const geometry::TsaiCamera*>& cameras,
                    const std::vector<cv::Mat>& masks, const Box& box, int voxels_on_longest) {
  const Eigen::Vector3d size = box.max - box.min;
  const double edge = size.maxCoeff() / voxels_on_longest;
  const Eigen::Vector3i n = (size / edge).array().ceil().cast<int>().max(1);
  auto at = [&](int x, int y, int z) { return (size_t(z) * n.y() + y) * n.x() + x; };
  std::vector<uint8_t> inside(size_t(n.x()) * n.y() * n.z(), 1);
  for (int z = 0; z < n.z(); ++z)
    for (int y = 0; y < n.y(); ++y)
      for (int x = 0; x < n.x(); ++x) {
        const Eigen::Vector3d p = box.min + edge * Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5);
        for (size_t c = 0; c < cameras.size(); ++c) {
          Eigen::Vector2d px = Eigen::Vector2d::Zero();
          bool in = cameras[c]->Project(p, &px);
          const int u = int(std::lround(px.x())), v = int(std::lround(px.y()));
          in = in && u >= 0 && v >= 0 && u < masks[c].cols && v < masks[c].rows &&
               masks[c].at<uint8_t>(v, u) != 0;
          if (!in) {
            inside[at(x, y, z)] = 0;
            break;
          }
        }
      }
  io::Mesh mesh;
  auto filled = [&](int x, int y, int z) {
    return x >= 0 && y >= 0 && z >= 0 && x < n.x() && y < n.y() && z < n.z() &&
           inside[at(x, y, z)] != 0;
  };
  const int step[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  for (int z = 0; z < n.z(); ++z)
    for (int y = 0; y < n.y(); ++y)
      for (int x = 0; x < n.x(); ++x) {
        if (!filled(x, y, z)) continue;
        for (const auto& s : step) {
          if (filled(x + s[0], y + s[1], z + s[2])) continue;
          // The face of the cube towards the empty neighbour: two triangles.
          const int axis = s[0] != 0 ? 0 : (s[1] != 0 ? 1 : 2);
          const int u = (axis + 1) % 3, w = (axis + 2) % 3;
          Eigen::Vector3d corner[4];
          for (int k = 0; k < 4; ++k) {
            Eigen::Vector3d c(x, y, z);
            c[axis] += s[axis] > 0 ? 1 : 0;
            c[u] += (k == 1 || k == 2) ? 1 : 0;
            c[w] += (k >= 2) ? 1 : 0;
            corner[k] = box.min + edge * c;
          }
          const int base = int(mesh.vertices.size());
          for (const auto& c : corner) mesh.vertices.push_back(c.cast<float>());
          mesh.faces.emplace_back(base, base + 1, base + 2);
          mesh.faces.emplace_back(base, base + 2, base + 3);
        }
      }
  return mesh;
}

struct Row {
  std::string instant, camera;
  double iou = NAN, inside = NAN, psnr = NAN, hull_iou = NAN;
  int parts = 0, triangles = 0;
  std::string colour;  // "atlas", "vertex" or "" (no mesh)
};

double Mean(const std::vector<Row>& rows, double Row::*field) {
  double sum = 0;
  int n = 0;
  for (const auto& r : rows)
    if (std::isfinite(r.*field)) sum += r.*field, ++n;
  return n > 0 ? sum / n : NAN;
}

int Main(int argc, char** argv) {
  std::string take_dir, work_dir, preview_dir;
  int hull_voxels = 200;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      core::Require(i + 1 < argc, a, "expects a value");
      return argv[++i];
    };
    if (a == "--take") take_dir = value();
    else if (a == "--work") work_dir = value();
    else if (a == "--preview") preview_dir = value();
    else if (a == "--hull-voxels") hull_voxels = std::stoi(value());
    else core::Require(false, a, "unknown argument (--take --work --preview --hull-voxels)");
  }
  core::Require(!take_dir.empty() && !work_dir.empty(), "silhouette_loo",
                "usage: --take TAKE --work WORK [--preview DIR] [--hull-voxels N]");
  core::Require(hull_voxels >= 0 && hull_voxels <= 1000, "--hull-voxels",
                "expected 0 (no hull) .. 1000");
  silhouette::TakeMasks masks(take::OpenTake(take_dir), silhouette::MaskOptions{});
  const take::Take& take = masks.take();
  const auto& cams = take.rig.cameras;
  std::vector<Row> rows;
  std::printf("%-12s %-8s %7s %7s %8s %6s %9s %9s  %s\n", "instant", "camera", "IoU", "inside",
              "PSNR dB", "parts", "triangles", "hull IoU", "colour");
  for (const auto& instant : take.instants) {
    std::vector<cv::Mat> instant_masks;
    for (const auto& c : cams) instant_masks.push_back(masks.Mask(instant, c.model.id));
    for (size_t ci = 0; ci < cams.size(); ++ci) {
      const geometry::TsaiCamera& cam = cams[ci].model;
      Row row;
      row.instant = instant;
      row.camera = cam.id;
      const fs::path out = fs::path(work_dir) / ("out_" + cam.id);
      const fs::path dir = out / instant;
      const cv::Mat& mask = instant_masks[ci];
      const cv::Mat image =
          silhouette::ReadFrame(take.FramePath(instant, cam.id), mask.size(), cam.id).colour;
      cv::Mat bgr = image;
      if (image.channels() == 1) cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
      cv::Mat shaded(mask.size(), CV_8UC3, cv::Scalar::all(0)), rendered_mask = cv::Mat::zeros(mask.size(), CV_8UC1);
      if (fs::exists(dir / "mesh_decimated.ply")) {
        const io::Mesh mesh = io::ReadPly(dir / "mesh_decimated.ply");
        row.parts = silhouette::MeshComponents(mesh);
        row.triangles = int(mesh.faces.size());
        const silhouette::MeshRendering r = silhouette::RenderMesh(cam, mesh);
        rendered_mask = silhouette::RenderedMask(r);
        row.iou = silhouette::MaskIoU(rendered_mask, mask);
        const int rendered = cv::countNonZero(rendered_mask);
        if (rendered > 0) row.inside = double(cv::countNonZero(rendered_mask & mask)) / rendered;
        if (fs::exists(dir / "textured.obj") && fs::exists(dir / "textured.png")) {
          const TexturedObj obj = ReadTexturedObj(dir / "textured.obj");
          const cv::Mat atlas = io::ReadImage(dir / "textured.png", io::ImageMode::kBgr8);
          const silhouette::MeshRendering t = silhouette::RenderMesh(cam, obj.mesh);
          shaded = silhouette::ShadeAtlas(t, obj.uv, atlas);
          row.psnr = silhouette::MaskedPsnr(shaded, bgr, mask & silhouette::RenderedMask(t));
          row.colour = "atlas";
        } else if (mesh.HasColors()) {
          shaded = silhouette::ShadeVertexColours(r, mesh);
          row.psnr = silhouette::MaskedPsnr(shaded, bgr, mask & rendered_mask);
          row.colour = "vertex";
        }
      }
      if (hull_voxels > 0 && fs::exists(out / "report.json")) {
        std::vector<const geometry::TsaiCamera*> others;
        std::vector<cv::Mat> other_masks;
        for (size_t o = 0; o < cams.size(); ++o) {
          if (o == ci) continue;
          others.push_back(&cams[o].model);
          other_masks.push_back(instant_masks[o]);
        }
        const io::Mesh hull =
            VisualHull(others, other_masks, ReadVolume(out / "report.json"), hull_voxels);
        row.hull_iou =
            silhouette::MaskIoU(silhouette::RenderedMask(silhouette::RenderMesh(cam, hull)), mask);
      }
      std::printf("%-12s %-8s %7.3f %7.3f %8.2f %6d %9d %9.3f  %s\n", instant.c_str(),
                  cam.id.c_str(), row.iou, row.inside, row.psnr, row.parts, row.triangles,
                  row.hull_iou, row.colour.c_str());
      std::fflush(stdout);
      if (!preview_dir.empty()) {
        cv::Mat side;
        cv::hconcat(silhouette::MaskPreview(bgr, mask), silhouette::MaskPreview(shaded, mask), side);
        const double s = 960.0 / side.cols;
        cv::resize(side, side, cv::Size(), s, s, cv::INTER_AREA);
        fs::create_directories(fs::path(preview_dir) / instant);
        io::WriteImage(fs::path(preview_dir) / instant / (cam.id + ".png"), side);
      }
      rows.push_back(row);
    }
  }
  std::printf("\nmeans over instants\n%-8s %7s %7s %8s %6s %9s\n", "camera", "IoU", "inside",
              "PSNR dB", "parts", "hull IoU");
  for (const auto& c : cams) {
    std::vector<Row> of;
    for (const auto& r : rows)
      if (r.camera == c.model.id) of.push_back(r);
    double parts = 0;
    for (const auto& r : of) parts += r.parts;
    std::printf("%-8s %7.3f %7.3f %8.2f %6.1f %9.3f\n", c.model.id.c_str(), Mean(of, &Row::iou),
                Mean(of, &Row::inside), Mean(of, &Row::psnr), parts / of.size(),
                Mean(of, &Row::hull_iou));
  }
  double parts = 0;
  for (const auto& r : rows) parts += r.parts;
  std::printf("%-8s %7.3f %7.3f %8.2f %6.1f %9.3f\n", "all", Mean(rows, &Row::iou),
              Mean(rows, &Row::inside), Mean(rows, &Row::psnr), parts / rows.size(),
              Mean(rows, &Row::hull_iou));
  // Per instant, the means over the cameras left out (the figures are per
  // instant).
  for (const auto& instant : take.instants) {
    std::vector<Row> of;
    for (const auto& r : rows)
      if (r.instant == instant) of.push_back(r);
    std::printf("%-12s IoU %.3f  inside %.3f  PSNR %.2f dB  hull IoU %.3f\n", instant.c_str(),
                Mean(of, &Row::iou), Mean(of, &Row::inside), Mean(of, &Row::psnr),
                Mean(of, &Row::hull_iou));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Main(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "silhouette_loo: %s\n", e.what());
    return 1;
  }
}
