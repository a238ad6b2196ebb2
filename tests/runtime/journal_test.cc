#include "scheduler/journal.h"

#include <gtest/gtest.h>

#include <fstream>

#include "io/file_util.h"
#include "testing/temp_dir.h"

namespace dome::scheduler {
namespace {

TEST(Journal, RecordsSurviveReopening) {
  testing::TempDir dir;
  const auto path = dir.path() / "journal.log";
  {
    Journal j(path, "digest1");
    EXPECT_TRUE(j.done().empty());
    j.RecordDone("t0/stereo/c1", {{{"stereo", std::string(64, 'a')}}});
    j.RecordDone("t0/surface", {{{"mesh.ply", std::string(64, 'b')}}});
  }
  Journal j(path, "digest1");
  ASSERT_EQ(j.done().size(), 2u);
  const auto& e = j.done().at("t0/stereo/c1");
  ASSERT_EQ(e.outputs.size(), 1u);
  EXPECT_EQ(e.outputs[0].first, "stereo");
  EXPECT_EQ(e.outputs[0].second, std::string(64, 'a'));
  EXPECT_EQ(j.done().count("t0/surface"), 1u);
}

TEST(Journal, TornLastRecordIsIgnoredAndTheNextStartsOnItsOwnLine) {
  testing::TempDir dir;
  const auto path = dir.path() / "journal.log";
  {
    Journal j(path, "d");
    j.RecordDone("t0/stereo/a", {});
  }
  {
    std::ofstream f(path, std::ios::app);
    f << "done t0/stereo/b stereo=ab";  // the master died mid-write
  }
  {
    Journal j(path, "d");
    EXPECT_EQ(j.done().size(), 1u);
    EXPECT_EQ(j.done().count("t0/stereo/b"), 0u);
    j.RecordDone("t0/stereo/c", {});
  }
  Journal j(path, "d");
  EXPECT_EQ(j.done().size(), 2u);
  EXPECT_EQ(j.done().count("t0/stereo/c"), 1u);
}

TEST(Journal, AnotherSessionsJournalIsMovedAside) {
  testing::TempDir dir;
  const auto path = dir.path() / "journal.log";
  {
    Journal j(path, "one");
    j.RecordDone("t0/stereo/a", {});
  }
  Journal j(path, "two");
  EXPECT_TRUE(j.done().empty());
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "journal.log.old"));
  EXPECT_EQ(io::ReadFileBytes(path), "dome-journal 1 two\n");
}

}  // namespace
}  // namespace dome::scheduler
