#include "synth/synth.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <sstream>

#include "capture/tape.h"
#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "schema/rig_json.h"
#include "synth/batter.h"
#include "synth/calibration.h"
#include "synth/dome_rig.h"
#include "synth/render.h"
#include "synth/scene.h"
#include "take/take.h"
#include "take/timecode.h"

namespace dome::synth {

namespace fs = std::filesystem;
using core::Require;

namespace {

// Noise streams: one per kind of image.
enum NoiseKind : uint64_t { kTakeView = 1, kStage1View = 2, kStage2View = 3, kPlateView = 4 };
constexpr int kFirstFrame = 10 * 30;  // 00:00:10:00 at 30 frames per second
constexpr int kFramesPerInstant = 5;  // 6 Hz

std::string TargetJson(const std::vector<TargetPoint>& points, const std::string& frame,
                       const std::string& description, double radius, double key_radius,
                       int grid_points = 0) {
  return schema::TargetToJson({"", frame, description, radius, key_radius, points, grid_points});
}

// The true view of the target from `camera` (pose: target -> camera), image <name>.png.
std::string ViewJson(const std::string& camera, const std::string& name,
                     const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                     const std::vector<ImagePoint>& points) {
  schema::CalibView view;
  view.camera = camera;
  view.image = name + ".png";
  view.target = "target.json";
  view.source = "truth";
  view.target_to_camera = schema::TargetPose{rotation, translation};
  view.points = points;
  return schema::CalibViewToJson(view);
}

// The truth mesh: vertices, normals, and the albedo at each vertex as a grey colour.
io::Mesh TruthMesh(const SceneMesh& scene) {
  io::Mesh mesh;
  mesh.vertices = scene.vertices;
  mesh.normals = scene.normals;
  mesh.faces = scene.faces;
  std::vector<int> part_of_vertex(scene.vertices.size(), 0);
  for (size_t f = 0; f < scene.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) part_of_vertex[scene.faces[f][k]] = scene.face_part[f];
  }
  mesh.colors.resize(scene.vertices.size());
  for (size_t i = 0; i < scene.vertices.size(); ++i) {
    const Part& part = scene.parts[part_of_vertex[i]];
    const double a = Albedo(part.material, part.ToLocal(scene.vertices[i].cast<double>()));
    const auto g = static_cast<uint8_t>(std::clamp(std::lround(a * 255.0), 0L, 255L));
    mesh.colors[i] = io::Color3u8(g, g, g);
  }
  return mesh;
}

void CreateFolder(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  Require(!ec, dir.string(), "cannot create the folder: " + ec.message());
}

// Prepares TAKE/: refuses to replace a take without `overwrite`, removes what a
// previous synth run wrote when it may, and checks that files can be written there.
void PrepareTakeDir(const fs::path& dir, bool overwrite) {
  std::error_code ec;
  // Only a folder that holds a take (a rig.json) has its take folders removed.
  const bool replace = overwrite && fs::exists(dir / "rig.json", ec);
  take::CreateTakeDir(dir, overwrite);
  if (replace) {
    for (const char* sub : {"frames", "tape", "truth", "calib", "background"}) {
      fs::remove_all(dir / sub, ec);
      Require(!ec, (dir / sub).string(), "cannot remove the old folder: " + ec.message());
    }
    fs::remove(dir / "rig.json", ec);
  }
  CreateFolder(dir / "frames");
  const fs::path probe = dir / ".dome-synth-probe";
  try {
    io::WriteFileAtomically(probe, "probe");
  } catch (const core::InputError& e) {
    throw core::InputError(dir.string(),
                           std::string("the output folder is not writable (") + e.what() + ")");
  }
  fs::remove(probe, ec);
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

const std::vector<SynthPreset>& SynthPresets() {
  static const std::vector<SynthPreset> presets = {
      {"paper", 51, 11, 320, 245},
      {"small", 6, 3, 160, 120},
  };
  return presets;
}

SynthPreset SynthOptions::Resolve() const {
  const auto& presets = SynthPresets();
  const auto it = std::find_if(presets.begin(), presets.end(),
                               [&](const SynthPreset& p) { return p.name == preset; });
  std::string names;
  for (const auto& p : presets) names += (names.empty() ? "" : ", ") + p.name;
  Require(it != presets.end(), "--preset",
          "unknown preset '" + preset + "' (expected one of: " + names + ")");
  SynthPreset out = *it;
  if (cameras) out.cameras = *cameras;
  if (instants) out.instants = *instants;
  if (width_px) out.width_px = *width_px;
  if (height_px) out.height_px = *height_px;
  DomeRigOptions rig;
  rig.cameras = out.cameras;
  rig.width_px = out.width_px;
  rig.height_px = out.height_px;
  rig.Check();
  Require(out.instants >= 1 && out.instants <= kMaxInstants, "--instants",
          "expected 1.." + std::to_string(kMaxInstants) + " instants, got " +
              std::to_string(out.instants));
  Require(threads >= 0, "--threads",
          "expected a thread count >= 0 (0 = all), got " + std::to_string(threads));
  return out;
}

std::string InstantName(int k) {
  const int frame = kFirstFrame + kFramesPerInstant * k;
  take::Timecode tc;
  tc.frames = frame % 30;
  tc.seconds = (frame / 30) % 60;
  tc.minutes = (frame / 1800) % 60;
  tc.hours = frame / 108000;
  return tc.FolderName();
}

double InstantTimeS(int k) { return kFramesPerInstant * k / 30.0; }

std::string SynthSummary::BriefReport() const {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof line,
                "synthetic take: preset %s, seed %llu, %d cameras, %d instants (%s .. %s), "
                "%dx%d images from %dx%d interlaced frames\n",
                scene.name.c_str(), static_cast<unsigned long long>(seed), scene.cameras,
                scene.instants, instants.empty() ? "" : instants.front().c_str(),
                instants.empty() ? "" : instants.back().c_str(), scene.width_px, scene.height_px,
                2 * scene.width_px, 2 * scene.height_px);
  out << line;
  std::snprintf(line, sizeof line, "  truth mesh: %d vertices, %d triangles per instant\n",
                truth_mesh_vertices, truth_mesh_faces);
  out << line;
  std::snprintf(line, sizeof line,
                "  bat (70 mm) across: median %.1f px (min %.1f, max %.1f); bat tip moves up to "
                "%.1f px between fields\n",
                bat_px_median, bat_px_min, bat_px_max, field_motion_px_max);
  out << line;
  std::snprintf(line, sizeof line,
                "  calibration truth: at least %d of 147 object points (stage 1) and %d of %d "
                "floor marks (stage 2) per camera\n",
                stage1_points_min, stage2_points_min,
                static_cast<int>(AllFloorMarkPoints().size()));
  out << line;
  std::snprintf(line, sizeof line, "  %d files in %.1f s\n", files_written, seconds);
  out << line;
  return out.str();
}

SynthSummary GenerateTake(const SynthOptions& options, const fs::path& out_dir) {
  const core::Stopwatch stopwatch;
  const SynthPreset scene = options.Resolve();
  PrepareTakeDir(out_dir, options.overwrite);

  SynthSummary summary;
  summary.scene = scene;
  summary.seed = options.seed;

  DomeRigOptions rig_options;
  rig_options.cameras = scene.cameras;
  rig_options.width_px = scene.width_px;
  rig_options.height_px = scene.height_px;
  const std::vector<DomeCamera> cameras = MakeDomeRig(rig_options);
  geometry::Rig rig;
  rig.source = "synthetic";
  rig.source_unit = "mm";
  rig.source_unit_mm = 1.0;
  for (const auto& cam : cameras) rig.cameras.push_back(cam.rig);
  schema::WriteRig(rig, out_dir / "rig.json");

  // Folders.
  for (int k = 0; k < scene.instants; ++k) {
    summary.instants.push_back(InstantName(k));
    const std::string& name = summary.instants.back();
    CreateFolder(out_dir / "frames" / name);
    CreateFolder(out_dir / "truth" / name / "depth");
    CreateFolder(out_dir / "truth" / name / "mask");
    if (options.write_tape) CreateFolder(out_dir / "tape" / name);
  }
  if (options.write_calibration) {
    CreateFolder(out_dir / "calib" / "stage1");
    CreateFolder(out_dir / "calib" / "stage2");
  }
  if (options.write_background) CreateFolder(out_dir / "background");

  // Scenes: the dome at each instant's two field times, and the floor marks.
  const int n = scene.instants;
  std::vector<std::unique_ptr<SceneMesh>> meshes(2 * n);
  core::ParallelFor(0, 2 * n, options.threads, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const double t = InstantTimeS(static_cast<int>(i / 2)) + (i % 2 == 1 ? kFieldDelayS : 0.0);
      meshes[i] = std::make_unique<SceneMesh>(BuildDomeScene(t));
    }
  });
  std::vector<std::unique_ptr<RayCaster>> casters;
  for (const auto& mesh : meshes) casters.push_back(std::make_unique<RayCaster>(*mesh));
  const SceneMesh floor_mesh = BuildFloorMarkScene();
  const RayCaster floor_caster(floor_mesh);
  // The background plates' scene: the dome scene without the person (the room alone;
  // the person casts no shadow in the synthetic lighting, synth/texture.h).
  const SceneMesh room_mesh = BuildRoom(false);
  const RayCaster room_caster(room_mesh);
  const Lighting dome_lighting = DomeLighting();
  const Lighting bench_lighting = BenchLighting();
  summary.truth_mesh_vertices = static_cast<int>(meshes[0]->vertices.size());
  summary.truth_mesh_faces = static_cast<int>(meshes[0]->faces.size());
  spdlog::info("synth: {} scenes of ~{} triangles built in {:.2f} s", meshes.size(),
               summary.truth_mesh_faces, stopwatch.ElapsedSeconds());

  // Jobs: one per (instant, camera) view, one per instant mesh, two per camera for
  // calibration. Pulled dynamically by the workers; every output is a function of its
  // job alone, so the take does not depend on the thread count.
  struct Job {
    enum Kind { kView, kMesh, kStage1, kStage2, kPlate } kind;
    int instant;
    int camera;
  };
  std::vector<Job> jobs;
  for (int k = 0; k < n; ++k) {
    for (int c = 0; c < scene.cameras; ++c) jobs.push_back({Job::kView, k, c});
  }
  for (int k = 0; k < n; ++k) jobs.push_back({Job::kMesh, k, 0});
  if (options.write_background) {
    for (int c = 0; c < scene.cameras; ++c) jobs.push_back({Job::kPlate, 0, c});
  }
  if (options.write_calibration) {
    // (a stage-1 job's `instant` is the object's pose, synth/calibration.h)
    for (int pose = 0; pose < kStage1Poses; ++pose) {
      for (int c = 0; c < scene.cameras; ++c) jobs.push_back({Job::kStage1, pose, c});
    }
    for (int c = 0; c < scene.cameras; ++c) jobs.push_back({Job::kStage2, 0, c});
  }

  std::vector<double> bat_px(static_cast<size_t>(n) * scene.cameras, -1.0);
  std::vector<double> field_motion(static_cast<size_t>(n) * scene.cameras, 0.0);
  std::vector<int> stage1_points(scene.cameras, 0), stage2_points(scene.cameras, 0);
  std::atomic<int> files{1};  // rig.json
  std::atomic<size_t> next{0}, done{0};
  std::mutex log_mutex;

  if (options.write_calibration) {
    io::WriteFileAtomically(
        out_dir / "calib" / "stage1" / "target.json",
        TargetJson(CalibObjectPoints(), "object",
                   "three orthogonal 800 mm white plates meeting at the origin (the "
                   "inside of a box corner), dotted faces on z=0, y=0, x=0; 7x7 black "
                   "dots 100 mm apart on each; the dot nearest the corner is larger",
                   kPlateDotRadiusMm, kPlateKeyDotRadiusMm));
    io::WriteFileAtomically(
        out_dir / "calib" / "stage2" / "target.json",
        TargetJson(AllFloorMarkPoints(), "world",
                   "floor marks: black dots on white pads, 5x5 grid 250 mm apart "
                   "centred on the dome's axis, the mark at (-500,-500) larger; "
                   "around it plain marks 500 mm apart out to 2 m from the axis",
                   kFloorMarkDotRadiusMm, kFloorMarkKeyDotRadiusMm,
                   static_cast<int>(FloorMarkPoints().size())));
    files += 2;
  }

  // A dome camera's view of a scene that does not move (the room for the background
  // plate, the floor marks for stage 2), without depth.
  auto render_static = [&](const DomeCamera& cam, int camera, const RayCaster& caster,
                           NoiseKind kind) {
    RenderRequest request;
    request.camera = &cam.rig.model;
    request.response = cam.response;
    request.first_field = &caster;
    request.second_field = &caster;
    request.lighting = &dome_lighting;
    request.noise_key = NoiseKey(options.seed, kind, 0, camera);
    request.depth = false;
    return RenderView(request);
  };
  auto run_job = [&](const Job& job) {
    const DomeCamera* cam = job.kind == Job::kMesh ? nullptr : &cameras[job.camera];
    switch (job.kind) {
      case Job::kView: {
        const std::string& instant = summary.instants[job.instant];
        const std::string& id = cam->rig.model.id;
        RenderRequest request;
        request.camera = &cam->rig.model;
        request.response = cam->response;
        request.first_field = casters[2 * job.instant].get();
        request.second_field = casters[2 * job.instant + 1].get();
        request.lighting = &dome_lighting;
        request.noise_key = NoiseKey(options.seed, kTakeView, job.instant, job.camera);
        request.person_mask = true;
        const RenderedView view = RenderView(request);
        io::WriteImage(out_dir / "frames" / instant / (id + ".png"), view.image,
                       io::PngEncoding::kFast);
        io::WriteDepthTiff(out_dir / "truth" / instant / "depth" / (id + ".tiff"), view.depth_mm);
        io::WriteImage(out_dir / "truth" / instant / "mask" / (id + ".png"), view.person,
                       io::PngEncoding::kFast);
        files += 3;
        if (options.write_tape) {
          io::WriteImage(out_dir / "tape" / instant / (id + ".png"), view.frame,
                         io::PngEncoding::kFast);
          ++files;
        }
        // Figures: the bat's width in pixels, and how far its tip moves between fields.
        const geometry::TsaiCamera& m = cam->rig.model;
        const double t = InstantTimeS(job.instant);
        const BatterPose p0 = PoseBatter(t), p1 = PoseBatter(t + kFieldDelayS);
        const Eigen::Vector3d middle = p0.bat_knob_mm + 0.6 * p0.bat_length_mm * p0.bat_dir;
        Eigen::Vector2d px;
        const size_t slot = static_cast<size_t>(job.instant) * scene.cameras + job.camera;
        if (m.Project(middle, &px) && px.x() >= 0 && px.y() >= 0 && px.x() <= m.width_px - 1 &&
            px.y() <= m.height_px - 1) {
          const double z = m.WorldToCamera(middle).z();
          const float depth = view.depth_mm.at<float>(static_cast<int>(std::lround(px.y())),
                                                      static_cast<int>(std::lround(px.x())));
          if (std::abs(depth - z) < 2.0 * p0.bat_radius_mm) {  // the bat is what we see
            bat_px[slot] = 2.0 * p0.bat_radius_mm * m.focal_mm * m.sx / (m.sensor.dpx_mm() * z);
          }
        }
        Eigen::Vector2d tip0, tip1;
        if (m.Project(p0.bat_knob_mm + p0.bat_length_mm * p0.bat_dir, &tip0) &&
            m.Project(p1.bat_knob_mm + p1.bat_length_mm * p1.bat_dir, &tip1)) {
          field_motion[slot] = (tip1 - tip0).norm();
        }
        break;
      }
      case Job::kMesh: {
        io::PlyWriteOptions ply;
        ply.comments = {"dome synth truth mesh, world frame, units mm",
                        "instant " + summary.instants[job.instant]};
        io::WritePly(out_dir / "truth" / summary.instants[job.instant] / "mesh.ply",
                     TruthMesh(*meshes[2 * job.instant]), ply);
        ++files;
        break;
      }
      case Job::kStage1: {
        const std::string& id = cam->rig.model.id;
        Eigen::Matrix3d r;
        Eigen::Vector3d t;
        const int pose = job.instant;
        Stage1Pose(cam->rig.model, job.camera, pose, &r, &t);
        const SceneMesh bench = BuildBenchScene(r, t);
        const RayCaster caster(bench);
        geometry::TsaiCamera camera_frame = cam->rig.model;  // the scene is in its frame
        camera_frame.rotation.setIdentity();
        camera_frame.translation_mm.setZero();
        RenderRequest request;
        request.camera = &camera_frame;
        request.response = cam->response;
        request.first_field = &caster;
        request.second_field = &caster;
        request.lighting = &bench_lighting;
        request.noise_key = NoiseKey(options.seed, kStage1View, pose, job.camera);
        request.depth = false;
        const RenderedView view = RenderView(request);
        std::vector<TargetPoint> points = CalibObjectPoints();
        for (auto& p : points) p.position_mm = r * p.position_mm + t;
        const auto truth = TrueImagePoints(camera_frame, points, kPlateDotRadiusMm, caster);
        if (pose == 0) stage1_points[job.camera] = static_cast<int>(truth.size());
        const fs::path dir = out_dir / "calib" / "stage1";
        // pose 0: <camera>.json; the object moved: <camera>.<pose>.json
        const std::string name = pose == 0 ? id : id + "." + std::to_string(pose);
        io::WriteImage(dir / (name + ".png"), view.image,
                       io::PngEncoding::kFast);
        io::WriteFileAtomically(dir / (name + ".json"), ViewJson(id, name, r, t, truth));
        files += 2;
        break;
      }
      case Job::kPlate: {
        io::WriteImage(out_dir / "background" / (cam->rig.model.id + ".png"),
                       render_static(*cam, job.camera, room_caster, kPlateView).image,
                       io::PngEncoding::kFast);
        ++files;
        break;
      }
      case Job::kStage2: {
        const std::string& id = cam->rig.model.id;
        const RenderedView view = render_static(*cam, job.camera, floor_caster, kStage2View);
        const auto truth = TrueImagePoints(cam->rig.model, AllFloorMarkPoints(),
                                           kFloorMarkDotRadiusMm, floor_caster);
        stage2_points[job.camera] = static_cast<int>(truth.size());
        const fs::path dir = out_dir / "calib" / "stage2";
        io::WriteImage(dir / (id + ".png"), view.image,
                       io::PngEncoding::kFast);
        io::WriteFileAtomically(
            dir / (id + ".json"),
            ViewJson(id, id, cam->rig.model.rotation, cam->rig.model.translation_mm, truth));
        files += 2;
        break;
      }
    }
  };

  const int threads = options.threads > 0 ? options.threads : core::HardwareThreads();
  core::ParallelFor(0, threads, threads, [&](int64_t, int64_t) {
    for (size_t i = next++; i < jobs.size(); i = next++) {
      run_job(jobs[i]);
      const size_t finished = ++done;
      if (finished % std::max<size_t>(1, jobs.size() / 10) == 0) {
        std::lock_guard<std::mutex> lock(log_mutex);
        spdlog::info("synth: {}/{} jobs done ({:.1f} s)", finished, jobs.size(),
                     stopwatch.ElapsedSeconds());
      }
    }
  });

  // Tape videos from the tape frames just written (capture/tape.h).
  if (options.write_tape && options.write_tape_video) {
    files += capture::WriteTakeTapes(out_dir, capture::TapeLayout{}, options.threads);
  }

  std::vector<double> visible;
  for (double b : bat_px) {
    if (b > 0) visible.push_back(b);
  }
  if (!visible.empty()) {
    summary.bat_px_median = Median(visible);
    summary.bat_px_min = *std::min_element(visible.begin(), visible.end());
    summary.bat_px_max = *std::max_element(visible.begin(), visible.end());
  }
  summary.field_motion_px_max = *std::max_element(field_motion.begin(), field_motion.end());
  if (options.write_calibration) {
    summary.stage1_points_min = *std::min_element(stage1_points.begin(), stage1_points.end());
    summary.stage2_points_min = *std::min_element(stage2_points.begin(), stage2_points.end());
  }
  summary.files_written = files;
  summary.seconds = stopwatch.ElapsedSeconds();
  return summary;
}

}  // namespace dome::synth
