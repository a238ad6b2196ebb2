#include "take/validate.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "io/image_io.h"
#include "schema/rig_json.h"
#include "take/timecode.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;

class Checker {
 public:
  explicit Checker(TakeReport* report) : report_(report) {}
  void Problem(const fs::path& where, const std::string& what) {
    report_->problems.push_back({where.string(), what});
  }

  // Checks one image file against the expected size; `depth` selects the pixel kind.
  enum class Kind { kFrame, kMask, kTruthDepth };
  void CheckImage(const fs::path& path, const geometry::TsaiCamera* camera, Kind kind,
                  bool decode) {
    if (!decode) return;
    ++report_->images_checked;
    cv::Mat image;
    try {
      image = io::ReadImage(path, io::ImageMode::kUnchanged);
    } catch (const core::InputError& e) {
      // The decoder's message names the path again; keep what it says was wrong.
      const std::string why = e.what();
      const size_t at = why.find(path.string() + ": ");
      Problem(path, "unreadable or corrupt image (" +
                        (at == 0 ? why.substr(path.string().size() + 2) : why) + ")");
      return;
    }
    if (kind == Kind::kFrame) {
      if (image.depth() != CV_8U ||
          (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
        Problem(path, "expected an 8-bit gray, BGR or BGRA image, got " +
                          std::to_string(image.channels()) + " channel(s) of depth code " +
                          std::to_string(image.depth()));
      }
    } else if (kind == Kind::kMask) {
      if (image.depth() != CV_8U) {
        Problem(path, "expected an 8-bit mask (0 = background, nonzero = foreground), got "
                      "depth code " +
                          std::to_string(image.depth()));
      }
    } else if (image.type() != CV_32FC1) {
      Problem(path, "expected a 1-channel 32-bit float depth map (mm)");
    }
    if (camera != nullptr && (image.cols != camera->width_px || image.rows != camera->height_px)) {
      Problem(path, "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                        ", rig.json says camera '" + camera->id + "' is " +
                        std::to_string(camera->width_px) + "x" + std::to_string(camera->height_px));
    }
  }

 private:
  TakeReport* report_;
};

// Files in `dir` with extension `ext`, by stem; everything else is reported.
std::map<std::string, fs::path> ListByStem(const fs::path& dir, const std::string& ext,
                                           Checker* checker) {
  std::map<std::string, fs::path> out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ext) {
      out[entry.path().stem().string()] = entry.path();
    } else {
      checker->Problem(entry.path(), "unexpected entry (expected <camera>" + ext + " files)");
    }
  }
  return out;
}

// Returns the number of files of known cameras.
int CheckCameraFiles(const fs::path& dir, const std::string& ext, const TakeReport& report,
                     Checker::Kind kind, bool required, bool decode, Checker* checker) {
  const auto files = ListByStem(dir, ext, checker);
  int known = 0;
  for (const auto& [stem, path] : files) {
    if (report.rig_ok && report.rig.Find(stem) < 0) {
      checker->Problem(path, "unknown camera id '" + stem + "' (not in rig.json)");
    }
  }
  if (!report.rig_ok) return 0;
  for (const auto& cam : report.rig.cameras) {
    const auto it = files.find(cam.model.id);
    if (it == files.end()) {
      if (required)
        checker->Problem(dir / (cam.model.id + ext),
                         "missing image of camera '" + cam.model.id + "'");
      continue;
    }
    ++known;
    checker->CheckImage(it->second, &cam.model, kind, decode);
  }
  return known;
}

std::vector<std::string> ListInstants(const fs::path& dir, Checker* checker) {
  std::vector<std::string> out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && ParseInstantName(name)) {
      out.push_back(name);
    } else {
      checker->Problem(entry.path(), "expected an instant folder named by timecode HH-MM-SS-FF");
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TakeReport ValidateTake(const fs::path& dir, const ValidateOptions& options) {
  TakeReport report;
  report.dir = dir;
  Checker checker(&report);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    checker.Problem(dir, "not a take folder (no such directory)");
    return report;
  }
  const fs::path rig_path = dir / "rig.json";
  if (!fs::is_regular_file(rig_path, ec)) {
    checker.Problem(rig_path, "missing: a take needs rig.json");
  } else {
    try {
      report.rig = schema::ReadRig(rig_path);
      report.rig_ok = true;
    } catch (const core::InputError& e) {
      report.problems.push_back({e.where(), std::string(e.what()).substr(e.where().size() + 2)});
    }
  }
  const fs::path frames = dir / "frames";
  if (!fs::is_directory(frames, ec)) {
    checker.Problem(frames, "missing: a take needs frames/<instant>/<camera>.png");
  } else {
    report.instants = ListInstants(frames, &checker);
    if (report.instants.empty())
      checker.Problem(frames, "no instants: expected at least one folder");
    for (const auto& instant : report.instants) {
      CheckCameraFiles(frames / instant, ".png", report, Checker::Kind::kFrame, true,
                       options.decode_images, &checker);
    }
  }
  // Optional silhouette inputs (silhouette/take_masks.h): given masks per instant (a
  // camera may have none, but an instant folder must be one of frames/), and plates.
  const fs::path masks = dir / "masks";
  if (fs::is_directory(masks, ec)) {
    const std::set<std::string> known(report.instants.begin(), report.instants.end());
    for (const auto& instant : ListInstants(masks, &checker)) {
      ++report.mask_instants;
      if (known.count(instant) == 0) {
        checker.Problem(masks / instant, "masks for an instant that has no frames/" + instant);
      }
      CheckCameraFiles(masks / instant, ".png", report, Checker::Kind::kMask, false,
                       options.decode_images, &checker);
    }
  }
  const fs::path background = dir / "background";
  if (fs::is_directory(background, ec)) {
    report.background_plates = CheckCameraFiles(background, ".png", report, Checker::Kind::kFrame,
                                                false, options.decode_images, &checker);
  }
  const fs::path calib = dir / "calib";
  if (fs::is_directory(calib, ec)) {
    report.has_calib = true;
    for (const auto& entry : fs::recursive_directory_iterator(calib)) {
      if (entry.is_regular_file()) ++report.calib_files;
    }
  }
  const fs::path truth = dir / "truth";
  if (fs::is_directory(truth, ec)) {
    report.has_truth = true;
    const std::set<std::string> known(report.instants.begin(), report.instants.end());
    for (const auto& instant : ListInstants(truth, &checker)) {
      ++report.truth_instants;
      if (known.count(instant) == 0) {
        checker.Problem(truth / instant, "truth for an instant that has no frames/" + instant);
      }
      if (!fs::is_regular_file(truth / instant / "mesh.ply", ec)) {
        checker.Problem(truth / instant / "mesh.ply", "missing truth mesh");
      }
      if (fs::is_directory(truth / instant / "depth", ec)) {
        CheckCameraFiles(truth / instant / "depth", ".tiff", report, Checker::Kind::kTruthDepth,
                         true, options.decode_images, &checker);
      }
      if (fs::is_directory(truth / instant / "mask", ec)) {
        CheckCameraFiles(truth / instant / "mask", ".png", report, Checker::Kind::kMask, true,
                         options.decode_images, &checker);
      }
    }
  }
  return report;
}

std::string TakeReport::Summary() const {
  std::ostringstream out;
  out << "take " << dir.string() << "\n";
  if (rig_ok) {
    out << "  rig: " << rig.cameras.size() << " camera(s), source " << rig.source << " (unit "
        << rig.source_unit << " = " << rig.source_unit_mm << " mm)\n";
    for (const auto& cam : rig.cameras) {
      const auto& m = cam.model;
      const Eigen::Vector3d c = m.CentreWorld();
      char line[256];
      std::snprintf(
          line, sizeof line,
          "    %-14s %5dx%-5d f %8.2f px  kappa1 %+.3e /mm^2  centre (%.1f, %.1f, %.1f) mm",
          m.id.c_str(), m.width_px, m.height_px, m.focal_mm / m.sensor.dpy_mm(), m.kappa1_per_mm2,
          c.x(), c.y(), c.z());
      out << line;
      if (m.lens.Any()) {
        std::snprintf(line, sizeof line, "  lens k1 %+.4f k2 %+.4f p1 %+.5f p2 %+.5f k3 %+.4f",
                      m.lens.k1, m.lens.k2, m.lens.p1, m.lens.p2, m.lens.k3);
        out << line;
      }
      if (!cam.neighbours.empty()) out << "  cluster " << cam.neighbours.size() + 1;
      out << "\n";
    }
  }
  out << "  instants: " << instants.size();
  if (!instants.empty()) {
    const auto first = ParseInstantName(instants.front());
    const auto last = ParseInstantName(instants.back());
    out << " (" << first->Text() << " .. " << last->Text() << ")";
  }
  out << "\n  images checked: " << images_checked << "\n";
  out << "  calib: " << (has_calib ? std::to_string(calib_files) + " file(s)" : "none") << "\n";
  out << "  masks: " << (mask_instants > 0 ? std::to_string(mask_instants) + " instant(s)" : "none")
      << "\n";
  out << "  background plates: "
      << (background_plates > 0 ? std::to_string(background_plates) : std::string("none")) << "\n";
  out << "  truth: " << (has_truth ? std::to_string(truth_instants) + " instant(s)" : "none")
      << "\n";
  if (problems.empty()) {
    out << "  OK\n";
  } else {
    out << "  " << problems.size() << " problem(s):\n";
    for (const auto& p : problems) out << "    " << p.Text() << "\n";
  }
  return out.str();
}

}  // namespace dome::take
