#include "pipeline/surface_stream.h"

#include <spdlog/spdlog.h>

#include <chrono>

#include "core/error.h"
#include "fusion/volume.h"
#include "io/file_util.h"
#include "pipeline/stages.h"

namespace dome::pipeline {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

SurfaceStream::SurfaceStream(const fusion::VolumeGrid& grid, int num_slabs, BlobAccess* blobs,
                             const fs::path& dir, const mesh::SmoothOptions& smooth,
                             std::function<void()> finished)
    : grid_(grid),
      smooth_(smooth),
      blobs_(blobs),
      dir_(dir),
      finished_callback_(std::move(finished)),
      slabs_(size_t(std::max(num_slabs, 0))),
      decoded_(slabs_.size()),
      thread_([this] { Run(); }) {}

SurfaceStream::~SurfaceStream() {
  Abort();
  thread_.join();
}

void SurfaceStream::Feed(int index, const std::string& sha256,
                         std::shared_ptr<const fusion::Slab> decoded) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (index < 0 || index >= int(slabs_.size()) || !slabs_[index].empty()) return;
  slabs_[index] = sha256;
  if (decoded && index >= next_ && index < next_ + kDecodedAhead) {
    decoded_[index] = std::move(decoded);
  }
  fed_cv_.notify_all();
}

void SurfaceStream::Feed(int index, const std::vector<runtime::BlobRef>& outputs,
                         std::shared_ptr<const void> decoded) {
  DOME_CHECK(!outputs.empty(), "a slab job has its output");
  Feed(index, outputs[0].sha256(), std::static_pointer_cast<const fusion::Slab>(decoded));
}

bool SurfaceStream::Fed(int index) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index >= 0 && index < int(slabs_.size()) && !slabs_[index].empty();
}

void SurfaceStream::Abort() {
  std::lock_guard<std::mutex> lock(mutex_);
  abort_ = true;
  fed_cv_.notify_all();
}

bool SurfaceStream::Finished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return finished_;
}

std::vector<runtime::BlobRef> SurfaceStream::Result() {
  std::lock_guard<std::mutex> lock(mutex_);
  DOME_CHECK(finished_, "the surface stream has not finished");
  if (!mesh_) throw core::InputError("instant " + dir_.filename().string(), error_);
  return {*mesh_};
}

double SurfaceStream::busy_seconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return busy_s_;
}

// Blocks until slab `index` is fed (waiting is not busy time).
void SurfaceStream::WaitForSlab(int index) {
  std::unique_lock<std::mutex> lock(mutex_);
  next_ = index;
  fed_cv_.wait(lock, [&] { return abort_ || !slabs_[index].empty(); });
  core::Require(!abort_, "slab " + std::to_string(index),
                "not stitched: the surface stage was stopped");
}

// Slab `index`, fed: the decoded one kept for it, else read from the store and decoded.
std::shared_ptr<const fusion::Slab> SurfaceStream::TakeSlab(int index) {
  std::string sha;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (decoded_[index]) return std::move(decoded_[index]);
    sha = slabs_[index];
  }
  auto bytes = blobs_->Read(sha);
  core::Require(bytes.has_value(), "slab " + std::to_string(index),
                "is not in the blob store (" + sha + ")");
  return std::make_shared<const fusion::Slab>(
      fusion::DecodeSlab(*bytes, "slab " + std::to_string(index)));
}

void SurfaceStream::Run() {
  auto since = Clock::now();
  // Adds the time since `since` and restarts it.
  auto add_busy = [&] {
    const auto now = Clock::now();
    std::lock_guard<std::mutex> lock(mutex_);
    busy_s_ += std::chrono::duration<double>(now - since).count();
    since = now;
  };
  std::optional<runtime::BlobRef> mesh;
  std::string error;
  try {
    const io::Mesh surface = Surface(
        grid_, int(slabs_.size()),
        [&](int index) {
          add_busy();
          WaitForSlab(index);
          since = Clock::now();  // the wait was not work
          return TakeSlab(index);
        },
        smooth_);
    if (surface.vertices.empty()) {
      // Not an error (an instant may be empty), but usually a volume that misses the
      // scene: say so where the user looks.
      const Eigen::Vector3d hi =
          grid_.origin_mm + Eigen::Vector3d(grid_.nx, grid_.ny, grid_.nz) * grid_.voxel_size_mm;
      spdlog::warn(
          "{}: the surface is empty: no camera saw a surface inside the volume [{:.0f} {:.0f} "
          "{:.0f}] .. [{:.0f} {:.0f} {:.0f}] mm; it may miss the scene (dome run --box)",
          (dir_ / kMeshPly).string(), grid_.origin_mm.x(), grid_.origin_mm.y(), grid_.origin_mm.z(),
          hi.x(), hi.y(), hi.z());
    }
    const std::string ply = EncodeMeshPly(surface);
    fs::create_directories(dir_);
    io::WriteFileAtomically(dir_ / kMeshPly, ply);
    mesh = blobs_->KeepWritten(ply, kMeshPly, dir_ / kMeshPly);
  } catch (const std::exception& e) {
    error = e.what();
  }
  add_busy();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    mesh_ = std::move(mesh);
    error_ = error.empty() && !mesh_ ? "no mesh" : error;
    finished_ = true;
  }
  if (finished_callback_) finished_callback_();
}

}  // namespace dome::pipeline
