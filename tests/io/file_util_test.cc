#include "io/file_util.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>

#include "test_util.h"

namespace dome::io {
namespace {

namespace fs = std::filesystem;
using ::dome::testing::TempDir;

// A process killed mid-write leaves "<file>.tmp-<pid>-<n>" behind: removed once its
// writer is gone, kept while it lives; other files are never touched.
TEST(FileUtil, StaleTemporaryFilesOfDeadWritersAreRemoved) {
  const TempDir dir;
  fs::create_directories(dir / "a" / "b");
  // A pid that is surely gone: a child that has exited and been reaped.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  const std::string dead = std::to_string(child), alive = std::to_string(::getpid());
  for (const fs::path& p :
       {dir / "mesh.ply", dir / ("mesh.ply.tmp-" + dead + "-3"),
        dir / "a" / "b" / ("c01.tiff.tmp-" + dead + "-12"), dir / ("x.tmp-" + alive + "-1"),
        dir / "notes.tmp-draft", dir / "y.tmp-12a-3"}) {
    WriteFileAtomically(p, "bytes");
  }
  EXPECT_EQ(RemoveStaleTempFiles(dir.path()), 2);
  EXPECT_TRUE(fs::exists(dir / "mesh.ply"));
  EXPECT_FALSE(fs::exists(dir / ("mesh.ply.tmp-" + dead + "-3")));
  EXPECT_FALSE(fs::exists(dir / "a" / "b" / ("c01.tiff.tmp-" + dead + "-12")));
  EXPECT_TRUE(fs::exists(dir / ("x.tmp-" + alive + "-1"))) << "a live writer's file";
  EXPECT_TRUE(fs::exists(dir / "notes.tmp-draft"));
  EXPECT_TRUE(fs::exists(dir / "y.tmp-12a-3"));
}

}  // namespace
}  // namespace dome::io
