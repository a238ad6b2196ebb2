#include "master/journal.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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

TEST(Journal, InputsDigestsAreKeptWithTheirRecords) {
  testing::TempDir dir;
  const auto path = dir.path() / "journal.log";
  {
    Journal j(path, "d");
    JournalEntry e{{{"stereo", std::string(64, 'a')}}, std::string(64, 'f')};
    j.RecordDone("t0/stereo/c1", e);
    j.RecordDone("t0/stereo/c2", {});
  }
  EXPECT_NE(io::ReadFileBytes(path).find("done t0/stereo/c1 @" + std::string(64, 'f') +
                                         " stereo=" + std::string(64, 'a') + "\n"),
            std::string::npos);
  Journal j(path, "d");
  EXPECT_EQ(j.done().at("t0/stereo/c1").inputs, std::string(64, 'f'));
  EXPECT_EQ(j.done().at("t0/stereo/c1").outputs.size(), 1u);
  EXPECT_EQ(j.done().at("t0/stereo/c2").inputs, "");
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
  EXPECT_EQ(io::ReadFileBytes(path), "dome-journal 2 two\n");
}

TEST(Journal, RecordsWrittenButNotYetSyncedSurviveAKilledProcess) {
  testing::TempDir dir;
  const auto path = dir.path() / "journal.log";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // A master killed between two group commits: no Sync, no destructor.
    Journal j(path, "d");
    j.RecordDone("t0/stereo/a", {{{"stereo", std::string(64, 'a')}}});
    j.RecordDone("t0/stereo/b", {{{"stereo", std::string(64, 'b')}}});
    ::_exit(j.unsynced() == 2 ? 0 : 3);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "two records appended, none synced";
  Journal j(path, "d");
  ASSERT_EQ(j.done().size(), 2u);
  EXPECT_EQ(j.done().at("t0/stereo/b").outputs[0].second, std::string(64, 'b'));
  EXPECT_EQ(j.unsynced(), 0);
  j.RecordDone("t0/stereo/c", {});
  EXPECT_EQ(j.unsynced(), 1);
  j.Sync();
  EXPECT_EQ(j.unsynced(), 0);
}

}  // namespace
}  // namespace dome::scheduler
