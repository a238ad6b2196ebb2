// The master's blob store (master/blob_store.h): outputs held under the same bytes.
#include "master/blob_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "io/file_util.h"
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

// The outputs added last are served from memory: not read back from their files (gone
// or overwritten here, which only a process outside dome would do) and not hashed again;
// past the budget the oldest are read from their files again, and a dropped output is
// gone from memory too.
TEST(BlobStore, RecentOutputsAreServedFromMemoryWithinTheBudget) {
  const fs::path dir =
      fs::temp_directory_path() / ("dome_blob_store_recent_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  BlobStore store(/*recent_bytes=*/3000);
  std::vector<runtime::BlobRef> refs;
  for (char c : std::string("abcd")) refs.push_back(store.AddBytes(dir, std::string(1000, c), {c}));
  for (const auto& r : refs) fs::remove(dir / r.sha256());
  std::string error;
  // 'a' went past the budget when 'd' came: its file is read, and it is gone.
  EXPECT_FALSE(store.Read(refs[0].sha256(), &error).has_value());
  EXPECT_NE(error.find((dir / refs[0].sha256()).string()), std::string::npos) << error;
  for (size_t k = 1; k < refs.size(); ++k) {
    const auto bytes = store.Read(refs[k].sha256(), nullptr);
    ASSERT_TRUE(bytes.has_value()) << k;
    EXPECT_EQ(*bytes, std::string(1000, "abcd"[k])) << k;
  }
  // Larger than the whole budget: never held in memory.
  const runtime::BlobRef big = store.AddBytes(dir, std::string(4000, 'e'), "big");
  fs::remove(dir / big.sha256());
  EXPECT_FALSE(store.Read(big.sha256(), nullptr).has_value());
  EXPECT_TRUE(store.Read(refs[3].sha256(), nullptr).has_value());
  store.Drop(refs[3].sha256());
  EXPECT_FALSE(store.Read(refs[3].sha256(), nullptr).has_value());
  fs::remove_all(dir);
}

// An output written to its file and then kept: the blob is that file under a second name
// (one copy on disk), and it keeps the bytes it was given when the file is replaced the
// way dome writes files, or deleted; a file that is not there is no copy, and the bytes
// are written.
TEST(BlobStore, AnOutputJustWrittenIsKeptAsASecondNameOfItsFile) {
  const fs::path out =
      fs::temp_directory_path() / ("dome_blob_store_linked_" + std::to_string(::getpid()));
  fs::remove_all(out);
  fs::create_directories(out / "00-00-00-00");
  const fs::path dir = out / ".blobs", file = out / "00-00-00-00" / "textured.obj";
  BlobStore store(/*recent_bytes=*/0);  // every Read from the file
  const std::string bytes(5000, 'v');
  io::WriteFileAtomically(file, bytes);
  const runtime::BlobRef ref = store.AddBytes(dir, bytes, "textured.obj", file);
  const fs::path blob = dir / ref.sha256();
  ASSERT_TRUE(fs::exists(blob));
  EXPECT_TRUE(fs::equivalent(blob, file));
  EXPECT_EQ(fs::hard_link_count(file), 2u);
  io::WriteFileAtomically(file, std::string(5000, 'w'));  // a later run's file
  EXPECT_FALSE(fs::equivalent(blob, file));
  ASSERT_TRUE(store.Read(ref.sha256(), nullptr).has_value());
  EXPECT_EQ(*store.Read(ref.sha256(), nullptr), bytes);
  fs::remove(file);
  EXPECT_EQ(*store.Read(ref.sha256(), nullptr), bytes);
  // Dropping the output removes its blob's name only.
  io::WriteFileAtomically(file, bytes);
  store.Drop(ref.sha256());
  const runtime::BlobRef again = store.AddBytes(dir, bytes, "textured.obj", file);
  store.Drop(again.sha256());
  EXPECT_FALSE(fs::exists(blob));
  EXPECT_EQ(io::ReadFileBytes(file), bytes);
  // No such file: the bytes are written.
  const std::string other(300, 'x');
  const runtime::BlobRef written = store.AddBytes(dir, other, "mesh.ply", out / "missing.ply");
  EXPECT_EQ(fs::hard_link_count(dir / written.sha256()), 1u);
  EXPECT_EQ(*store.Read(written.sha256(), nullptr), other);
  fs::remove_all(out);
}

}  // namespace
}  // namespace dome::scheduler
