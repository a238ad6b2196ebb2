#include "pipeline/stages.h"

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <random>

#include "core/error.h"
#include "fusion/integrate.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "mesh/decimate.h"
#include "mesh/gltf.h"
#include "mesh/marching_cubes.h"
#include "mesh/texture.h"
#include "pipeline/coarse_to_fine.h"
#include "pipeline/session.h"
#include "schema/rig_json.h"
#include "stereo/take_stereo.h"

namespace dome::pipeline {

// The inputs of one instant's fusion, decoded and tabulated: what every slab job of
// that instant shares.
struct PreparedFusion {
  std::vector<fusion::RangeImage> images;  // referenced by `integrator`
  std::unique_ptr<fusion::Integrator> integrator;
  fusion::Slab slab;  // the last slab's buffers, reused by the next slab of this size
};

namespace {

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

std::string BlobName(const runtime::Job& job, size_t i) {
  return "job " + job.id() + " blob " +
         (i < size_t(job.blobs_size()) ? job.blobs(int(i)).name() : std::to_string(i));
}

void RequireBlobs(const runtime::Job& job, const JobBlobs& blobs, size_t n) {
  core::Require(
      blobs.size() == size_t(job.blobs_size()) && blobs.size() >= n, "job " + job.id(),
      "expected " + std::to_string(n) + " input blobs, got " + std::to_string(blobs.size()));
}

geometry::Rig RigBlob(const runtime::Job& job, const JobBlobs& blobs) {
  return schema::ParseRigJson(*blobs[0], BlobName(job, 0));
}

cv::Mat FrameBlob(const runtime::Job& job, const JobBlobs& blobs, size_t i, io::ImageMode mode) {
  return io::DecodeImage(*blobs[i], mode, BlobName(job, i));
}

std::vector<runtime::Output> RunStereo(const runtime::Job& job, const JobBlobs& blobs) {
  const runtime::StereoJob& sj = job.stereo();
  RequireBlobs(job, blobs, 2 + sj.neighbours_size());
  const geometry::Rig rig = RigBlob(job, blobs);
  stereo::TakeStereoOptions options = stereo::FromStereoSettings(sj.stereo(), "job " + job.id());
  options.stereo.num_threads = job.threads();
  auto camera = [&](const std::string& id) {
    const int k = rig.Find(id);
    core::Require(k >= 0, "job " + job.id(), "camera '" + id + "' is not in the rig");
    return rig.cameras[k].model;
  };
  stereo::StereoInput input;
  input.reference.camera = camera(sj.camera());
  input.reference.image = FrameBlob(job, blobs, 1, io::ImageMode::kUnchanged);
  for (int n = 0; n < sj.neighbours_size(); ++n) {
    stereo::StereoView v;
    v.camera = camera(sj.neighbours(n));
    v.image = FrameBlob(job, blobs, 2 + n, io::ImageMode::kUnchanged);
    input.neighbours.push_back(std::move(v));
  }
  stereo::StereoResult result;
  if (options.coarse_to_fine) {
    const std::string where = "job " + job.id();
    const CoarseToFineOptions c2f = FromCoarseToFineSettings(*options.coarse_to_fine, where);
    ClipDepthRange(*options.coarse_to_fine, input.reference.camera, where, &options.stereo);
    result = ComputeDepthCoarseToFine(input, options.stereo, c2f);
  } else {
    result = stereo::ComputeDepth(input, options.stereo);
  }
  result.camera = sj.camera();
  std::vector<runtime::Output> outputs(1);
  outputs[0].set_name(kStereoOutput);
  outputs[0].set_data(EncodeStereoOutput(result));
  for (stereo::StereoFile& f : stereo::EncodeStereoFiles(result, sj.write_previews())) {
    runtime::Output& o = outputs.emplace_back();
    o.set_name(std::move(f.path));
    o.set_data(std::move(f.bytes));
  }
  return outputs;
}

// Identifies what PreparedFusion is built from: everything in the job but its planes.
std::string FusionKey(const runtime::Job& job) {
  const runtime::FusionJob& fj = job.fusion();
  std::string key = fj.volume().SerializeAsString();
  key += '\0' + fj.fusion().SerializeAsString() + '\0' + std::to_string(job.threads());
  for (const auto& b : job.blobs()) key += '\0' + b.sha256();
  return key;
}

std::unique_ptr<PreparedFusion> PrepareFusion(const runtime::Job& job, const JobBlobs& blobs) {
  const runtime::FusionJob& fj = job.fusion();
  const geometry::Rig rig = RigBlob(job, blobs);
  const std::string where = "job " + job.id();
  const fusion::VolumeGrid grid = FromVolume(fj.volume(), where);
  fusion::FusionOptions options = FromFusionSettings(fj.fusion(), grid.voxel_size_mm, where);
  options.num_threads = job.threads();
  core::Require(blobs.size() == rig.cameras.size() + 1, where,
                "expected one stereo output per rig camera (" + std::to_string(rig.cameras.size()) +
                    "), got " + std::to_string(blobs.size() - 1));
  auto prepared = std::make_unique<PreparedFusion>();
  // Cameras in rig order, windows in the options' order: the accumulation order is
  // fixed, so every run gives the same bits.
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    const stereo::StereoResult r = DecodeStereoOutput(*blobs[c + 1], BlobName(job, c + 1));
    core::Require(r.camera == rig.cameras[c].model.id, BlobName(job, c + 1),
                  "expected the stereo output of camera '" + rig.cameras[c].model.id + "', got '" +
                      r.camera + "'");
    for (const auto& ri : r.range_images) {
      fusion::RangeImage image;
      image.camera = rig.cameras[c].model;
      image.depth_mm = ri.depth_mm;
      image.where = BlobName(job, c + 1);
      prepared->images.push_back(std::move(image));
    }
  }
  prepared->integrator = std::make_unique<fusion::Integrator>(grid, prepared->images, options);
  return prepared;
}

std::vector<runtime::Output> RunFusion(const runtime::Job& job, const JobBlobs& blobs,
                                       JobMemo* memo) {
  const runtime::FusionJob& fj = job.fusion();
  RequireBlobs(job, blobs, 2);
  FromVolume(fj.volume(), "job " + job.id()).CheckSlab(fj.k0(), fj.k1(), "job " + job.id());
  std::unique_ptr<PreparedFusion> own;
  PreparedFusion* prepared = nullptr;
  if (memo) {
    prepared = memo->Fusion(FusionKey(job), [&] { return PrepareFusion(job, blobs); });
  } else {
    own = PrepareFusion(job, blobs);
    prepared = own.get();
  }
  prepared->integrator->IntegrateSlab(fj.k0(), fj.k1(), &prepared->slab);
  runtime::Output out;
  out.set_name(kSlabOutput);
  out.set_data(fusion::EncodeSlab(prepared->slab));
  return {out};
}

std::vector<runtime::Output> RunDecimate(const runtime::Job& job, const JobBlobs& blobs) {
  RequireBlobs(job, blobs, 1);
  mesh::DecimationOptions options;
  options.target_ratio = job.decimate().ratio();
  options.Check();
  runtime::Output out;
  out.set_name(kDecimatedOutput);
  if (options.target_ratio == 1.0) {
    // Ratio 1 keeps the surface as extracted (EncodeMeshPly bytes, as this blob is).
    out.set_data(*blobs[0]);
    return {out};
  }
  const io::Mesh surface = io::ParsePly(*blobs[0], BlobName(job, 0));
  out.set_data(EncodeMeshPly(mesh::Decimate(surface, options)));
  return {out};
}

std::vector<runtime::Output> RunTexture(const runtime::Job& job, const JobBlobs& blobs) {
  RequireBlobs(job, blobs, 2);
  const geometry::Rig rig = RigBlob(job, blobs);
  io::Mesh decimated = io::ParsePly(*blobs[1], BlobName(job, 1));
  core::Require(blobs.size() == rig.cameras.size() + 2, "job " + job.id(),
                "expected one frame per rig camera (" + std::to_string(rig.cameras.size()) +
                    "), got " + std::to_string(blobs.size() - 2));
  std::vector<mesh::TextureView> views;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    mesh::TextureView v;
    v.camera = rig.cameras[c].model;
    v.where = BlobName(job, c + 2);
    v.image = FrameBlob(job, blobs, c + 2, io::ImageMode::kBgr8);
    views.push_back(std::move(v));
  }
  mesh::TextureOptions options;
  options.num_threads = job.threads();
  mesh::ColorVertices(&decimated, views, options);
  std::vector<runtime::Output> outputs(1);
  outputs[0].set_name(kDecimatedOutput);
  outputs[0].set_data(EncodeMeshPly(decimated));
  if (job.texture().atlas()) {
    // WriteTexturedObj writes three files that name each other; write them to a
    // private folder and return their bytes.
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("dome_texture_" + std::to_string(::getpid()) +
                                                      "_" + std::to_string(std::random_device{}()));
    fs::create_directories(dir);
    try {
      const mesh::TexturedMesh textured = mesh::BuildTextureAtlas(decimated, views, options);
      mesh::WriteTexturedObj(dir / kTexturedObj, textured);
      for (const char* name : {kTexturedObj, kTexturedMtl, kTexturedPng}) {
        runtime::Output o;
        o.set_name(name);
        o.set_data(io::ReadFileBytes(dir / name));
        outputs.push_back(std::move(o));
      }
      runtime::Output glb;
      glb.set_name(kTexturedGlb);
      glb.set_data(mesh::EncodeGlb(textured));
      outputs.push_back(std::move(glb));
    } catch (...) {
      std::error_code ec;
      fs::remove_all(dir, ec);
      throw;
    }
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  return outputs;
}

}  // namespace

std::string EncodeMeshPly(const io::Mesh& mesh) {
  return io::EncodePly(mesh, {io::PlyFormat::kBinaryLittleEndian, {"units mm"}});
}

std::string EncodeStereoOutput(const stereo::StereoResult& result) {
  runtime::StereoOutput out;
  out.set_camera(result.camera);
  out.set_num_levels(result.num_levels);
  for (const auto& r : result.range_images) {
    auto* ri = out.add_range_images();
    ri->set_window_px(r.window_px);
    *ri->mutable_depth_mm() = EncodeFloatImage(r.depth_mm);
    *ri->mutable_reliability() = EncodeFloatImage(r.reliability);
    ri->set_density(r.density);
  }
  std::string bytes;
  out.SerializeToString(&bytes);
  return bytes;
}

stereo::StereoResult DecodeStereoOutput(const std::string& bytes, const std::string& where) {
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
    r.density = ri.density();
    result.range_images.push_back(std::move(r));
  }
  core::Require(!result.range_images.empty(), where, "stereo output without a range image");
  return result;
}

io::Mesh ExtractSurface(const fusion::VolumeGrid& grid, int num_slabs,
                        const std::function<std::string(int)>& slab) {
  return ExtractSurfaceFromSlabs(grid, num_slabs, [&](int s) {
    return std::make_shared<const fusion::Slab>(
        fusion::DecodeSlab(slab(s), "slab " + std::to_string(s)));
  });
}

io::Mesh ExtractSurfaceFromSlabs(
    const fusion::VolumeGrid& grid, int num_slabs,
    const std::function<std::shared_ptr<const fusion::Slab>(int)>& slab) {
  mesh::StreamingMarchingCubes mc(grid);
  for (int s = 0; s < num_slabs; ++s) mc.AddSlab(*slab(s));
  core::Require(mc.next_plane() == grid.nz, "surface",
                "slabs cover planes 0.." + std::to_string(mc.next_plane()) + ", expected " +
                    std::to_string(grid.nz));
  return mc.Finish();
}

JobMemo::JobMemo() = default;
JobMemo::~JobMemo() = default;

PreparedFusion* JobMemo::Fusion(const std::string& key,
                                const std::function<std::unique_ptr<PreparedFusion>()>& build) {
  if (!fusion_ || fusion_key_ != key) {
    // Drop the old instant's tables before building the new ones: one set in memory.
    fusion_.reset();
    fusion_key_.clear();
    fusion_ = build();
    fusion_key_ = key;
    ++fusion_preparations_;
  }
  return fusion_.get();
}

std::vector<runtime::Output> RunJob(const runtime::Job& job, const JobBlobs& blobs, JobMemo* memo) {
  switch (job.kind_case()) {
    case runtime::Job::kStereo:
      return RunStereo(job, blobs);
    case runtime::Job::kFusion:
      return RunFusion(job, blobs, memo);
    case runtime::Job::kDecimate:
      return RunDecimate(job, blobs);
    case runtime::Job::kTexture:
      return RunTexture(job, blobs);
    case runtime::Job::kNoop:
      return {};
    default:
      throw core::InputError("job " + job.id(), "has no known kind");
  }
}

}  // namespace dome::pipeline
