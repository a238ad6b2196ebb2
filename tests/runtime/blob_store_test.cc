// The master's blob store (master/blob_store.h): outputs held under the same bytes.
#include "master/blob_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "net/content_hash.h"

namespace dome::scheduler {
namespace {
namespace fs = std::filesystem;

// Two outputs with the same bytes (an empty fusion slab of two instants of one
// session): the surface of the first instant drops its slabs while the second's
// surface still has to read its own. The blob stays until the last one is dropped.
TEST(BlobStore, OutputsWithTheSameBytesAreDroppedOneByOne) {
  const fs::path dir =
      fs::temp_directory_path() / ("dome_blob_store_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  BlobStore store;
  const std::string bytes(1000, 'x');
  const runtime::BlobRef a = store.AddBytes(dir, bytes, "slab of instant 1");
  const runtime::BlobRef b = store.AddBytes(dir, bytes, "slab of instant 2");
  ASSERT_EQ(a.sha256(), b.sha256());
  const fs::path file = dir / a.sha256();
  store.Drop(a.sha256());
  ASSERT_TRUE(store.Read(b.sha256(), nullptr).has_value());
  EXPECT_EQ(*store.Read(b.sha256(), nullptr), bytes);
  EXPECT_TRUE(fs::exists(file));
  store.Drop(b.sha256());
  EXPECT_FALSE(store.Read(b.sha256(), nullptr).has_value());
  EXPECT_FALSE(fs::exists(file));
  EXPECT_EQ(store.size(), 0u);
  // An output once held and dropped, then made again, is held again.
  store.AddBytes(dir, bytes, "again");
  EXPECT_TRUE(store.Read(a.sha256(), nullptr).has_value());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dome::scheduler
