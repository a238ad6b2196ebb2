// Oracle: ffmpeg's readvitc filter, an independent VITC decoder, reads the frames our
// encoder draws, and our decoder agrees with it on the same frames.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "capture/tape.h"
#include "capture/timecode_count.h"
#include "capture/vitc.h"
#include "testing/temp_dir.h"

namespace dome::capture {
namespace {

bool HaveFfmpeg() { return std::system("ffmpeg -hide_banner -version > /dev/null 2>&1") == 0; }

// Runs readvitc over `input` (ffmpeg input options included) and returns, per frame
// number, the time code text it found ("" when it found none).
std::map<int, std::string> RunReadVitc(const std::string& input,
                                       const std::filesystem::path& report) {
  const std::string command = "ffmpeg -hide_banner -loglevel error -nostdin " + input +
                              " -vf readvitc,metadata=mode=print:file=" + report.string() +
                              " -f null - 2>&1";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  std::map<int, std::string> found;
  std::ifstream in(report);
  std::string line;
  int frame = -1;
  while (std::getline(in, line)) {
    if (line.rfind("frame:", 0) == 0) {
      frame = std::stoi(line.substr(6));
      found[frame] = "";
    } else if (line.rfind("lavfi.readvitc.tc_str=", 0) == 0) {
      found[frame] = line.substr(22);
    }
  }
  return found;
}

// Labels around every minute boundary of two hours (drop-frame's skipped labels and
// its tenth minutes), plus random ones.
std::vector<take::Timecode> TestLabels(VideoStandard standard, int random_count) {
  std::vector<take::Timecode> labels;
  for (int h : {0, 13}) {
    for (int m = 0; m < 60; ++m) {
      const take::Timecode boundary{h, m, 0,
                                    standard == VideoStandard::k525DropFrame && m % 10 ? 2 : 0};
      const int64_t n = FrameNumber(boundary, standard);
      for (int64_t k = std::max<int64_t>(0, n - 2); k <= n + 1; ++k)
        labels.push_back(LabelOf(k, standard));
    }
  }
  std::mt19937 rng(17);
  for (int i = 0; i < random_count; ++i)
    labels.push_back(LabelOf(rng() % FramesPerDay(standard), standard));
  return labels;
}

TEST(VitcFfmpegOracle, ReadvitcReadsOurFramesAndOurDecoderAgrees) {
  if (!HaveFfmpeg())
    GTEST_SKIP() << "ffmpeg is not installed (Debian package ffmpeg); oracle skipped";
  testing::TempDir dir;
  constexpr int kWidth = 720, kHeight = 32;
  int compared = 0, agreed_ffmpeg = 0, agreed_ours = 0;

  // 525/60 drop-frame: raw grey frames, one VITC line per field (rows 10 and 11),
  // then words with one flipped bit each, which neither decoder may report.
  {
    const auto standard = VideoStandard::k525DropFrame;
    const std::vector<take::Timecode> labels = TestLabels(standard, 600);
    std::vector<cv::Mat> frames;
    std::vector<std::string> expected;
    std::mt19937 rng(23);
    for (const auto& tc : labels) {
      cv::Mat frame(kHeight, kWidth, CV_8UC1, cv::Scalar(16));
      VitcWord w;
      w.time = tc;
      w.drop_frame = true;
      w.user_bits = rng();
      DrawVitcLine(EncodeVitc(w, standard), frame.ptr<uint8_t>(10), kWidth);
      w.field_mark = true;
      DrawVitcLine(EncodeVitc(w, standard), frame.ptr<uint8_t>(11), kWidth);
      frames.push_back(frame);
      expected.push_back(tc.Text(true));
    }
    for (int k = 0; k < kVitcBits; ++k) {
      VitcWord w;
      w.time = labels[k];
      w.drop_frame = true;
      VitcBits bits = EncodeVitc(w, standard);
      bits[k] ^= 1;
      cv::Mat frame(kHeight, kWidth, CV_8UC1, cv::Scalar(16));
      DrawVitcLine(bits, frame.ptr<uint8_t>(10), kWidth);
      frames.push_back(frame);
      expected.push_back("");
    }
    const auto raw = dir / "525.gray";
    {
      std::ofstream out(raw, std::ios::binary);
      for (const auto& f : frames) out.write(reinterpret_cast<const char*>(f.data), f.total());
    }
    const auto found = RunReadVitc(
        "-f rawvideo -pix_fmt gray -s 720x32 -r 30000/1001 -i " + raw.string(), dir / "525.txt");
    ASSERT_EQ(found.size(), frames.size());
    const VitcDecoder ours({.standard = standard, .last_row = kHeight - 1});
    for (size_t i = 0; i < frames.size(); ++i) {
      ++compared;
      const std::string& theirs = found.at(static_cast<int>(i));
      EXPECT_EQ(theirs, expected[i]) << "frame " << i;
      agreed_ffmpeg += theirs == expected[i];
      const auto read = ours.ReadFirst(frames[i]);
      const std::string mine = read ? read->word.time.Text(read->word.drop_frame) : "";
      EXPECT_EQ(mine, theirs) << "frame " << i;
      agreed_ours += mine == theirs;
      if (read) {
        EXPECT_EQ(read->row, 10);
      }
    }
  }

  // 625/50: a tape file (FFV1 video) of full tape frames, 720 wide.
  {
    const auto standard = VideoStandard::k625;
    const std::vector<take::Timecode> labels = TestLabels(standard, 300);
    TapeLayout layout;
    layout.standard = standard;
    const auto path = dir / "625.avi";
    std::vector<std::string> expected;
    {
      TapeWriter writer(path, cv::Size(kWidth, 2 * layout.vbi_field_lines + 8), standard);
      for (const auto& tc : labels) {
        cv::Mat picture(8, kWidth, CV_8UC1, cv::Scalar(90));
        VitcWord w;
        w.time = tc;
        writer.Write(ComposeTapeFrame(picture, w, layout));
        expected.push_back(tc.Text(false));
      }
    }
    const auto found = RunReadVitc("-i " + path.string(), dir / "625.txt");
    const std::vector<cv::Mat> frames = ReadTapeFrames(path);
    ASSERT_EQ(found.size(), labels.size());
    ASSERT_EQ(frames.size(), labels.size());
    const VitcDecoder ours(layout.DecoderOptions());
    for (size_t i = 0; i < frames.size(); ++i) {
      ++compared;
      const std::string& theirs = found.at(static_cast<int>(i));
      EXPECT_EQ(theirs, expected[i]) << "frame " << i;
      agreed_ffmpeg += theirs == expected[i];
      const auto read = ours.ReadFirst(frames[i]);
      const std::string mine = read ? read->word.time.Text(false) : "";
      EXPECT_EQ(mine, theirs);
      agreed_ours += mine == theirs;
      if (read) {
        EXPECT_FALSE(read->word.field_mark);
      }
    }
  }
  EXPECT_GE(compared, 1000);
  std::printf(
      "readvitc oracle: %d frames, ffmpeg read the encoded time code (or nothing for a flipped "
      "bit) "
      "on %d, our decoder agreed with ffmpeg on %d\n",
      compared, agreed_ffmpeg, agreed_ours);
}

}  // namespace
}  // namespace dome::capture
