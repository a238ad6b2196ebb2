#include "capture/vitc.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

namespace dome::capture {
namespace {

VitcWord Word(take::Timecode tc, bool drop = false) {
  VitcWord w;
  w.time = tc;
  w.drop_frame = drop;
  return w;
}

TEST(Vitc, BitLayoutFollowsSmpte12m) {
  VitcWord w = Word({12, 34, 56, 23}, true);
  w.colour_frame = true;
  w.user_bits = 0x89ABCDEF;
  const VitcBits b = EncodeVitc(w, VideoStandard::k525DropFrame);
  for (int g = 0; g < 9; ++g) {
    EXPECT_EQ(b[10 * g], 1);
    EXPECT_EQ(b[10 * g + 1], 0);
  }
  auto nibble = [&](int at) { return b[at] | b[at + 1] << 1 | b[at + 2] << 2 | b[at + 3] << 3; };
  EXPECT_EQ(nibble(2), 3);           // frame units
  EXPECT_EQ(b[12] | b[13] << 1, 2);  // frame tens
  EXPECT_EQ(b[14], 1);               // drop frame
  EXPECT_EQ(b[15], 1);               // colour frame
  EXPECT_EQ(nibble(22), 6);          // seconds units
  EXPECT_EQ(nibble(42), 4);          // minutes units
  EXPECT_EQ(nibble(62), 2);          // hours units
  EXPECT_EQ(nibble(6), 0xF);         // user group 1
  EXPECT_EQ(nibble(76), 0x8);        // user group 8
  // Field mark: bit 35 on 525/60, bit 75 on 625/50.
  w.field_mark = true;
  EXPECT_EQ(EncodeVitc(w, VideoStandard::k525DropFrame)[35], 1);
  EXPECT_EQ(EncodeVitc(w, VideoStandard::k625)[75], 1);
  EXPECT_EQ(EncodeVitc(w, VideoStandard::k625)[35], 0);
  // The CRC: every residue class of bit index mod 8 has even parity over 90 bits.
  for (int r = 0; r < 8; ++r) {
    int parity = 0;
    for (int j = r; j < kVitcBits; j += 8) parity ^= b[j];
    EXPECT_EQ(parity, 0) << r;
  }
}

TEST(Vitc, WordsRoundTripThroughBits) {
  std::mt19937 rng(7);
  for (auto standard : {VideoStandard::k525DropFrame, VideoStandard::k625}) {
    for (int i = 0; i < 500; ++i) {
      VitcWord w = Word(LabelOf(rng() % FramesPerDay(standard), standard),
                        standard == VideoStandard::k525DropFrame);
      w.field_mark = rng() & 1;
      w.colour_frame = rng() & 1;
      w.binary_group_flags = rng() & 7;
      w.user_bits = rng();
      const auto back = DecodeVitcBits(EncodeVitc(w, standard), standard);
      ASSERT_TRUE(back);
      EXPECT_EQ(*back, w);
    }
  }
}

TEST(Vitc, EverySingleFlippedBitIsRejected) {
  std::mt19937 rng(11);
  for (int i = 0; i < 20; ++i) {
    const VitcWord w = Word(LabelOf(rng() % 2000000, VideoStandard::k525DropFrame), true);
    const VitcBits good = EncodeVitc(w, VideoStandard::k525DropFrame);
    for (int k = 0; k < kVitcBits; ++k) {
      VitcBits bad = good;
      bad[k] ^= 1;
      EXPECT_FALSE(DecodeVitcBits(bad, VideoStandard::k525DropFrame)) << "bit " << k;
      // And drawn on a line, the decoder never reports it.
      std::vector<uint8_t> line(720);
      DrawVitcLine(bad, line.data(), 720);
      EXPECT_FALSE(
          VitcDecoder({.standard = VideoStandard::k525DropFrame}).ReadLine(line.data(), 720))
          << "bit " << k;
    }
  }
}

// A line distorted as a digitizer may: gain, offset, horizontal scale and shift, noise.
struct Distortion {
  double gain, offset, scale, shift_px, noise_sigma;
};

TEST(Vitc, DecoderToleratesLevelsScaleAndNoise) {
  std::mt19937 rng(3);
  const std::vector<Distortion> cases = {
      {1.0, 0, 1.0, 0, 0},    {0.6, 30, 1.0, 0.3, 0},   {1.2, -10, 1.0, 0.7, 4},
      {1.0, 0, 0.93, 0.2, 6}, {1.0, 0, 1.05, 0.5, 6},   {0.45, 60, 0.96, 0.1, 8},
      {1.0, 0, 1.0, 0, 12},   {0.8, 10, 1.04, 0.9, 10},
  };
  for (int width : {640, 720}) {
    for (const Distortion& d : cases) {
      std::normal_distribution<double> noise(0.0, d.noise_sigma);
      int read = 0, total = 0;
      for (int i = 0; i < 100; ++i) {
        VitcWord w = Word(LabelOf(rng() % FramesPerDay(VideoStandard::k525DropFrame),
                                  VideoStandard::k525DropFrame),
                          true);
        w.user_bits = rng();
        w.field_mark = i & 1;
        VitcLineOptions line;
        line.cell_px = d.scale * width / 96.0;
        line.start_px = 1.5 * width / 96.0 + d.shift_px;  // room for the widest word
        std::vector<uint8_t> clean(width), dirty(width);
        DrawVitcLine(EncodeVitc(w, VideoStandard::k525DropFrame), clean.data(), width, line);
        for (int x = 0; x < width; ++x) {
          dirty[x] = cv::saturate_cast<uint8_t>(d.gain * clean[x] + d.offset + noise(rng));
        }
        const auto got =
            VitcDecoder({.standard = VideoStandard::k525DropFrame}).ReadLine(dirty.data(), width);
        ++total;
        if (!got) continue;
        ++read;
        ASSERT_EQ(got->word, w) << "a wrong word passed the CRC";
        EXPECT_NEAR(got->cell_px, line.cell_px, 0.02 * line.cell_px);
        EXPECT_NEAR(got->start_px, line.start_px, 0.5);
      }
      EXPECT_EQ(read, total) << "width " << width << " gain " << d.gain << " scale " << d.scale
                             << " noise " << d.noise_sigma;
    }
  }
}

TEST(Vitc, DecoderReportsTheRowAndFieldAndIgnoresPictureAndNoiseLines) {
  cv::Mat frame(40, 640, CV_8UC1, cv::Scalar(16));
  cv::RNG rng(5);
  rng.fill(frame.rowRange(30, 40), cv::RNG::UNIFORM, 0, 256);  // picture-like noise
  VitcWord w = Word({0, 0, 10, 5});
  VitcBits first = EncodeVitc(w, VideoStandard::k525NonDrop);
  w.field_mark = true;
  VitcBits second = EncodeVitc(w, VideoStandard::k525NonDrop);
  DrawVitcLine(first, frame.ptr<uint8_t>(8), 640);
  DrawVitcLine(second, frame.ptr<uint8_t>(9), 640);
  const VitcDecoder decoder({.standard = VideoStandard::k525NonDrop, .last_row = 39});
  const auto reads = decoder.ReadAll(frame);
  ASSERT_EQ(reads.size(), 2u);
  EXPECT_EQ(reads[0].row, 8);
  EXPECT_FALSE(reads[0].word.field_mark);
  EXPECT_EQ(reads[1].row, 9);
  EXPECT_TRUE(reads[1].word.field_mark);
  EXPECT_EQ(reads[0].word.time, (take::Timecode{0, 0, 10, 5}));
  // Nothing on a frame without VITC.
  cv::Mat blank(40, 640, CV_8UC1, cv::Scalar(16));
  rng.fill(blank, cv::RNG::UNIFORM, 0, 256);
  EXPECT_FALSE(decoder.ReadFirst(blank));
}

}  // namespace
}  // namespace dome::capture
