#include "ingest/publish.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "capture.pb.h"
#include "capture/pass_planner.h"
#include "capture/sim_deck.h"
#include "io/image_io.h"
#include "capture/tape_fixture.h"
#include "testing/temp_dir.h"

namespace dome::ingest {
namespace {

namespace fs = std::filesystem;
using namespace capture;

CapturedFrame Frame(int64_t n) {
  CapturedFrame f;
  f.time = LabelOf(n, VideoStandard::k525NonDrop);
  f.take_image = test_tapes::ExpectedTakeImage(n);
  f.pass = 1;
  return f;
}

// An endpoint of the test's own, known before anything binds it: an ipc socket file in
// the test's folder. A TCP port picked free beforehand could be taken by a test running
// beside this one while the ingest is down; ZeroMQ's reconnects and the spool behave
// the same over ipc. (The master's capture ingest over TCP is tested in
// tests/capture/master_ingest_test.cc.)
std::string OwnEndpoint(const testing::TempDir& dir) {
  return "ipc://" + (dir.path() / "ingest.sock").string();
}

// An ingest serving on its own thread until destroyed.
class IngestThread {
 public:
  explicit IngestThread(const IngestOptions& options) : ingest_(options) {
    endpoint_ = ingest_.endpoint();
    thread_ = std::thread([this] {
      while (!stop_) ingest_.Poll(20);
    });
  }
  ~IngestThread() {
    stop_ = true;
    thread_.join();
  }
  const std::string& endpoint() const { return endpoint_; }
  const FrameIngest& ingest() const { return ingest_; }

 private:
  FrameIngest ingest_;
  std::string endpoint_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

int SpoolFiles(const fs::path& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".frame";
  return n;
}

void ExpectStored(const fs::path& take, const std::string& camera, int64_t first, int64_t last) {
  for (int64_t n = first; n <= last; ++n) {
    const fs::path path = take / "frames" / Frame(n).time.FolderName() / (camera + ".png");
    ASSERT_TRUE(fs::exists(path)) << path;
    const cv::Mat got = io::ReadImage(path, io::ImageMode::kGray8);
    EXPECT_EQ(cv::countNonZero(got != Frame(n).take_image), 0) << path;
  }
}

TEST(Publish, FramesAreStoredAndAcknowledged) {
  testing::TempDir dir;
  IngestThread ingest({.bind = "tcp://127.0.0.1:*", .take_dir = dir / "take"});
  FramePublisher publisher("c07", {.endpoint = ingest.endpoint(), .spool_dir = dir / "spool"});
  for (int64_t n = 300; n < 320; ++n) publisher.Publish(Frame(n));
  ASSERT_TRUE(publisher.Flush(10000));
  EXPECT_EQ(publisher.acknowledged(), 20);
  EXPECT_EQ(SpoolFiles(dir / "spool"), 0);
  EXPECT_EQ(ingest.ingest().stored(), 20);
  ExpectStored(dir / "take", "c07", 300, 319);
  // The same frame again is a duplicate, left as it was.
  publisher.Publish(Frame(305));
  ASSERT_TRUE(publisher.Flush(10000));
  EXPECT_EQ(ingest.ingest().duplicates(), 1);
  EXPECT_EQ(ingest.ingest().stored(), 20);
}

TEST(Publish, NothingIsLostWhileTheIngestIsDownOrRestarts) {
  testing::TempDir dir;
  const std::string endpoint = OwnEndpoint(dir);
  FramePublisher publisher(
      "c01", {.endpoint = endpoint, .spool_dir = dir / "spool", .ack_timeout_ms = 200});
  // Down from the start: frames wait in the spool.
  for (int64_t n = 300; n < 310; ++n) publisher.Publish(Frame(n));
  EXPECT_FALSE(publisher.Flush(500));
  EXPECT_EQ(SpoolFiles(dir / "spool"), 10);
  {
    IngestThread ingest({.bind = endpoint, .take_dir = dir / "take"});
    ASSERT_TRUE(publisher.Flush(10000));
    EXPECT_EQ(SpoolFiles(dir / "spool"), 0);
    for (int64_t n = 310; n < 315; ++n) publisher.Publish(Frame(n));
    ASSERT_TRUE(publisher.Flush(10000));
  }  // the ingest goes away ...
  for (int64_t n = 315; n < 330; ++n) publisher.Publish(Frame(n));
  EXPECT_FALSE(publisher.Flush(400));
  {
    IngestThread ingest({.bind = endpoint, .take_dir = dir / "take"});  // ... and comes back
    ASSERT_TRUE(publisher.Flush(10000));
    EXPECT_EQ(ingest.ingest().stored(), 15);
  }
  EXPECT_GT(publisher.reconnects(), 0);
  EXPECT_EQ(SpoolFiles(dir / "spool"), 0);
  ExpectStored(dir / "take", "c01", 300, 329);
}

TEST(Publish, ASpoolLeftByAnEarlierRunIsSentFirst) {
  testing::TempDir dir;
  const std::string endpoint = OwnEndpoint(dir);
  {
    FramePublisher first("c02",
                         {.endpoint = endpoint, .spool_dir = dir / "spool", .ack_timeout_ms = 200});
    for (int64_t n = 300; n < 306; ++n) first.Publish(Frame(n));
    EXPECT_FALSE(first.Flush(200));
  }  // the agent stopped with frames undelivered
  IngestThread ingest({.bind = endpoint, .take_dir = dir / "take"});
  FramePublisher second("c02", {.endpoint = endpoint, .spool_dir = dir / "spool"});
  EXPECT_EQ(second.spooled_at_start().size(), 6u);
  EXPECT_EQ(second.pending(), 6u);
  ASSERT_TRUE(second.Flush(10000));
  ExpectStored(dir / "take", "c02", 300, 305);
}

TEST(Publish, TheIngestRejectsGarbageAndKeepsServing) {
  testing::TempDir dir;
  IngestThread ingest({.bind = "tcp://127.0.0.1:*", .take_dir = dir / "take"});
  zmq::context_t context;
  zmq::socket_t peer(context, zmq::socket_type::dealer);
  peer.set(zmq::sockopt::linger, 0);
  peer.connect(ingest.endpoint());
  auto ask = [&](const std::string& bytes) {
    peer.send(zmq::buffer(bytes));
    zmq::message_t reply;
    peer.set(zmq::sockopt::rcvtimeo, 5000);
    EXPECT_TRUE(peer.recv(reply));
    proto::CaptureAck ack;
    EXPECT_TRUE(ack.ParseFromArray(reply.data(), static_cast<int>(reply.size())));
    return ack;
  };
  proto::CaptureAck ack = ask("\xff\xfe garbage");
  EXPECT_EQ(ack.status(), proto::CaptureAck::REJECTED);
  EXPECT_NE(ack.error().find("protobuf"), std::string::npos) << ack.error();
  proto::CaptureMessage m;
  m.set_protocol("dome-capture/0");
  ack = ask(m.SerializeAsString());
  EXPECT_NE(ack.error().find("expected 'dome-capture/1'"), std::string::npos) << ack.error();
  m.set_protocol(kCaptureProtocol);
  auto* f = m.mutable_frame();
  f->set_camera_id("c03");
  f->set_timecode("00:00:10:00");
  f->set_field(1);
  f->set_width_px(4);
  f->set_height_px(4);
  f->set_pixels(std::string(15, '\0'));
  ack = ask(m.SerializeAsString());
  EXPECT_EQ(ack.status(), proto::CaptureAck::REJECTED);
  EXPECT_NE(ack.error().find("15 pixel bytes for 4 x 4"), std::string::npos) << ack.error();
  f->set_camera_id("../etc");
  f->set_pixels(std::string(16, '\0'));
  ack = ask(m.SerializeAsString());
  EXPECT_NE(ack.error().find("camera_id '../etc'"), std::string::npos) << ack.error();
  f->set_camera_id("c03");
  ack = ask(m.SerializeAsString());
  EXPECT_EQ(ack.status(), proto::CaptureAck::STORED);
  EXPECT_EQ(ingest.ingest().rejected(), 4);
  EXPECT_TRUE(fs::exists(dir / "take" / "frames" / "00-00-10-00" / "c03.png"));
}

// Progress that an agent's socket rebuild let overtake a newer message is not shown;
// a new run of the agent is; a final progress is acknowledged even when stale.
TEST(Publish, OvertakenProgressIsNotShownAndTheFinalOneIsAcknowledged) {
  testing::TempDir dir;
  std::vector<std::pair<uint32_t, int>> shown;  // (sequence, captured)
  IngestOptions options{.bind = "tcp://127.0.0.1:*", .take_dir = dir / "take"};
  options.on_progress = [&](const IngestProgress& p) {
    shown.emplace_back(p.sequence, p.agent.captured);
  };
  FrameIngest ingest(options);
  zmq::context_t context;
  zmq::socket_t peer(context, zmq::socket_type::dealer);
  peer.set(zmq::sockopt::linger, 0);
  peer.set(zmq::sockopt::rcvtimeo, 50);
  peer.connect(ingest.endpoint());
  auto send = [&](uint64_t run, uint32_t sequence, int captured, bool done) {
    proto::CaptureMessage m;
    m.set_protocol(kCaptureProtocol);
    auto* p = m.mutable_progress();
    p->set_camera_id("c04");
    p->set_run_id(run);
    p->set_sequence(sequence);
    p->set_captured(captured);
    p->set_wanted(9);
    p->set_done(done);
    peer.send(zmq::buffer(m.SerializeAsString()));
    ingest.Poll(1000);
    zmq::message_t reply;
    if (!peer.recv(reply)) return false;
    proto::CaptureAck ack;
    return ack.ParseFromArray(reply.data(), static_cast<int>(reply.size())) && ack.progress();
  };
  EXPECT_FALSE(send(7, 2, 5, false));  // progress is not acknowledged ...
  EXPECT_FALSE(send(7, 1, 3, false));  // overtaken: not shown
  EXPECT_TRUE(send(7, 3, 9, true));    // ... the final one is
  EXPECT_TRUE(send(7, 3, 9, true));    // resent: acknowledged again, not shown again
  EXPECT_FALSE(send(8, 1, 0, false));  // the agent's next run
  const std::vector<std::pair<uint32_t, int>> expected = {{2, 5}, {3, 9}, {1, 0}};
  EXPECT_EQ(shown, expected);
  EXPECT_EQ(ingest.progress().at("c04").agent.captured, 0);
}

}  // namespace
}  // namespace dome::ingest

namespace dome::ingest {
namespace {
using namespace capture;

// The whole agent path in one process: passes over a tape, frames published while the
// ingest is stopped mid-capture and started again; every frame ends up in the take
// once, under its own time code.
TEST(Publish, IngestRestartedDuringCaptureLosesNothing) {
  testing::TempDir dir;
  const std::string endpoint = OwnEndpoint(dir);
  TapeLayout layout;
  SimDeck deck(test_tapes::MakeTape(test_tapes::Consecutive(270, 100), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {.keep_per_second = 10.0, .drop_probability = 0.05, .seed = 9});
  CaptureOptions options;
  options.range = ParseRange("00:00:10:00-00:00:11:09", layout.standard, "range");
  options.preroll_frames = 10;
  PassPlanner planner(&deck, &digitizer, options);
  FramePublisher publisher(
      "c04", {.endpoint = endpoint, .spool_dir = dir / "spool", .ack_timeout_ms = 200});
  auto ingest =
      std::make_unique<IngestThread>(IngestOptions{.bind = endpoint, .take_dir = dir / "take"});
  int published = 0;
  const CaptureSummary summary = planner.Run([&](const CapturedFrame& frame) {
    publisher.Publish(frame);
    publisher.Pump(5);
    if (++published == 12) {
      ingest.reset();  // the master goes down ...
    } else if (published == 13) {
      publisher.Pump(500);  // ... long enough for a frame to time out: the publisher reconnects
    } else if (published == 25) {
      ingest =
          std::make_unique<IngestThread>(IngestOptions{.bind = endpoint, .take_dir = dir / "take"});
    }
  });
  ASSERT_TRUE(summary.complete()) << summary.BriefReport();
  EXPECT_GE(summary.passes.size(), 3u);
  ASSERT_TRUE(publisher.Flush(10000));
  EXPECT_GT(publisher.reconnects(), 0);
  EXPECT_EQ(SpoolFiles(dir / "spool"), 0);
  ExpectStored(dir / "take", "c04", 300, 339);
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir / "take" / "frames"))
    files += e.is_regular_file();
  EXPECT_EQ(files, 40);
}

}  // namespace
}  // namespace dome::ingest
