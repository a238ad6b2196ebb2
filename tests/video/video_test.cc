// Video files through dome's video module (video/video.h): lossless FFV1 round trips,
// what the container says, and a missing or foreign module named.
#include "video/video.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <fstream>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::video {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;

std::vector<cv::Mat> Frames(int n, cv::Size size, int type) {
  std::vector<cv::Mat> out;
  cv::RNG rng(5);
  for (int i = 0; i < n; ++i) {
    cv::Mat f(size, type);
    rng.fill(f, cv::RNG::UNIFORM, 0, 256);
    out.push_back(f);
  }
  return out;
}

TEST(Video, Ffv1KeepsEveryFrameExactlyAndSaysItsRateCountAndSize) {
  TempDir dir;
  for (const bool colour : {false, true}) {
    SCOPED_TRACE(colour ? "colour" : "grey");
    const auto path = (dir.path() / (colour ? "c.avi" : "g.avi")).string();
    const cv::Size size(64, 48);
    const auto frames = Frames(5, size, colour ? CV_8UC3 : CV_8UC1);
    {
      const auto sink = CreateFfv1(path, size, 29.97, colour);
      for (const auto& f : frames) sink->Write(f);
      sink->Close();
    }
    const auto source = OpenFile(path);
    EXPECT_NEAR(source->fps(), 29.97, 0.01);
    EXPECT_EQ(source->frame_count(), 5);
    EXPECT_EQ(source->size(), size);
    cv::Mat frame;
    ASSERT_TRUE(source->Skip());
    for (size_t i = 1; i < frames.size(); ++i) {
      ASSERT_TRUE(source->Read(&frame)) << i;
      cv::Mat got = frame;
      if (!colour && frame.channels() == 3) cv::extractChannel(frame, got, 0);
      EXPECT_EQ(cv::norm(got, frames[i], cv::NORM_INF), 0) << i;
    }
    EXPECT_FALSE(source->Read(&frame));
  }
}

TEST(Video, FilesThatAreNotVideosAndUnwritablePathsAreNamed) {
  TempDir dir;
  const auto text = (dir.path() / "notes.avi").string();
  std::ofstream(text) << "not a video";
  ExpectInputError([&] { OpenFile(text); }, {"notes.avi", "cannot be opened as a video"});
  ExpectInputError(
      [&] {
        CreateFfv1((dir.path() / "no/such/dir/t.avi").string(), {8, 8}, 30, false);
      },
      {"t.avi", "cannot open for writing"});
}

// In a child process (the module is loaded once per process): a module path with no
// module, and a shared library that is not dome's module, are named.
TEST(VideoDeathTest, AMissingOrForeignModuleIsNamed) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const auto open_with = [](const char* module) {
    setenv("DOME_VIDEO_MODULE", module, 1);
    try {
      OpenFile("whatever.avi");
    } catch (const core::InputError& e) {
      std::fprintf(stderr, "%s\n", e.what());
      std::exit(3);
    }
    std::exit(0);
  };
  EXPECT_EXIT(open_with("/nonexistent/libdome_video.so"), ::testing::ExitedWithCode(3),
              "video support: /nonexistent/libdome_video.so: cannot load dome's video module");
  EXPECT_EXIT(open_with("libz.so.1"), ::testing::ExitedWithCode(3),
              "libz.so.1: not dome's video module of this version");
}

}  // namespace
}  // namespace dome::video
