// dome-capture as a user runs it: a stand-alone ingest process, agents on the
// synthetic take's tapes, the ingest down during a capture.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "io/image_io.h"
#include "synth/synth.h"
#include "synth_tapes_fixture.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome::capture {
namespace {

namespace fs = std::filesystem;

// dome-capture in the background (ingest, emulate-deck); its first output line says
// where it listens.
class BackgroundCapture {
 public:
  explicit BackgroundCapture(std::vector<std::string> args) {
    int out[2];
    EXPECT_EQ(::pipe(out), 0);
    const std::string binary = std::string(DOME_BINARY_DIR) + "/bin/dome-capture";
    args.insert(args.begin(), binary);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], STDOUT_FILENO);
      ::close(out[0]);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(binary.c_str(), argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    in_ = ::fdopen(out[0], "r");
    char line[512] = {0};
    if (std::fgets(line, sizeof line, in_) != nullptr) first_line_ = line;
    // Keep reading what it prints (logs), so it never blocks or dies on a closed pipe.
    drain_ = std::thread([this] {
      char buf[512];
      while (std::fgets(buf, sizeof buf, in_) != nullptr) {
      }
    });
  }
  ~BackgroundCapture() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    drain_.join();
    std::fclose(in_);
  }
  // The text after `key` on the first line, up to `end`.
  std::string After(const std::string& key, char end) const {
    const size_t at = first_line_.find(key);
    if (at == std::string::npos) return "";
    const size_t stop = first_line_.find(end, at + key.size());
    return first_line_.substr(at + key.size(), stop - at - key.size());
  }

 private:
  pid_t pid_ = -1;
  FILE* in_ = nullptr;
  std::thread drain_;
  std::string first_line_;
};

struct IngestProcess : BackgroundCapture {
  IngestProcess(const std::string& bind, const fs::path& take)
      : BackgroundCapture({"ingest", "--bind", bind, "--take", take.string()}) {}
  std::string Endpoint() const { return After("listening on ", ','); }
};

class CaptureCli : public test_tapes::SmallTakeWithTapes {
 protected:
  static void ExpectTakeEqualsSynth(const fs::path& take, const std::string& camera) {
    ExpectFramesEqualSynth(take, camera);
  }
};

TEST_F(CaptureCli, CapturesATapeIntoTheIngestsTake) {
  dome::testing::TempDir work;
  IngestProcess ingest("tcp://127.0.0.1:*", work / "take");
  ASSERT_FALSE(ingest.Endpoint().empty());
  const auto result = dome::testing::RunDomeBinary(
      "--camera c00 --deck sim:" + (Synth() / "tape" / "c00.avi").string() +
          " --digitizer sim --range " + Range() +
          " --every 5 --keep-per-second 10 --insecure --master " + ingest.Endpoint() + " --spool " +
          work.File("spool"),
      "dome-capture");
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("captured 3 of 3 frames"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("[c00] pass 1"), std::string::npos) << result.output;
  ExpectTakeEqualsSynth(work / "take", "c00");
}

TEST_F(CaptureCli, FramesCapturedWhileTheIngestIsDownArriveOnTheNextRun) {
  dome::testing::TempDir work;
  const std::string args = "--camera c01 --deck sim:" + (Synth() / "tape" / "c01.avi").string() +
                           " --digitizer sim --range " + Range() +
                           " --every 5 --insecure --spool " + work.File("spool") +
                           " --ack-timeout-ms 200 --flush-timeout-ms 600";
  // Nothing listens on the port yet.
  std::string endpoint;
  {
    IngestProcess probe("tcp://127.0.0.1:*", work / "probe");
    endpoint = probe.Endpoint();
  }
  auto down = dome::testing::RunDomeBinary(args + " --master " + endpoint, "dome-capture");
  EXPECT_EQ(down.exit_code, 1) << down.output;
  EXPECT_NE(down.output.find("still in the spool"), std::string::npos) << down.output;
  IngestProcess ingest(endpoint, work / "take");
  auto up = dome::testing::RunDomeBinary(args + " --master " + endpoint, "dome-capture");
  EXPECT_EQ(up.exit_code, 0) << up.output;
  EXPECT_NE(up.output.find("3 frames in the spool from an earlier run"), std::string::npos)
      << up.output;
  ExpectTakeEqualsSynth(work / "take", "c01");
}

TEST_F(CaptureCli, SerialDeckThatNeverAnswersIsAClearError) {
  dome::testing::TempDir work;
  // An emulated deck that stays silent, on a pseudo-terminal, in its own process.
  const BackgroundCapture emulator(
      {"emulate-deck", "--tape", (Synth() / "tape" / "c02.avi").string(), "--silent-after", "0"});
  const std::string device = emulator.After(" on ", '\n');
  ASSERT_FALSE(device.empty());
  const auto result = dome::testing::RunDomeBinary(
      "--camera c02 --deck serial:" + device +
          " --digitizer file:" + (Synth() / "tape" / "c02.avi").string() + " --range " + Range() +
          " --every 5 --insecure --master tcp://127.0.0.1:1 --spool " + work.File("spool"),
      "dome-capture");
  EXPECT_EQ(result.exit_code, 2) << result.output;
  EXPECT_NE(result.output.find("serial:" + device), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("no reply"), std::string::npos) << result.output;
}

TEST_F(CaptureCli, WithoutKeysOrInsecureTheMissingKeyFlagIsNamed) {
  const auto r = dome::testing::RunDomeBinary(
      "--camera c00 --deck sim:x.avi --range 00:00:10:00-00:00:10:10 --master tcp://x:1",
      "dome-capture");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--master-key"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--insecure"), std::string::npos) << r.output;
}

// The agent's options are checked by the library, which names the option at fault.
TEST_F(CaptureCli, BadFlagsNameTheOption) {
  auto r = dome::testing::RunDomeBinary(
      "--camera c00 --deck tape.avi --range 00:00:10:00-00:00:10:10 --insecure --master tcp://x:1",
      "dome-capture");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("deck: got 'tape.avi'"), std::string::npos) << r.output;
  r = dome::testing::RunDomeBinary(
      "--camera c00 --deck sim:x.avi --range 00:00:10:99-00:00:10:10 --insecure --master tcp://x:1",
      "dome-capture");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("range: "), std::string::npos) << r.output;
}

}  // namespace
}  // namespace dome::capture
