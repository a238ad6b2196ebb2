#include "scheduler/surface_stream.h"

#include <chrono>

#include "core/error.h"
#include "io/file_util.h"
#include "pipeline/stages.h"

namespace dome::scheduler {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

SurfaceStream::SurfaceStream(const fusion::VolumeGrid& grid, int num_slabs, BlobStore* store,
                             const fs::path& dir, const fs::path& blob_dir)
    : grid_(grid),
      store_(store),
      dir_(dir),
      blob_dir_(blob_dir),
      slabs_(size_t(std::max(num_slabs, 0))),
      thread_([this] { Run(); }) {}

SurfaceStream::~SurfaceStream() {
  Abort();
  thread_.join();
}

void SurfaceStream::Feed(int index, const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (index < 0 || index >= int(slabs_.size()) || !slabs_[index].empty()) return;
  slabs_[index] = sha256;
  fed_cv_.notify_all();
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

runtime::BlobRef SurfaceStream::Result() {
  std::lock_guard<std::mutex> lock(mutex_);
  DOME_CHECK(finished_, "the surface stream has not finished");
  if (!mesh_) throw core::InputError("instant " + dir_.filename().string(), error_);
  return *mesh_;
}

double SurfaceStream::busy_seconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return busy_s_;
}

// Blocks until slab `index` is fed (its wait is not busy time), then reads it.
std::string SurfaceStream::WaitForSlab(int index) {
  std::string sha;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    fed_cv_.wait(lock, [&] { return abort_ || !slabs_[index].empty(); });
    core::Require(!abort_, "slab " + std::to_string(index),
                  "not stitched: the surface stage was stopped");
    sha = slabs_[index];
  }
  auto bytes = store_->Read(sha);
  core::Require(bytes.has_value(), "slab " + std::to_string(index),
                "is not in the blob store (" + sha + ")");
  return std::move(*bytes);
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
    const io::Mesh surface = pipeline::ExtractSurface(grid_, int(slabs_.size()), [&](int index) {
      add_busy();
      std::string bytes = WaitForSlab(index);
      since = Clock::now();  // the wait was not work
      return bytes;
    });
    const std::string ply = pipeline::EncodeMeshPly(surface);
    fs::create_directories(dir_);
    io::WriteFileAtomically(dir_ / "mesh.ply", ply);
    mesh = store_->AddBytes(blob_dir_, ply, "mesh.ply");
    mesh->set_name("mesh.ply");
  } catch (const std::exception& e) {
    error = e.what();
  }
  add_busy();
  std::lock_guard<std::mutex> lock(mutex_);
  mesh_ = std::move(mesh);
  error_ = error.empty() && !mesh_ ? "no mesh" : error;
  finished_ = true;
}

}  // namespace dome::scheduler
