#include "pipeline/jobs.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/error.h"
#include "core/json.h"
#include "core/parallel_for.h"
#include "fusion/volume.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "pipeline/frame_handoff.h"
#include "pipeline/ideal_greys.h"
#include "pipeline/settings.h"
#include "pipeline/shared_fusion.h"
#include "pipeline/shared_hulls.h"
#include "pipeline/stage.h"
#include "pipeline/stages.h"
#include "pipeline/surface_stream.h"
#include "schema/rig_json.h"
#include "silhouette/hull.h"
#include "silhouette/photo_hull.h"
#include "silhouette/take_masks.h"
#include "stereo/cluster.h"
#include "stereo/temporal_bounds.h"

namespace dome::pipeline {
namespace {

namespace fs = std::filesystem;

// ---- helpers shared by the stages -------------------------------------------------------

runtime::FloatImage EncodeFloatImage(const cv::Mat& m) {
  DOME_CHECK(m.empty() || m.type() == CV_32FC1, "float image expected");
  runtime::FloatImage f;
  f.set_rows(m.rows);
  f.set_cols(m.cols);
  std::string data(size_t(m.rows) * m.cols * sizeof(float), '\0');
  for (int r = 0; r < m.rows; ++r) {
    std::memcpy(data.data() + size_t(r) * m.cols * sizeof(float), m.ptr<float>(r),
                size_t(m.cols) * sizeof(float));
  }
  f.set_data(std::move(data));
  return f;
}

cv::Mat DecodeFloatImage(const runtime::FloatImage& f, const std::string& where) {
  core::Require(f.rows() >= 0 && f.cols() >= 0 &&
                    f.data().size() == size_t(f.rows()) * size_t(f.cols()) * sizeof(float),
                where,
                "float image of " + std::to_string(f.rows()) + "x" + std::to_string(f.cols()) +
                    " does not hold that many floats");
  cv::Mat m(f.rows(), f.cols(), CV_32FC1);
  if (!f.data().empty()) std::memcpy(m.data, f.data().data(), f.data().size());
  return m;
}

// The smallest rectangle holding every non-zero value of two maps of one size (0x0 at
// 0, 0 when there is none).
cv::Rect NonZeroRect(const cv::Mat& a, const cv::Mat& b) {
  int x0 = a.cols, y0 = a.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < a.rows; ++y) {
    const float* pa = a.ptr<float>(y);
    const float* pb = b.ptr<float>(y);
    int first = -1, last = -1;
    for (int x = 0; x < a.cols; ++x) {
      if (pa[x] != 0.0f || pb[x] != 0.0f) {
        if (first < 0) first = x;
        last = x;
      }
    }
    if (first < 0) continue;
    x0 = std::min(x0, first);
    x1 = std::max(x1, last);
    y0 = std::min(y0, y);
    y1 = y;
  }
  if (x1 < 0) return cv::Rect(0, 0, 0, 0);
  return cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

// Where `crop` lies in its full map: at (x0, y0) of full_cols x full_rows; checked to fit.
stereo::MapCut CheckedCut(const runtime::StereoRangeImage& ri, const cv::Mat& crop,
                          const std::string& where) {
  const int64_t rows = ri.full_rows(), cols = ri.full_cols(), x0 = ri.x0(), y0 = ri.y0();
  core::Require(ri.has_full_rows() && ri.has_full_cols() && ri.has_x0() && ri.has_y0(), where,
                "needs all of full_rows, full_cols, x0 and y0, or none");
  core::Require(rows >= 1 && cols >= 1 && rows * cols <= (int64_t(1) << 31) && x0 >= 0 && y0 >= 0 &&
                    x0 + crop.cols <= cols && y0 + crop.rows <= rows,
                where,
                "a " + std::to_string(crop.cols) + "x" + std::to_string(crop.rows) +
                    " rectangle at " + std::to_string(x0) + ", " + std::to_string(y0) +
                    " does not fit a " + std::to_string(cols) + "x" + std::to_string(rows) +
                    " image");
  return {cv::Point(int(x0), int(y0)), cv::Size(int(cols), int(rows))};
}

// `crop` put back at its place in a full map of zeros.
cv::Mat PlaceRect(const stereo::MapCut& cut, const cv::Mat& crop) {
  cv::Mat full(cut.full, CV_32FC1, cv::Scalar(0));
  if (!crop.empty()) crop.copyTo(full(cv::Rect(cut.at, crop.size())));
  return full;
}

std::string JobWhere(const runtime::Job& job) { return "job " + job.id(); }

std::string BlobName(const runtime::Job& job, size_t i) {
  return JobWhere(job) + " blob " +
         (i < size_t(job.blobs_size()) ? job.blobs(int(i)).name() : std::to_string(i));
}

// The job's settings message (its stage's own), parsed.
template <class Settings>
Settings JobSettings(const runtime::Job& job) {
  Settings s;
  core::Require(s.ParseFromString(job.settings()), JobWhere(job),
                "settings are not a " + s.GetTypeName() + " message");
  return s;
}

void RequireBlobs(const runtime::Job& job, const JobBlobs& blobs, size_t n) {
  core::Require(
      blobs.size() == size_t(job.blobs_size()) && blobs.size() >= n, JobWhere(job),
      "expected " + std::to_string(n) + " input blobs, got " + std::to_string(blobs.size()));
}

// The rig of blob 0: parsed once per worker while its bytes stay the same (every job
// of a session sends the same rig; parsing 51 cameras' JSON was a few percent of a
// masked stereo job).
geometry::Rig RigBlob(const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
  auto parse = [&] {
    return std::make_unique<geometry::Rig>(schema::ParseRigJson(*blobs[0], BlobName(job, 0)));
  };
  if (!memo) return *parse();
  return *memo->Get<geometry::Rig>(job.blobs(0).sha256(), parse);
}

cv::Mat FrameBlob(const runtime::Job& job, const JobBlobs& blobs, size_t i, io::ImageMode mode) {
  return io::DecodeImage(*blobs[i], mode, BlobName(job, i));
}

const geometry::TsaiCamera& RigCameraOf(const geometry::Rig& rig, const std::string& id,
                                        const runtime::Job& job) {
  const int k = rig.Find(id);
  core::Require(k >= 0, JobWhere(job), "camera '" + id + "' is not in the rig");
  return rig.cameras[k].model;
}

// The visual hull of the rig's cameras from the masks at blobs[first..], rig order.
// The masks are blobs [first, first + cameras); `after` blobs of the job follow them.
std::unique_ptr<silhouette::VisualHull> HullBlobs(const runtime::Job& job, const JobBlobs& blobs,
                                                  size_t first, size_t after,
                                                  const geometry::Rig& rig, int carve_votes,
                                                  int min_views, bool distances) {
  // The hull's rule as the master sent it (SilhouetteSettings), named by its job field.
  core::Require(carve_votes >= 1, JobWhere(job),
                "carve_votes: expected at least 1 camera, got " + std::to_string(carve_votes));
  core::Require(min_views >= 2, JobWhere(job),
                "min_views: expected at least 2 cameras, got " + std::to_string(min_views));
  core::Require(blobs.size() == first + rig.cameras.size() + after, JobWhere(job),
                "expected one mask per rig camera (" + std::to_string(rig.cameras.size()) +
                    ") after blob " + std::to_string(first) +
                    (after ? " and " + std::to_string(after) + " blobs after them" : "") +
                    ", got " + std::to_string(blobs.size() - std::min(blobs.size(), first)) +
                    " blobs from there");
  // Built once for every worker of the process (shared_hulls.h), so with all their
  // threads: a worker that would wait for another's build builds part of it.
  const int threads = std::max(job.threads(), ProcessWorkerThreads());
  std::vector<geometry::TsaiCamera> cameras(rig.cameras.size());
  std::vector<cv::Mat> masks(rig.cameras.size());
  core::ParallelFor(0, int64_t(rig.cameras.size()), threads, [&](int64_t b, int64_t e) {
    for (int64_t c = b; c < e; ++c) {
      cameras[size_t(c)] = rig.cameras[size_t(c)].model;
      masks[size_t(c)] = FrameBlob(job, blobs, first + size_t(c), io::ImageMode::kGray8);
    }
  });
  silhouette::HullOptions options;
  options.num_threads = threads;
  options.distances = distances;
  options.carve_votes = carve_votes;
  options.min_views = min_views;
  // Fusion's hull (the one with distances) is never asked for ray bounds.
  if (distances) options.ray_block_px = 1;
  return std::make_unique<silhouette::VisualHull>(cameras, masks, options);
}

// The masks stage's outputs of the instant, rig order.
void AddMaskBlobs(const JobContext& ctx, std::vector<runtime::BlobRef>* blobs) {
  for (int c = 0; c < int(ctx.plan.cameras.size()); ++c)
    blobs->push_back(ctx.outputs("masks", c).at(0));
}

// A job's settings message (serialized) and its blobs, in the order its run reads them.
void SetJob(const google::protobuf::Message& settings, std::vector<runtime::BlobRef> blobs,
            runtime::Job* job) {
  job->set_settings(settings.SerializeAsString());
  for (auto& b : blobs) *job->add_blobs() = std::move(b);
}

using Parts = std::function<std::vector<std::string>(const SessionPlan&)>;

StageDescriptor Descriptor(std::string name, std::vector<std::string> after, Parts parts) {
  StageDescriptor d;
  d.name = std::move(name);
  d.after = std::move(after);
  d.parts = std::move(parts);
  return d;
}

// Every default stage but noop reconstructs a take; a no-op session runs only noop.
bool Reconstructs(const SessionPlan& plan) { return plan.spec.noop_jobs() <= 0; }

std::vector<std::string> OnePart(const SessionPlan& plan) {
  return Reconstructs(plan) ? std::vector<std::string>{""} : std::vector<std::string>{};
}

// ---- stereo ---------------------------------------------------------------------------

// Blobs [first, last) of `job` decoded in `mode`. A worker's job (one with a memo) first
// looks among the frames this process's jobs kept (frame_handoff.h), then among those it
// decoded before the session ran (`dome run`'s derivation), and keeps what it decodes on
// its threads; a job without one decodes every blob.
std::vector<cv::Mat> FrameBlobs(const runtime::Job& job, const JobBlobs& blobs, size_t first,
                                size_t last, io::ImageMode mode, JobMemo* memo) {
  const bool keep = memo != nullptr;
  DOME_CHECK(first <= last && last <= blobs.size(), "frame blobs within the job's blobs");
  std::vector<cv::Mat> images(last - first);
  std::vector<size_t> missing;
  for (size_t i = first; i < last; ++i) {
    const std::string& sha256 = job.blobs(int(i)).sha256();
    cv::Mat found = keep ? FindKeptFrame(sha256, mode) : cv::Mat();
    if (found.empty() && keep) {
      const cv::Mat handed = TakeDecodedFrame(sha256);
      if (!handed.empty()) {
        KeepFrame(sha256, io::ImageMode::kUnchanged, handed);
        found = FindKeptFrame(sha256, mode);
      }
    }
    if (!found.empty()) {
      images[i - first] = found;
    } else {
      missing.push_back(i);
    }
  }
  core::ParallelFor(0, int64_t(missing.size()), job.threads(), [&](int64_t b, int64_t e) {
    for (int64_t k = b; k < e; ++k)
      images[missing[k] - first] = FrameBlob(job, blobs, missing[k], mode);
  });
  if (keep) {
    for (size_t i : missing)
      images[i - first] = KeepFrame(job.blobs(int(i)).sha256(), mode, images[i - first]);
  }
  return images;
}

// ---- masks ----------------------------------------------------------------------------

// One camera's foreground mask at one instant (silhouette/take_masks.h), made where the
// jobs run rather than at submit: a long take's submit would otherwise decode and
// classify every frame before its first job. Parts: the cameras, when stereo or fusion
// use the masks; none otherwise.
StageDescriptor MaskStage() {
  StageDescriptor d = Descriptor("masks", {}, [](const SessionPlan& plan) {
    return Reconstructs(plan) && !plan.mask_inputs.empty() ? plan.cameras
                                                           : std::vector<std::string>{};
  });
  d.send_ahead = true;
  d.make_job = [](const JobContext& ctx, runtime::Job* job) {
    runtime::MaskJob mj;
    mj.set_camera(ctx.plan.cameras[ctx.part]);
    mj.set_source(ctx.plan.mask_sources.at(ctx.part));
    std::vector<runtime::BlobRef> blobs = {ctx.plan.rig};
    for (const auto& b : ctx.plan.mask_inputs.at(ctx.instant).at(ctx.part)) blobs.push_back(b);
    SetJob(mj, std::move(blobs), job);
  };
  d.run = [](const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
    const auto mj = JobSettings<runtime::MaskJob>(job);
    RequireBlobs(job, blobs, 2);
    const geometry::Rig rig = RigBlob(job, blobs, memo);
    const geometry::TsaiCamera& camera = RigCameraOf(rig, mj.camera(), job);
    const cv::Size size(camera.width_px, camera.height_px);
    auto unchanged = [&](size_t i) { return FrameBlob(job, blobs, i, io::ImageMode::kUnchanged); };
    // Made already by this process's derivation (frame_handoff.h): the same inputs.
    std::vector<std::string> inputs;
    for (int b = 1; b < job.blobs_size(); ++b) inputs.push_back(job.blobs(b).sha256());
    cv::Mat mask = TakeMask(MaskHandoffKey(mj.camera(), mj.source(), inputs));
    auto make = [&]() -> cv::Mat {
      if (mj.source() == "given") {
        return silhouette::MaskImage(unchanged(1), size, mj.camera(), BlobName(job, 1));
      } else if (mj.source() == "plate" || mj.source() == "median") {
        const bool median = mj.source() == "median";
        const size_t needed = median ? 1 + silhouette::MaskOptions::kMinMedianInstants : 2;
        core::Require(median ? blobs.size() >= 1 + needed : blobs.size() == 1 + needed,
                      JobWhere(job),
                      median ? "a median mask needs the frame and at least " +
                                   std::to_string(needed - 1) + " frames for the median, got " +
                                   std::to_string(blobs.size() - 1) + " blobs after the rig"
                             : "a plate's mask needs the frame and the plate, got " +
                                   std::to_string(blobs.size() - 1) + " blobs after the rig");
        const silhouette::Frame frame =
            silhouette::SplitFrame(unchanged(1), size, mj.camera(), BlobName(job, 1));
        cv::Mat background;
        if (median) {
          std::vector<cv::Mat> colours(blobs.size() - 2);
          core::ParallelFor(0, int64_t(colours.size()), job.threads(), [&](int64_t b, int64_t e) {
            for (int64_t i = b; i < e; ++i) {
              colours[size_t(i)] = silhouette::SplitFrame(unchanged(size_t(i) + 2), size,
                                                          mj.camera(), BlobName(job, size_t(i) + 2))
                                       .colour;
            }
          });
          background = silhouette::MedianBackground(colours, frame.colour.channels());
        } else {
          background = silhouette::SplitFrame(unchanged(2), size, mj.camera(), BlobName(job, 2)).colour;
        }
        return silhouette::MaskAgainst(
            frame, background,
            median ? silhouette::MaskSource::kMedian : silhouette::MaskSource::kPlate,
            silhouette::MaskOptions{});
      } else {
        throw core::InputError(JobWhere(job), "unknown mask source '" + mj.source() +
                                                  "' (expected given, plate or median)");
      }
    };
    if (mask.size() != size) mask = make();
    std::vector<runtime::Output> outputs(1);
    outputs[0].set_name(kMaskOutput);
    outputs[0].set_data(io::EncodePng(mask, io::PngEncoding::kFast));  // as `dome masks`
    return outputs;
  };
  d.store = [](const StoreContext& ctx, const runtime::JobResult& r) {
    const std::string& bytes = OutputBytes(r, kMaskOutput, ctx.where);
    const std::string& cam = ctx.plan.cameras[ctx.part];
    const geometry::TsaiCamera& camera = ctx.plan.take.rig.cameras[ctx.part].model;
    const cv::Mat mask = io::DecodeImage(bytes, io::ImageMode::kUnchanged, ctx.where);
    core::Require(mask.type() == CV_8UC1 && mask.cols == camera.width_px &&
                      mask.rows == camera.height_px,
                  ctx.where,
                  "expected the mask of camera '" + cam + "' as an 8-bit gray " +
                      std::to_string(camera.width_px) + "x" + std::to_string(camera.height_px) +
                      " PNG, got " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
                      " of type " + std::to_string(mask.type()));
    fs::create_directories(ctx.dir / "mask");
    const fs::path file = ctx.dir / "mask" / (cam + ".png");
    io::WriteFileAtomically(file, bytes);
    return StoredResult{{ctx.blobs->KeepWritten(bytes, kMaskOutput, file)}, nullptr};
  };
  return d;
}

// ---- stereo -----------------------------------------------------------------------------

// What a stereo job's temporal bounds are made from: the previous instant's result for
// its camera and the reference's ideal greys then and now.
struct TemporalInput {
  TemporalUse use;
  stereo::StereoResult previous;
  cv::Mat grey_before, grey_now;
};

// From blobs `at` (the previous "stereo" output) and `at + 1` (the previous frame).
TemporalInput TemporalBlobs(const runtime::Job& job, const runtime::StereoJob& sj,
                            const JobBlobs& blobs, size_t at, const stereo::StereoInput& input,
                            const stereo::TakeStereoOptions& options, JobMemo* memo) {
  TemporalInput t;
  t.use = FromTemporalSettings(sj.temporal(), JobWhere(job));
  t.previous = DecodeStereoOutput(*blobs[at], BlobName(job, at));
  core::Require(t.previous.camera == sj.camera(), BlobName(job, at),
                "is the previous stereo output of camera '" + t.previous.camera +
                    "', expected '" + sj.camera() + "'");
  const stereo::StereoView& ref = input.reference;
  const stereo::StereoView before{
      ref.camera, FrameBlobs(job, blobs, at + 1, at + 2, io::ImageMode::kUnchanged, memo)[0]};
  const std::string where = BlobName(job, at + 1);
  // Kept for the process: it was this camera's reference grey at the previous instant.
  t.grey_before = SharedIdealGrey(
      IdealGreyKey(job.blobs(int(at + 1)).sha256(), job.blobs(0).sha256(), ref.camera.id,
                   options.stereo),
      before, options.stereo, where);
  t.grey_now = ref.ideal_grey.empty() ? stereo::IdealGrey(ref, options.stereo, JobWhere(job))
                                      : ref.ideal_grey;
  return t;
}

StageDescriptor StereoStage() {
  StageDescriptor d = Descriptor("stereo", {"masks"}, [](const SessionPlan& plan) {
    return Reconstructs(plan) ? plan.cameras : std::vector<std::string>{};
  });
  d.send_ahead = true;
  d.after_previous_instant = [](const SessionPlan& plan) { return plan.options.temporal.stereo; };
  d.make_job = [](const JobContext& ctx, runtime::Job* job) {
    const SessionPlan& plan = ctx.plan;
    runtime::StereoJob sj;
    sj.set_camera(plan.cameras[ctx.part]);
    *sj.mutable_stereo() = ToStereoSettings(plan.options.stereo);
    sj.set_write_previews(plan.options.stereo.write_previews);
    const auto& frames = plan.frames[ctx.instant];
    std::vector<runtime::BlobRef> blobs = {plan.rig, frames[ctx.part]};
    for (int j : stereo::SelectCluster(plan.take.rig, sj.camera(), plan.options.stereo.cluster)) {
      sj.add_neighbours(plan.cameras[j]);
      blobs.push_back(frames[j]);
    }
    if (plan.options.temporal.stereo && ctx.instant > 0) {
      *sj.mutable_temporal() = ToTemporalSettings(plan.options.temporal);
      blobs.push_back(ctx.previous_outputs().at(0));
      blobs.push_back(plan.frames[ctx.instant - 1][ctx.part]);
    }
    if (plan.options.silhouettes.stereo) {
      sj.set_hull_bounds(true);
      sj.set_carve_votes(plan.options.silhouettes.carve_votes);
      sj.set_min_views(plan.options.silhouettes.min_views);
      AddMaskBlobs(ctx, &blobs);
    }
    SetJob(sj, std::move(blobs), job);
  };
  d.run = [](const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
    const auto sj = JobSettings<runtime::StereoJob>(job);
    const size_t num_frames = 2 + size_t(sj.neighbours_size());
    // Then, with temporal bounds, the previous instant's stereo output and frame.
    const size_t first_mask = num_frames + (sj.has_temporal() ? 2 : 0);
    RequireBlobs(job, blobs, first_mask);
    const geometry::Rig rig = RigBlob(job, blobs, memo);
    stereo::TakeStereoOptions options = FromStereoSettings(sj.stereo(), JobWhere(job));
    options.stereo.num_threads = job.threads();
    const std::vector<cv::Mat> frames =
        FrameBlobs(job, blobs, 1, num_frames, io::ImageMode::kUnchanged, memo);
    stereo::StereoInput input;
    input.reference.camera = RigCameraOf(rig, sj.camera(), job);
    input.reference.image = frames[0];
    for (int n = 0; n < sj.neighbours_size(); ++n) {
      input.neighbours.push_back({RigCameraOf(rig, sj.neighbours(n), job), frames[1 + n]});
    }
    std::vector<std::string> grey_keys;
    if (options.coarse_to_fine) {
      // Coarse to fine cuts its views to the clip box, the same cut in every job: the
      // cut greys are kept for the process under these keys and the cut (Stereo).
      for (int blob = 1; blob < int(num_frames); ++blob) {
        grey_keys.push_back(IdealGreyKey(
            job.blobs(blob).sha256(), job.blobs(0).sha256(),
            blob == 1 ? input.reference.camera.id : input.neighbours[size_t(blob) - 2].camera.id,
            options.stereo));
      }
    } else {
      // The whole views' ideal greys, kept for the process's other stereo jobs of the
      // instant (pipeline/ideal_greys.h).
      auto grey = [&](stereo::StereoView* v, int blob, const char* role) {
        v->ideal_grey = SharedIdealGrey(
            IdealGreyKey(job.blobs(blob).sha256(), job.blobs(0).sha256(), v->camera.id,
                         options.stereo),
            *v, options.stereo, role + v->camera.id + "'");
      };
      grey(&input.reference, 1, "reference '");
      for (int n = 0; n < sj.neighbours_size(); ++n)
        grey(&input.neighbours[size_t(n)], 2 + n, "neighbour '");
    }
    // The search's level count over [z_min, z_max] (the widest-baseline neighbour's
    // parallax step): the hull's rays are sampled at the search's own levels, and the
    // temporal margin is counted in them.
    auto levels = [&](double z_min, double z_max) {
      if (options.stereo.num_levels > 0) return options.stereo.num_levels;
      std::vector<geometry::TsaiCamera> nb;
      for (const auto& v : input.neighbours) nb.push_back(v.camera);
      return stereo::CountDepthLevels(input.reference.camera, nb, z_min, z_max,
                                      options.stereo.level_step_px);
    };
    std::shared_ptr<const silhouette::VisualHull> hull;
    if (sj.hull_bounds()) {
      // Every stereo job of an instant needs the same hull (the masks of all cameras):
      // built once for the process's workers (shared_hulls.h), keyed by the masks, the
      // rule and the threads.
      std::string key = "stereo hull\n" + std::to_string(job.threads()) + '\n' +
                        std::to_string(sj.carve_votes()) + ' ' + std::to_string(sj.min_views());
      for (int b = int(first_mask); b < job.blobs_size(); ++b) key += '\n' + job.blobs(b).sha256();
      hull = SharedHull(key, [&] {
        return HullBlobs(job, blobs, first_mask, 0, rig, sj.carve_votes(), sj.min_views(),
                         /*distances=*/false);
      });
    }
    std::optional<TemporalInput> temporal;
    if (sj.has_temporal()) temporal = TemporalBlobs(job, sj, blobs, num_frames, input, options, memo);
    MakeSearchBounds bounds;
    if (hull || temporal) {
      const int index = rig.Find(sj.camera());
      bounds = [&, index](double z_min, double z_max) {
        const int n = levels(z_min, z_max);
        std::optional<stereo::SearchBounds> b;
        if (hull) b = stereo::SearchBounds{hull->RayBounds(index, z_min, z_max, n)};
        if (temporal) {
          stereo::TemporalBoundsStats st;
          stereo::SearchBounds t = stereo::TemporalBounds(
              temporal->previous.range_images, temporal->grey_before, temporal->grey_now, z_min,
              z_max, n, temporal->use.bounds, JobWhere(job) + ": temporal bounds", &st);
          spdlog::debug("{}: temporal bounds: {} of {} tiles bounded, {} changed, {} unknown "
                        "(threshold {:.2f} greys)",
                        JobWhere(job), st.bounded, st.tiles, st.changed, st.unknown,
                        st.threshold_grey);
          b = b ? stereo::IntersectBounds(*b, t) : std::move(t);
        }
        return std::move(*b);
      };
    }
    const stereo::StereoResult result = Stereo(input, options, JobWhere(job), bounds, grey_keys);
    std::vector<runtime::Output> outputs(1);
    outputs[0].set_name(kStereoOutput);
    outputs[0].set_data(EncodeStereoOutput(result));
    // The workers encode the files; the master only checks and writes them.
    for (stereo::StereoFile& f :
         stereo::EncodeStereoFiles(result, sj.write_previews(), job.threads())) {
      runtime::Output& o = outputs.emplace_back();
      o.set_name(std::move(f.path));
      o.set_data(std::move(f.bytes));
    }
    return outputs;
  };
  d.store = [](const StoreContext& ctx, const runtime::JobResult& r) {
    const std::string& bytes = OutputBytes(r, kStereoOutput, ctx.where);
    // The rectangles, compared with the files as placed in them (no whole maps made).
    std::vector<stereo::MapCut> cuts;
    const stereo::StereoResult result = DecodeStereoRects(bytes, ctx.where, &cuts);
    const std::string& camera = ctx.plan.cameras[ctx.part];
    core::Require(result.camera == camera, ctx.where, "is for camera '" + result.camera + "'");
    // Checking the files the worker encoded costs a fraction of encoding them.
    std::vector<stereo::StereoFile> files;
    for (const auto& o : r.outputs()) {
      if (o.name() != kStereoOutput) files.push_back({o.name(), o.data()});
    }
    stereo::CheckStereoFiles(result, ctx.plan.options.stereo.write_previews, files, ctx.where,
                             cuts);
    stereo::WriteStereoFiles(files, ctx.plan.instants[ctx.instant], ctx.dir.parent_path());
    return StoredResult{{ctx.blobs->Keep(bytes, kStereoOutput)}, nullptr};
  };
  return d;
}

// ---- fusion ---------------------------------------------------------------------------

StageDescriptor FusionStage() {
  StageDescriptor d = Descriptor("fusion", {"masks", "stereo"}, [](const SessionPlan& plan) {
    std::vector<std::string> parts;
    for (int s = 0; Reconstructs(plan) && s < plan.num_slabs; ++s)
      parts.push_back(std::to_string(s));
    return parts;
  });
  d.send_ahead = true;
  d.after_previous_instant = [](const SessionPlan& plan) { return plan.options.temporal.fusion; };
  d.make_job = [](const JobContext& ctx, runtime::Job* job) {
    const SessionOptions& o = ctx.plan.options;
    runtime::FusionJob fj;
    const auto [k0, k1] = SlabPlanes(o.grid, o.slab_planes, ctx.part);
    fj.set_k0(k0);
    fj.set_k1(k1);
    *fj.mutable_volume() = ToVolume(o.grid);
    *fj.mutable_fusion() = ToFusionSettings(o.fusion);
    std::vector<runtime::BlobRef> blobs = {ctx.plan.rig};
    for (int c = 0; c < int(ctx.plan.cameras.size()); ++c) {
      blobs.push_back(ctx.outputs("stereo", c).at(0));
    }
    if (o.temporal.fusion && ctx.instant > 0) {
      *fj.mutable_temporal() = ToTemporalSettings(o.temporal);
      blobs.push_back(ctx.previous_outputs().at(0));
      for (int t : {ctx.instant, ctx.instant - 1})
        for (const auto& frame : ctx.plan.frames[t]) blobs.push_back(frame);
    }
    if (o.silhouettes.fusion) {
      fj.set_hull(true);
      fj.set_carve_votes(o.silhouettes.carve_votes);
      fj.set_min_views(o.silhouettes.min_views);
      fj.set_hull_surface(o.silhouettes.hull_surface);
      AddMaskBlobs(ctx, &blobs);
      if (o.silhouettes.photo_carve) {
        fj.set_photo_carve(true);
        for (const auto& frame : ctx.plan.frames[ctx.instant]) blobs.push_back(frame);
      }
    }
    SetJob(fj, std::move(blobs), job);
  };
  d.run = [](const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
    const auto fj = JobSettings<runtime::FusionJob>(job);
    RequireBlobs(job, blobs, 2);
    const std::string where = JobWhere(job);
    const fusion::VolumeGrid grid = FromVolume(fj.volume(), where);
    grid.CheckSlab(fj.k0(), fj.k1(), where);
    // Every slab job of an instant shares its decoded range images and tables: built
    // once for the process's workers (shared_fusion.h), keyed by everything in the job
    // but its planes, with all their threads (a worker that would wait builds part).
    const int build_threads = std::max(job.threads(), ProcessWorkerThreads());
    auto build = [&]() {
      const geometry::Rig rig = RigBlob(job, blobs, memo);
      fusion::FusionOptions options = FromFusionSettings(fj.fusion(), grid.voxel_size_mm, where);
      options.num_threads = build_threads;  // the tables; each slab runs on job.threads()
      const size_t n = rig.cameras.size();
      const size_t num_masks = fj.hull() ? n : 0;
      const size_t num_photo = fj.hull() && fj.photo_carve() ? n : 0;
      const size_t num_temporal = fj.has_temporal() ? 1 + 2 * n : 0;
      core::Require(blobs.size() == n + 1 + num_masks + num_photo + num_temporal, where,
                    "expected one stereo output per rig camera (" + std::to_string(n) + ")" +
                        (num_masks ? ", one mask each" : "") +
                        (num_photo ? ", one frame each for the photo hull" : "") +
                        (num_temporal ? ", the previous slab and two frames each" : "") + ", got " +
                        std::to_string(blobs.size() - 1) + " blobs after the rig");
      // Cameras in rig order, windows in the options' order.
      std::vector<std::vector<fusion::RangeImage>> per_camera(n);
      core::ParallelFor(0, int64_t(n), build_threads, [&](int64_t c0, int64_t c1) {
        for (int64_t c = c0; c < c1; ++c) {
          const size_t b = size_t(c) + 1;
          std::vector<stereo::MapCut> cuts;
          const stereo::StereoResult r = DecodeStereoRects(*blobs[b], BlobName(job, b), &cuts);
          core::Require(r.camera == rig.cameras[size_t(c)].model.id, BlobName(job, b),
                        "expected the stereo output of camera '" +
                            rig.cameras[size_t(c)].model.id + "', got '" + r.camera + "'");
          // Each map made the range image PrepareFusion would cut from the whole map,
          // from its rectangle (no whole map made: 5 MB each on Robovision).
          for (size_t k = 0; k < r.range_images.size(); ++k) {
            std::optional<fusion::RangeImage> image =
                CutRangeImage(rig.cameras[size_t(c)].model, r.range_images[k].depth_mm, cuts[k],
                              BlobName(job, b));
            if (image) per_camera[size_t(c)].push_back(std::move(*image));
          }
        }
      });
      std::vector<fusion::RangeImage> images;
      for (auto& v : per_camera)
        for (auto& ri : v) images.push_back(std::move(ri));
      fusion::HullFusionOptions hull_options;
      hull_options.fill_unseen = fj.hull_surface();
      // The hull with distances: built once for the process's workers (shared_hulls.h).
      std::shared_ptr<const silhouette::VisualHull> hull;
      if (fj.hull()) {
        const size_t first_mask = n + 1 + num_temporal;
        std::string key = "fusion hull\n" + std::to_string(job.threads()) + '\n' +
                          std::to_string(fj.carve_votes()) + ' ' + std::to_string(fj.min_views());
        for (size_t b = first_mask; b < first_mask + n; ++b)
          key += '\n' + job.blobs(int(b)).sha256();
        hull = SharedHull(key, [&] {
          return HullBlobs(job, blobs, first_mask, num_photo, rig, fj.carve_votes(), fj.min_views(),
                           true);
        });
      }
      std::shared_ptr<const silhouette::PhotoHull> photo_hull;
      if (num_photo) {
        const size_t first_frame = n + 1 + num_temporal + num_masks;
        const std::vector<cv::Mat> frames =
            FrameBlobs(job, blobs, first_frame, first_frame + n, io::ImageMode::kBgr8, memo);
        std::vector<geometry::TsaiCamera> cameras;
        for (const auto& rc : rig.cameras) cameras.push_back(rc.model);
        silhouette::PhotoHullOptions po;
        // Cells of two voxels: what decides a cell is a 5x5-pixel mean and a z-buffer of
        // 4x4-pixel cells, on Panoptic about a voxel across at the people (8.5 mm voxels
        // from the voxel budget, 2.2 mm pixels), and the carving's cost grows as the
        // cube of the cells' count a side. (Cells of one voxel: the same leave-one-out
        // IoU on Panoptic, 0.576.)
        po.cell_mm = 2.0 * grid.voxel_size_mm;
        po.num_threads = build_threads;
        const Eigen::Vector3d lo = grid.origin_mm;
        const Eigen::Vector3d hi =
            lo + Eigen::Vector3d(grid.nx, grid.ny, grid.nz) * grid.voxel_size_mm;
        auto carved = std::make_shared<silhouette::PhotoHull>(*hull, cameras, frames, lo, hi, po);
        const silhouette::PhotoHullStats& st = carved->stats();
        spdlog::debug(
            "{}: photo hull: {} of {} hull cells carved in {} sweep(s), {} of them by "
            "the opening ({} it removed kept for a silhouette)",
            where, st.carved_cells, st.hull_cells, st.sweeps, st.opened_cells, st.restored_cells);
        photo_hull = std::move(carved);
      }
      auto prepared = PrepareFusion(grid, std::move(images), options, std::move(hull), hull_options);
      prepared->photo_hull = std::move(photo_hull);
      if (fj.has_temporal()) {
        // What changed since the previous instant, per camera on its own pixel grid:
        // the temporal bounds' rule (stereo/temporal_bounds.h ChangedTiles) on plain
        // greys (no contrast mapping, no undistortion: the voxels are projected with the
        // lens).
        const TemporalUse use = FromTemporalSettings(fj.temporal(), where);
        const size_t first = n + 2;  // after the rig, the outputs and the slab
        const std::vector<cv::Mat> now =
            FrameBlobs(job, blobs, first, first + n, io::ImageMode::kUnchanged, memo);
        const std::vector<cv::Mat> before =
            FrameBlobs(job, blobs, first + n, first + 2 * n, io::ImageMode::kUnchanged, memo);
        prepared->change_views.resize(n);
        prepared->carry = use.carry;
        core::ParallelFor(0, int64_t(n), build_threads, [&](int64_t c0, int64_t c1) {
          for (int64_t c = c0; c < c1; ++c) {
            const auto& cam = rig.cameras[size_t(c)].model;
            auto grey = [&](const cv::Mat& image, size_t blob) {
              return stereo::GreyImage({cam, image}, stereo::StereoOptions{}, false,
                                       BlobName(job, blob));
            };
            prepared->change_views[size_t(c)] = {
                cam,
                stereo::ChangedTiles(grey(before[size_t(c)], first + n + size_t(c)),
                                     grey(now[size_t(c)], first + size_t(c)), use.bounds.tile_px,
                                     use.bounds.change_factor, use.bounds.change_floor_grey,
                                     BlobName(job, first + size_t(c))),
                use.bounds.tile_px};
            spdlog::debug("{}: camera {}: {} of {} tiles changed", where, cam.id,
                          cv::countNonZero(prepared->change_views[size_t(c)].changed_tiles),
                          prepared->change_views[size_t(c)].changed_tiles.total());
          }
        });
      }
      return prepared;
    };
    runtime::FusionJob shared = fj;
    shared.clear_k0();
    shared.clear_k1();
    // Not the threads: the tables and every slab are the same bits on any number.
    std::string key = "fusion\n" + shared.SerializeAsString();
    // Every blob but the previous instant's slab, which is this slab's own. The blobs
    // are the rig, n outputs, the slab, 2 n frames and, with the hull, n masks.
    int previous_slab = -1;
    if (fj.has_temporal()) {
      const int per_camera = 3 + (fj.hull() ? 1 : 0) + (fj.hull() && fj.photo_carve() ? 1 : 0);
      const int cameras = (job.blobs_size() - 2) / per_camera;
      core::Require(cameras >= 1 && job.blobs_size() == 2 + per_camera * cameras, where,
                    "expected the rig, then per camera a stereo output, the previous slab, "
                    "two frames per camera" +
                        std::string(fj.hull() ? " and a mask per camera" : "") +
                        std::string(fj.hull() && fj.photo_carve() ? " and a frame" : "") +
                        ", got " + std::to_string(job.blobs_size()) + " blobs");
      previous_slab = 1 + cameras;
    }
    for (int b = 0; b < job.blobs_size(); ++b)
      if (b != previous_slab) key += '\n' + job.blobs(b).sha256();
    // A worker's job (one with a memo) shares the process's; its slab buffers stay in
    // its memo for its next slab of the size.
    const std::shared_ptr<const PreparedFusion> prepared =
        memo ? SharedPreparedFusion(key, build) : std::shared_ptr<const PreparedFusion>(build());
    fusion::Slab own_buffer;
    fusion::Slab* buffer =
        memo ? memo->Get<fusion::Slab>("slab buffer", [] { return std::make_unique<fusion::Slab>(); })
             : &own_buffer;
    std::optional<fusion::Slab> previous;
    fusion::TemporalCarryStats carried;
    if (fj.has_temporal()) {
      previous = fusion::DecodeSlab(*blobs[size_t(previous_slab)], BlobName(job, size_t(previous_slab)));
    }
    runtime::Output out;
    out.set_name(kSlabOutput);
    out.set_data(fusion::EncodeSlab(
        FuseSlab(*prepared, buffer, fj.k0(), fj.k1(), previous ? &*previous : nullptr, where,
                 &carried, job.threads())));
    if (previous) {
      spdlog::debug("{}: {} of {} blocks still, {} voxels carried from the previous instant",
                    where, carried.still_blocks, carried.blocks, carried.voxels_carried);
    }
    return std::vector<runtime::Output>{out};
  };
  d.store = [](const StoreContext& ctx, const runtime::JobResult& r) {
    const std::string& bytes = OutputBytes(r, kSlabOutput, ctx.where);
    auto slab = std::make_shared<const fusion::Slab>(fusion::DecodeSlab(bytes, ctx.where));
    const SessionOptions& o = ctx.plan.options;
    core::Require(slab->k0 == SlabPlanes(o.grid, o.slab_planes, ctx.part).first &&
                      slab->nx == o.grid.nx && slab->ny == o.grid.ny,
                  ctx.where, "is not the slab asked for");
    return StoredResult{{ctx.blobs->Keep(bytes, kSlabOutput)}, std::move(slab)};
  };
  return d;
}

// ---- surface (the master's) -------------------------------------------------------------

StageDescriptor SurfaceStage() {
  StageDescriptor d = Descriptor("surface", {"fusion"}, OnePart);
  d.consumes_inputs = true;  // the slabs are in the mesh
  d.start_on_master = [](const MasterStageContext& ctx) -> std::unique_ptr<MasterStageRun> {
    const SessionOptions& o = ctx.plan.options;
    return std::make_unique<SurfaceStream>(o.grid, ctx.plan.num_slabs, ctx.blobs, ctx.dir, o.smooth,
                                           ctx.finished);
  };
  return d;
}

// ---- decimate ---------------------------------------------------------------------------

StageDescriptor DecimateStage() {
  StageDescriptor d = Descriptor("decimate", {"surface"}, OnePart);
  d.borrows_idle_threads = true;
  d.make_job = [](const JobContext& ctx, runtime::Job* job) {
    const mesh::DecimationOptions o = DecimationFor(ctx.plan.options);
    runtime::DecimateJob dj;
    dj.set_ratio(o.target_ratio);
    dj.set_speck_area_fraction(o.speck_area_fraction);
    dj.set_speck_diagonal_mm(o.speck_diagonal_mm);
    dj.set_speck_gap_mm(o.speck_gap_mm);
    SetJob(dj, {ctx.outputs("surface", 0).at(0)}, job);
  };
  d.run = [](const runtime::Job& job, const JobBlobs& blobs, JobMemo*) {
    const auto dj = JobSettings<runtime::DecimateJob>(job);
    RequireBlobs(job, blobs, 1);
    mesh::DecimationOptions options;
    options.target_ratio = dj.ratio();
    options.speck_area_fraction = dj.speck_area_fraction();
    options.speck_diagonal_mm = dj.speck_diagonal_mm();
    options.speck_gap_mm = dj.speck_gap_mm();
    options.num_threads = job.threads();  // the regions of a large surface
    mesh::DecimationSummary summary;
    std::vector<runtime::Output> outputs(2);
    outputs[0].set_name(kDecimatedPly);
    if (options.target_ratio == 1.0) {
      // Ratio 1 keeps the surface as extracted (specks too): its blob is already
      // EncodeMeshPly bytes.
      outputs[0].set_data(*blobs[0]);
      summary.triangles_in = summary.triangles_out =
          int64_t(io::ParsePly(*blobs[0], BlobName(job, 0)).faces.size());
    } else {
      outputs[0].set_data(EncodeMeshPly(
          pipeline::Decimate(io::ParsePly(*blobs[0], BlobName(job, 0)), options, &summary)));
    }
    // The summary without its time, so that the file is the same on every run.
    summary.seconds = 0;
    outputs[1].set_name(kDecimationJson);
    outputs[1].set_data(DecimationSummaryJson(summary) + "\n");
    return outputs;
  };
  d.store = [](const StoreContext& ctx, const runtime::JobResult& r) {
    const std::string& bytes = OutputBytes(r, kDecimatedPly, ctx.where);
    io::ParsePly(bytes, ctx.where);
    const std::string& summary = OutputBytes(r, kDecimationJson, ctx.where);
    core::Require(core::Json::accept(summary), ctx.where,
                  std::string(kDecimationJson) + " is not JSON");
    fs::create_directories(ctx.dir);
    io::WriteFileAtomically(ctx.dir / kDecimationJson, summary);
    return StoredResult{
        {ctx.blobs->Keep(bytes, kDecimatedPly),
         ctx.blobs->KeepWritten(summary, kDecimationJson, ctx.dir / kDecimationJson)},
        nullptr};
  };
  return d;
}

// ---- texture ----------------------------------------------------------------------------

StageDescriptor TextureStage() {
  StageDescriptor d = Descriptor("texture", {"decimate"}, OnePart);
  d.borrows_idle_threads = true;
  d.make_job = [](const JobContext& ctx, runtime::Job* job) {
    // The rig, the decimated mesh, every camera's frame.
    std::vector<runtime::BlobRef> blobs = {ctx.plan.rig, ctx.outputs("decimate", 0).at(0)};
    const auto& frames = ctx.plan.frames[ctx.instant];
    blobs.insert(blobs.end(), frames.begin(), frames.end());
    runtime::TextureJob tj;
    tj.set_atlas(ctx.plan.options.texture);
    SetJob(tj, std::move(blobs), job);
  };
  d.run = [](const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
    const auto tj = JobSettings<runtime::TextureJob>(job);
    RequireBlobs(job, blobs, 2);
    const geometry::Rig rig = RigBlob(job, blobs, memo);
    io::Mesh decimated = io::ParsePly(*blobs[1], BlobName(job, 1));
    core::Require(blobs.size() == rig.cameras.size() + 2, JobWhere(job),
                  "expected one frame per rig camera (" + std::to_string(rig.cameras.size()) +
                      "), got " + std::to_string(blobs.size() - 2));
    const std::vector<cv::Mat> frames = FrameBlobs(job, blobs, 2, blobs.size(), io::ImageMode::kBgr8, memo);
    std::vector<mesh::TextureView> views;
    for (size_t c = 0; c < rig.cameras.size(); ++c)
      views.push_back({rig.cameras[c].model, frames[c], BlobName(job, c + 2)});
    mesh::TextureOptions options;
    options.num_threads = job.threads();
    const TextureResult textured = Texture(std::move(decimated), views, options, tj.atlas());
    std::vector<runtime::Output> outputs(1);
    outputs[0].set_name(kDecimatedPly);
    outputs[0].set_data(EncodeMeshPly(textured.coloured));
    if (textured.atlas) {
      for (NamedFile& f : TexturedFiles(*textured.atlas, job.threads())) {
        runtime::Output& o = outputs.emplace_back();
        o.set_name(std::move(f.name));
        o.set_data(std::move(f.bytes));
      }
    }
    return outputs;
  };
  d.store = [](const StoreContext& ctx, const runtime::JobResult& r) {
    fs::create_directories(ctx.dir);
    io::ParsePly(OutputBytes(r, kDecimatedPly, ctx.where), ctx.where);
    std::vector<std::string> names = {kDecimatedPly};
    if (ctx.plan.options.texture) {
      names.insert(names.end(), {kTexturedObj, kTexturedMtl, kTexturedPng, kTexturedGlb});
    }
    StoredResult stored;
    for (const std::string& name : names) {
      const std::string& bytes = OutputBytes(r, name, ctx.where);
      io::WriteFileAtomically(ctx.dir / name, bytes);
      stored.outputs.push_back(ctx.blobs->KeepWritten(bytes, name, ctx.dir / name));
    }
    return stored;
  };
  return d;
}

// ---- noop -------------------------------------------------------------------------------

StageDescriptor NoopStage() {
  StageDescriptor d = Descriptor("noop", {}, [](const SessionPlan& plan) {
    std::vector<std::string> parts;
    for (int i = 0; i < plan.spec.noop_jobs(); ++i) parts.push_back(std::to_string(i));
    return parts;
  });
  d.send_ahead = true;
  d.make_job = [](const JobContext&, runtime::Job*) {};
  d.run = [](const runtime::Job&, const JobBlobs&, JobMemo*) {
    return std::vector<runtime::Output>{};
  };
  d.store = [](const StoreContext&, const runtime::JobResult&) { return StoredResult{}; };
  return d;
}

}  // namespace

std::string EncodeStereoOutput(const stereo::StereoResult& result) {
  runtime::StereoOutput out;
  out.set_camera(result.camera);
  out.set_num_levels(result.num_levels);
  for (const auto& r : result.range_images) {
    auto* ri = out.add_range_images();
    ri->set_window_px(r.window_px);
    // Only the rectangle of the depths travels: outside it both maps are 0, and a
    // clipped camera's depths cover a part of its frame (Robovision: the object on
    // the table), so the fusion jobs and the store get a fraction of the bytes.
    // (Maps of other sizes or types, an empty reliability, travel whole as before.)
    if (r.depth_mm.type() == CV_32FC1 && r.reliability.type() == CV_32FC1 &&
        r.depth_mm.size() == r.reliability.size() && !r.depth_mm.empty()) {
      const cv::Rect rect = NonZeroRect(r.depth_mm, r.reliability);
      ri->set_full_rows(r.depth_mm.rows);
      ri->set_full_cols(r.depth_mm.cols);
      ri->set_x0(rect.x);
      ri->set_y0(rect.y);
      *ri->mutable_depth_mm() = EncodeFloatImage(r.depth_mm(rect));
      *ri->mutable_reliability() = EncodeFloatImage(r.reliability(rect));
    } else {
      *ri->mutable_depth_mm() = EncodeFloatImage(r.depth_mm);
      *ri->mutable_reliability() = EncodeFloatImage(r.reliability);
    }
    ri->set_density(r.density);
  }
  std::string bytes;
  out.SerializeToString(&bytes);
  return bytes;
}

stereo::StereoResult DecodeStereoOutput(const std::string& bytes, const std::string& where) {
  std::vector<stereo::MapCut> cuts;
  stereo::StereoResult result = DecodeStereoRects(bytes, where, &cuts);
  for (size_t k = 0; k < result.range_images.size(); ++k) {
    stereo::RangeImage& r = result.range_images[k];
    const stereo::MapCut& cut = cuts[k];
    if (cut.at == cv::Point(0, 0) && r.depth_mm.size() == cut.full &&
        (r.reliability.empty() || r.reliability.size() == cut.full)) {
      continue;  // whole
    }
    r.depth_mm = PlaceRect(cut, r.depth_mm);
    r.reliability = PlaceRect(cut, r.reliability);
  }
  return result;
}

stereo::StereoResult DecodeStereoRects(const std::string& bytes, const std::string& where,
                                       std::vector<stereo::MapCut>* cuts) {
  cuts->clear();
  runtime::StereoOutput out;
  core::Require(out.ParseFromString(bytes), where, "not a stereo output (StereoOutput protobuf)");
  stereo::StereoResult result;
  result.camera = out.camera();
  result.num_levels = out.num_levels();
  for (const auto& ri : out.range_images()) {
    stereo::RangeImage r;
    r.window_px = ri.window_px();
    r.depth_mm = DecodeFloatImage(ri.depth_mm(), where + ": depth_mm");
    r.reliability = DecodeFloatImage(ri.reliability(), where + ": reliability");
    if (ri.has_full_rows() || ri.has_full_cols() || ri.has_x0() || ri.has_y0()) {
      cuts->push_back(CheckedCut(ri, r.depth_mm, where + ": depth_mm"));
      CheckedCut(ri, r.reliability, where + ": reliability");
    } else {
      cuts->push_back({cv::Point(0, 0), r.depth_mm.size()});
    }
    r.density = ri.density();
    result.range_images.push_back(std::move(r));
  }
  core::Require(!result.range_images.empty(), where, "stereo output without a range image");
  return result;
}

std::shared_ptr<const StageSet> DefaultStages() {
  static const auto stages =
      std::make_shared<const StageSet>(StageSet{{MaskStage(), StereoStage(), FusionStage(), SurfaceStage(),
                                                 DecimateStage(), TextureStage(), NoopStage()}});
  return stages;
}

int StageSet::Find(const std::string& name) const {
  for (size_t i = 0; i < stages.size(); ++i) {
    if (stages[i].name == name) return int(i);
  }
  return -1;
}

std::vector<runtime::Output> RunJob(const StageSet& stages, const runtime::Job& job,
                                    const JobBlobs& blobs, JobMemo* memo) {
  const int s = stages.Find(job.stage());
  core::Require(s >= 0 && stages.stages[s].run, JobWhere(job),
                "names no stage a worker runs ('" + job.stage().substr(0, 100) + "')");
  return stages.stages[s].run(job, blobs, memo);
}

const std::string& OutputBytes(const runtime::JobResult& result, const std::string& name,
                               const std::string& where) {
  for (const auto& o : result.outputs()) {
    if (o.name() == name) return o.data();
  }
  throw core::InputError(where, "lacks output '" + name + "'");
}

}  // namespace dome::pipeline
