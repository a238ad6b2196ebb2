#include "pipeline/surface_stream.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "core/error.h"
#include "fusion/volume.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "mesh/smooth.h"
#include "net/content_hash.h"
#include "pipeline/stages.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {
namespace {

using namespace std::chrono_literals;

// The master's blobs, in memory: what a stream reads its slabs from and keeps its mesh in.
class MemoryBlobs : public BlobAccess {
 public:
  std::optional<std::string> Read(const std::string& sha256) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = blobs_.find(sha256);
    if (it == blobs_.end()) return std::nullopt;
    return it->second;
  }
  runtime::BlobRef Keep(const std::string& bytes, const std::string& name) override {
    runtime::BlobRef ref;
    ref.set_sha256(net::Sha256Hex(bytes));
    ref.set_size(bytes.size());
    ref.set_name(name);
    std::lock_guard<std::mutex> lock(mutex_);
    blobs_[ref.sha256()] = bytes;
    return ref;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::string> blobs_;
};

// The surface of the slabs, stitched in order without a stream.
io::Mesh OfflineSurface(const fusion::VolumeGrid& grid, const std::vector<std::string>& slabs,
                        const mesh::SmoothOptions& smooth = {}) {
  return Surface(
      grid, int(slabs.size()),
      [&](int k) {
        return std::make_shared<const fusion::Slab>(fusion::DecodeSlab(slabs[k], "slab"));
      },
      smooth);
}

// A 24^3 grid of 10 mm voxels holding the signed distance to a sphere of radius 70 mm
// at its centre, cut into slabs of 5 planes (the last one of 4).
struct Sphere {
  fusion::VolumeGrid grid;
  std::vector<std::string> slabs;  // encoded, plane order
  Sphere() {
    grid.origin_mm = Eigen::Vector3d(-120, -120, -120);
    grid.voxel_size_mm = 10;
    grid.nx = grid.ny = grid.nz = 24;
    for (int k0 = 0; k0 < grid.nz; k0 += 5) {
      fusion::Slab s;
      s.k0 = k0;
      s.k1 = std::min(grid.nz, k0 + 5);
      s.nx = grid.nx;
      s.ny = grid.ny;
      for (int k = s.k0; k < s.k1; ++k) {
        for (int j = 0; j < grid.ny; ++j) {
          for (int i = 0; i < grid.nx; ++i) {
            s.distance_mm.push_back(float(grid.VoxelCentreMm(i, j, k).norm() - 70.0));
            s.weight.push_back(1.0f);
          }
        }
      }
      slabs.push_back(fusion::EncodeSlab(s));
    }
  }
};

bool WaitFinished(const SurfaceStream& stream) {
  for (int i = 0; i < 3000 && !stream.Finished(); ++i) std::this_thread::sleep_for(10ms);
  return stream.Finished();
}

TEST(SurfaceStream, SlabsFedOutOfOrderGiveTheMeshOfTheWholeVolume) {
  testing::TempDir dir;
  const Sphere sphere;
  MemoryBlobs store;
  std::vector<runtime::BlobRef> refs;
  for (const auto& bytes : sphere.slabs) refs.push_back(store.Keep(bytes, "slab"));
  // The offline extraction of the same slabs: the stream must write the same bytes.
  const std::string expected = EncodeMeshPly(OfflineSurface(sphere.grid, sphere.slabs));
  SurfaceStream stream(sphere.grid, int(refs.size()), &store, dir.path() / "t0");
  // Slab 0 last: nothing can be stitched before it, then everything at once.
  for (int k = int(refs.size()) - 1; k >= 1; --k) stream.Feed(k, refs[k].sha256());
  std::this_thread::sleep_for(50ms);
  EXPECT_FALSE(stream.Finished()) << "slab 0 has not come yet";
  EXPECT_FALSE(stream.Fed(0));
  stream.Feed(0, refs[0].sha256());
  EXPECT_TRUE(stream.Fed(0));
  ASSERT_TRUE(WaitFinished(stream));
  const runtime::BlobRef mesh = stream.Result().at(0);
  EXPECT_EQ(mesh.name(), "mesh.ply");
  const std::string written = io::ReadFileBytes(dir.path() / "t0" / "mesh.ply");
  EXPECT_TRUE(written == expected) << "the streamed mesh differs from the offline one";
  EXPECT_EQ(store.Read(mesh.sha256()).value_or(""), expected);
  // A sphere of radius 70 mm: every vertex within half a voxel of it.
  const io::Mesh parsed = io::ParsePly(written, "mesh.ply");
  ASSERT_GT(parsed.vertices.size(), 100u);
  for (const auto& v : parsed.vertices) EXPECT_NEAR(v.cast<double>().norm(), 70.0, 5.0);
  EXPECT_GE(stream.busy_seconds(), 0.0);
  EXPECT_LT(stream.busy_seconds(), 30.0);
}

TEST(SurfaceStream, SmoothsTheWholeSurfaceBeforeWritingIt) {
  testing::TempDir dir;
  const Sphere sphere;
  MemoryBlobs store;
  mesh::SmoothOptions smooth;
  smooth.iterations = 4;
  const std::string unsmoothed = EncodeMeshPly(OfflineSurface(sphere.grid, sphere.slabs));
  const io::Mesh expected = OfflineSurface(sphere.grid, sphere.slabs, smooth);
  SurfaceStream stream(sphere.grid, int(sphere.slabs.size()), &store, dir.path() / "t0", smooth);
  for (int k = 0; k < int(sphere.slabs.size()); ++k) {
    stream.Feed(k, store.Keep(sphere.slabs[k], "slab").sha256());
  }
  ASSERT_TRUE(WaitFinished(stream));
  stream.Result();
  const std::string written = io::ReadFileBytes(dir.path() / "t0" / "mesh.ply");
  EXPECT_TRUE(written == EncodeMeshPly(expected));
  EXPECT_FALSE(written == unsmoothed);
}

TEST(SurfaceStream, AbortEndsAStreamWaitingForSlabsWithAnError) {
  testing::TempDir dir;
  const Sphere sphere;
  MemoryBlobs store;
  SurfaceStream stream(sphere.grid, int(sphere.slabs.size()), &store, dir.path() / "t0");
  stream.Feed(0, store.Keep(sphere.slabs[0], "slab").sha256());
  stream.Abort();
  ASSERT_TRUE(WaitFinished(stream));
  testing::ExpectInputError([&] { stream.Result(); },
                            {"instant t0", "the surface stage was stopped"});
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "t0" / "mesh.ply"));
}

// The master completes a run when it says it has finished (MasterStageContext::finished):
// the call comes once, from the stream's thread, with Finished() already true, whether
// the stream made its mesh or was stopped.
TEST(SurfaceStream, SaysOnceThatItHasFinishedWhenItEnds) {
  testing::TempDir dir;
  const Sphere sphere;
  MemoryBlobs store;
  for (const bool stopped : {false, true}) {
    std::mutex mutex;
    std::condition_variable called_cv;
    int calls = 0;
    bool finished_when_called = false;
    std::unique_ptr<SurfaceStream> stream;
    stream = std::make_unique<SurfaceStream>(sphere.grid, int(sphere.slabs.size()), &store,
                                             dir.path() / (stopped ? "stopped" : "made"),
                                             mesh::SmoothOptions{}, [&] {
                                               std::lock_guard<std::mutex> lock(mutex);
                                               // The stream is made before its thread can end: it
                                               // waits for slabs.
                                               finished_when_called = stream->Finished();
                                               ++calls;
                                               called_cv.notify_all();
                                             });
    if (stopped) {
      stream->Abort();
    } else {
      for (int k = 0; k < int(sphere.slabs.size()); ++k) {
        stream->Feed(k, store.Keep(sphere.slabs[k], "slab").sha256());
      }
    }
    {
      std::unique_lock<std::mutex> lock(mutex);
      ASSERT_TRUE(called_cv.wait_for(lock, 30s, [&] { return calls > 0; }))
          << (stopped ? "stopped" : "made") << ": never said it had finished";
      EXPECT_TRUE(finished_when_called);
    }
    stream.reset();  // joins its thread: no later call
    EXPECT_EQ(calls, 1);
  }
}

TEST(SurfaceStream, ASlabMissingFromTheStoreFailsNamingIt) {
  testing::TempDir dir;
  const Sphere sphere;
  MemoryBlobs store;
  SurfaceStream stream(sphere.grid, int(sphere.slabs.size()), &store, dir.path() / "t0");
  stream.Feed(0, std::string(64, 'a'));
  ASSERT_TRUE(WaitFinished(stream));
  testing::ExpectInputError([&] { stream.Result(); }, {"slab 0", "not in the blob store"});
}

// Slabs handed over decoded (the master decodes results to check them) are stitched as
// they are, not read from the store again, while they are among the next kDecodedAhead
// the stream needs; slabs further ahead are read from the store when their turn comes.
TEST(SurfaceStream, DecodedSlabsAreUsedWithoutReadingTheStore) {
  testing::TempDir dir;
  const Sphere sphere;
  ASSERT_GT(int(sphere.slabs.size()), SurfaceStream::kDecodedAhead);
  const std::string expected = EncodeMeshPly(OfflineSurface(sphere.grid, sphere.slabs));
  auto decoded = [&](int k) {
    return std::make_shared<const fusion::Slab>(fusion::DecodeSlab(sphere.slabs[k], "slab"));
  };
  {
    // Every slab decoded; the first kDecodedAhead under addresses the store does not
    // hold (they can only come from the hand-over), the others stored as well.
    MemoryBlobs store;
    SurfaceStream stream(sphere.grid, int(sphere.slabs.size()), &store, dir.path() / "a");
    for (int k = 0; k < int(sphere.slabs.size()); ++k) {
      const std::string sha = k < SurfaceStream::kDecodedAhead
                                  ? std::string(64, char('a' + k))
                                  : store.Keep(sphere.slabs[k], "slab").sha256();
      stream.Feed(k, sha, decoded(k));
    }
    ASSERT_TRUE(WaitFinished(stream));
    EXPECT_TRUE(io::ReadFileBytes(dir.path() / "a" / "mesh.ply") == expected);
  }
  {
    // Slab kDecodedAhead fed first, decoded but too far ahead: it is read from the
    // store (which lacks it) when its turn comes.
    MemoryBlobs store;
    SurfaceStream stream(sphere.grid, int(sphere.slabs.size()), &store, dir.path() / "b");
    const int far = SurfaceStream::kDecodedAhead;
    stream.Feed(far, std::string(64, 'f'), decoded(far));
    for (int k = 0; k < far; ++k) stream.Feed(k, std::string(64, char('a' + k)), decoded(k));
    ASSERT_TRUE(WaitFinished(stream));
    testing::ExpectInputError([&] { stream.Result(); },
                              {"slab " + std::to_string(far), "not in the blob store"});
  }
}

}  // namespace
}  // namespace dome::pipeline
