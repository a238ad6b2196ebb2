#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <random>

#include "io/image_io.h"
#include "silhouette/background.h"
#include "silhouette/take_masks.h"
#include "synth/synth.h"
#include "take/take.h"
#include "take/validate.h"
#include "take_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::silhouette {
namespace {

namespace fs = std::filesystem;
using dome::testing::ExpectInputError;

// A textured colour background (smooth blobs of every hue), deterministic.
cv::Mat TexturedBackground(cv::Size size, unsigned seed) {
  cv::Mat small(size.height / 8 + 1, size.width / 8 + 1, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(small, cv::RNG::UNIFORM, cv::Scalar::all(40), cv::Scalar::all(220));
  cv::Mat out;
  cv::resize(small, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

cv::Mat AddNoise(const cv::Mat& image, double sigma, unsigned seed) {
  cv::Mat noise(image.size(), CV_32FC(image.channels()));
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(sigma));
  cv::Mat f, out;
  image.convertTo(f, CV_32F);
  f += noise;
  f.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

TEST(Foreground, ShadowsAndGlobalLightingAreBackgroundColourChangesAreNot) {
  const cv::Size size(200, 150);
  const cv::Mat plate = TexturedBackground(size, 1);
  cv::Mat frame = plate.clone();
  // A shadow: the background at 80 % brightness, same colour (a dome's lamps leave
  // shadows above ForegroundOptions::shadow_min).
  const cv::Rect shadow(20, 20, 60, 40);
  frame(shadow) = plate(shadow) * 0.8;
  // A dark cloth of the background's colour: at 55 % brightness, darker than a shadow.
  const cv::Rect cloth(20, 100, 20, 20);
  frame(cloth) = plate(cloth) * 0.55;
  // A person: a saturated colour unlike the background's.
  const cv::Rect person(120, 60, 30, 70);
  frame(person).setTo(cv::Scalar(30, 160, 60));
  // The whole frame 10 % brighter (exposure), then sensor noise on both.
  frame = frame * 1.1;
  const cv::Mat noisy_plate = AddNoise(plate, 2.0, 2), noisy_frame = AddNoise(frame, 2.0, 3);
  ForegroundOptions options;
  ForegroundStats stats;
  const cv::Mat raw =
      ClassifyForeground(noisy_frame, noisy_plate, cv::Mat(), options, false, &stats);
  EXPECT_NEAR(stats.gain, 1.1, 0.01);
  ASSERT_EQ(stats.sigma.size(), 3u);
  // Both images' noise: sqrt(1 + 1.1^2) x 2 = 2.97 levels; the shadow, the person and the cloth
  // (16 % of the pixels) widen the spread the median absolute deviation sees a little.
  for (double s : stats.sigma) {
    EXPECT_GT(s, 2.97);
    EXPECT_LT(s, 2.97 * 1.3);
  }
  cv::Mat truth = cv::Mat::zeros(size, CV_8UC1);
  truth(person).setTo(255);
  truth(cloth).setTo(255);
  EXPECT_GT(MaskIoU(raw, truth), 0.97);
  EXPECT_LT(cv::countNonZero(raw(shadow)), 5);  // the shadow is background
  // Plain differencing (the threshold on |I - B| alone) would take the shadow.
  const cv::Mat clean = CleanMask(raw, cv::Mat(), CleanupOptions{});
  EXPECT_GT(MaskIoU(clean, truth), 0.995);
}

TEST(Foreground, GrayImagesHaveNoShadowToleranceAndTooDarkIsForeground) {
  const cv::Size size(120, 100);
  cv::Mat plate;
  cv::cvtColor(TexturedBackground(size, 5), plate, cv::COLOR_BGR2GRAY);
  cv::Mat frame = plate.clone();
  const cv::Rect darker(10, 10, 30, 30);
  frame(darker) = plate(darker) * 0.7;
  const cv::Mat raw = ClassifyForeground(AddNoise(frame, 1.5, 7), AddNoise(plate, 1.5, 8),
                                         cv::Mat(), ForegroundOptions{}, false);
  EXPECT_GT(cv::countNonZero(raw(darker)), 0.95 * darker.area());
  EXPECT_LT(cv::countNonZero(raw) - cv::countNonZero(raw(darker)), 10);
}

TEST(Foreground, ThresholdsFollowFromTheFalseAlarmRate) {
  ForegroundOptions options;
  options.false_alarm_per_pixel = 0.05;
  EXPECT_NEAR(options.BrightnessThreshold(), 1.959964, 1e-5);
  EXPECT_NEAR(options.ChromaThreshold(), std::sqrt(-2.0 * std::log(0.05)), 1e-12);
  options.false_alarm_per_pixel = 0.7;
  ExpectInputError([&] { options.Check(); }, {"false_alarm_per_pixel", "(0, 0.5)"});
}

TEST(Cleanup, DropsSpecklesKeepsThinPartsFillsSmallHoles) {
  cv::Mat raw = cv::Mat::zeros(200, 200, CV_8UC1);
  raw(cv::Rect(50, 50, 40, 80)).setTo(255);  // body
  raw(cv::Rect(90, 60, 40, 2)).setTo(255);   // a bat two pixels thick
  raw(cv::Rect(60, 70, 2, 2)).setTo(0);      // a 4-pixel hole: filled
  raw(cv::Rect(60, 100, 20, 20)).setTo(0);   // a 400-pixel hole: kept
  raw.at<uint8_t>(10, 10) = 255;             // speckle
  raw.at<uint8_t>(150, 170) = 255;
  CleanupOptions options;  // 200x200: components < 8 px go, holes <= 8 px are filled
  const cv::Mat clean = CleanMask(raw, cv::Mat(), options);
  EXPECT_EQ(clean.at<uint8_t>(10, 10), 0);
  EXPECT_EQ(clean.at<uint8_t>(150, 170), 0);
  EXPECT_EQ(cv::countNonZero(clean(cv::Rect(90, 60, 40, 2))), 80);  // the bat stays
  EXPECT_EQ(cv::countNonZero(clean(cv::Rect(60, 70, 2, 2))), 4);
  EXPECT_EQ(cv::countNonZero(clean(cv::Rect(62, 102, 16, 16))), 0);
}

TEST(Median, IsThePerPixelMiddleValue) {
  std::vector<cv::Mat> images;
  for (int v : {9, 3, 200}) images.push_back(cv::Mat(2, 2, CV_8UC3, cv::Scalar(v, 255 - v, v / 2)));
  const cv::Mat m = MedianImage(images);
  EXPECT_EQ(m.at<cv::Vec3b>(1, 1), cv::Vec3b(9, 246, 4));
  images.pop_back();  // even count: the lower middle
  EXPECT_EQ(MedianImage(images).at<cv::Vec3b>(0, 0), cv::Vec3b(3, 246, 1));
  EXPECT_EQ(MedianInstants({"a", "b", "c", "d", "e"}, 3),
            (std::vector<std::string>{"a", "c", "e"}));
}

TEST(FillFromSettled, KnownPixelsStayAndAGradientIsFilledAcrossAHole) {
  // A horizontal ramp 40..200 over 200 columns with a 60x60 hole: the fill across it
  // follows the ramp to within a third of its rise there (push-pull blends the hole's
  // borders, so it is flatter than the ramp).
  cv::Mat values(120, 200, CV_32FC3), known(120, 200, CV_8UC1, cv::Scalar(255));
  for (int y = 0; y < values.rows; ++y)
    for (int x = 0; x < values.cols; ++x)
      values.at<cv::Vec3f>(y, x) = cv::Vec3f::all(40 + 0.8f * x);
  known(cv::Rect(70, 30, 60, 60)).setTo(0);
  cv::Mat holed = values.clone();
  holed(cv::Rect(70, 30, 60, 60)).setTo(cv::Scalar::all(0));
  const cv::Mat fill = FillFromSettled(holed, known);
  double worst_known = 0, worst_hole = 0;
  for (int y = 0; y < values.rows; ++y) {
    for (int x = 0; x < values.cols; ++x) {
      const double d =
          cv::norm(fill.at<cv::Vec3f>(y, x) - values.at<cv::Vec3f>(y, x), cv::NORM_INF);
      (known.at<uint8_t>(y, x) ? worst_known : worst_hole) =
          std::max(known.at<uint8_t>(y, x) ? worst_known : worst_hole, d);
    }
  }
  EXPECT_EQ(worst_known, 0.0);
  EXPECT_LT(worst_hole, 16.0);  // a third of the 48 levels the ramp rises across the hole
  // Nothing known: zeros.
  const cv::Mat none = FillFromSettled(values, cv::Mat::zeros(values.size(), CV_8UC1));
  EXPECT_EQ(cv::norm(none, cv::NORM_INF), 0.0);
}

// A smooth BGR floor: blue rises along x and green along y from `base`, red is base + 20.
cv::Mat SmoothFloor(cv::Size size, int base) {
  cv::Mat floor(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      floor.at<cv::Vec3b>(y, x) = cv::Vec3b(base + x / 10, base + 10 + y / 10, base + 20);
  return floor;
}

// Three images of a smooth floor with noise; two dark people stand on the same spot in
// images 0 and 1 (their colours a little apart), a third elsewhere in image 2. The
// plain median there is a person's colour; the consensus is the floor everywhere.
TEST(ConsensusBackground, TwoPeopleOnOneSpotLeaveTheFloorNotTheirColour) {
  const cv::Size size(200, 150);
  const cv::Mat floor = SmoothFloor(size, 70);
  const cv::Rect spot(60, 40, 40, 70), elsewhere(140, 30, 30, 60);
  std::vector<cv::Mat> images;
  for (int k = 0; k < 3; ++k) {
    cv::Mat im = floor.clone();
    if (k == 0) im(spot).setTo(cv::Scalar(25, 28, 30));
    if (k == 1) im(spot).setTo(cv::Scalar(30, 30, 27));
    if (k == 2) im(elsewhere).setTo(cv::Scalar(20, 150, 200));
    images.push_back(AddNoise(im, 1.5, 7 + k));
  }
  const cv::Mat median = MedianImage(images);
  ConsensusStats stats;
  const cv::Mat consensus = ConsensusBackground(images, ConsensusOptions{}, &stats);
  auto error = [&](const cv::Mat& background, const cv::Rect& r) {
    cv::Mat diff;
    cv::absdiff(background(r), floor(r), diff);
    return cv::norm(diff, cv::NORM_INF);
  };
  EXPECT_GT(error(median, spot), 40.0);    // the plain median holds the people
  EXPECT_LE(error(consensus, spot), 8.0);  // image 2's floor, noise only
  EXPECT_LE(error(consensus, elsewhere), 8.0);
  EXPECT_NEAR(stats.settled_fraction, 1.0 - (spot.area() + elsewhere.area()) / double(size.area()),
              0.01);
  EXPECT_NEAR(stats.chosen_fraction, (spot.area() + elsewhere.area()) / double(size.area()), 0.01);
  // Only on the spot does the chosen colour differ from the median's.
  EXPECT_NEAR(stats.changed_fraction, spot.area() / double(size.area()), 0.005);
  // The masks of image 2 against each: a phantom where the people stood with the
  // median, none with the consensus.
  const cv::Mat with_median =
      ClassifyForeground(images[2], median, cv::Mat(), ForegroundOptions{}, true);
  const cv::Mat with_consensus =
      ClassifyForeground(images[2], consensus, cv::Mat(), ForegroundOptions{}, true);
  EXPECT_GT(cv::countNonZero(with_median(spot)), spot.area() / 2);
  EXPECT_EQ(cv::countNonZero(with_consensus(spot)), 0);
  // And image 0's person is found with the consensus only.
  EXPECT_LT(cv::countNonZero(
                ClassifyForeground(images[0], median, cv::Mat(), ForegroundOptions{}, true)(spot)),
            spot.area() / 2);
  EXPECT_GT(cv::countNonZero(ClassifyForeground(images[0], consensus, cv::Mat(),
                                                ForegroundOptions{}, true)(spot)),
            spot.area() * 95 / 100);
}

// Image 0 shows a dark person over a floor that images 1 and 2 show; a small dark mark
// on the floor lies under the person, where the person's colour matches it in every
// image, so those pixels are settled. As the fill's only data inside the person they
// would pull it dark and make the person the background around the mark
// (fill_open_fraction 0); the opening leaves the fill to the floor around.
TEST(ConsensusBackground, SettledSpecksInsideAPersonDoNotMakeThePersonTheBackground) {
  const cv::Size size(200, 150);
  cv::Mat floor = SmoothFloor(size, 150);
  const cv::Rect person(60, 40, 60, 70), mark(86, 71, 8, 8);
  floor(mark).setTo(cv::Scalar(26, 28, 30));
  std::vector<cv::Mat> images;
  for (int k = 0; k < 3; ++k) {
    cv::Mat im = floor.clone();
    if (k == 0) im(person).setTo(cv::Scalar(26, 28, 30));
    images.push_back(AddNoise(im, 1.5, 11 + k));
  }
  // Pixels of the person's rectangle whose background is not the floor's (noise aside).
  auto wrong = [&](const ConsensusOptions& options) {
    const cv::Mat b = ConsensusBackground(images, options);
    cv::Mat diff;
    cv::absdiff(b(person), floor(person), diff);
    std::vector<cv::Mat> channels;
    cv::split(diff, channels);
    const cv::Mat worst = cv::max(cv::max(channels[0], channels[1]), channels[2]);
    return cv::countNonZero(worst > 8);
  };
  ConsensusOptions no_opening;
  no_opening.fill_open_fraction = 0.0;
  EXPECT_GT(wrong(no_opening), 100);
  EXPECT_EQ(wrong(ConsensusOptions{}), 0);
  ConsensusOptions o;
  o.fill_open_fraction = 0.2;
  ExpectInputError([&] { o.Check(); }, {"ConsensusOptions: fill_open_fraction", "[0, 0.05]"});
}

// Three images that agree nowhere (each a different flat grey): no pixel is settled,
// nothing to fill from, and the background is the median (not the image nearest an
// empty fill's zeros, the darkest).
TEST(ConsensusBackground, NothingAgreedLeavesTheMedian) {
  std::vector<cv::Mat> images;
  for (int v : {5, 120, 200}) images.push_back(cv::Mat(30, 40, CV_8UC3, cv::Scalar::all(v)));
  ConsensusStats stats;
  const cv::Mat b = ConsensusBackground(images, ConsensusOptions{}, &stats);
  EXPECT_EQ(cv::norm(b, MedianImage(images), cv::NORM_INF), 0.0);
  EXPECT_EQ(stats.settled_fraction, 0.0);
  EXPECT_EQ(stats.chosen_fraction, 0.0);
}

TEST(ConsensusOptions, OutOfRangeIsNamed) {
  ConsensusOptions o;
  o.agree_false_alarm = 0.7;
  ExpectInputError([&] { ConsensusBackground({cv::Mat(4, 4, CV_8UC1)}, o); },
                   {"ConsensusOptions: agree_false_alarm", "(0, 0.5)"});
  o = ConsensusOptions{};
  o.fill_tolerance = 0.5;
  ExpectInputError([&] { o.Check(); }, {"ConsensusOptions: fill_tolerance", "[1, 100)"});
}

// A take of 3 cameras whose colour frames show a square moving over a textured
// background: given `instants`, the square at a different place in each.
struct MovingSquareTake {
  dome::testing::TempDir temp;
  fs::path dir;
  geometry::Rig rig = take::testing::MakeRingRig(3, 160, 120);
  std::vector<cv::Mat> truth;  // per instant, the square
  explicit MovingSquareTake(int instants) {
    dir = take::testing::WriteTake(temp / "take", rig, instants);
    const take::Take take = take::OpenTake(dir);
    const cv::Mat plate = TexturedBackground({160, 120}, 11);
    for (int k = 0; k < instants; ++k) {
      cv::Mat t = cv::Mat::zeros(120, 160, CV_8UC1);
      t(cv::Rect(10 + 45 * k, 30, 25, 60)).setTo(255);
      truth.push_back(t);
      for (const auto& cam : rig.cameras) {
        cv::Mat frame = plate.clone();
        frame.setTo(cv::Scalar(200, 40, 90), t);
        io::WriteImage(take.FramePath(take.instants[k], cam.model.id),
                       AddNoise(frame, 1.5, 100 * k + cam.model.id.back()));
      }
    }
  }
};

TEST(TakeMasks, MedianOfThreeInstantsFindsTheMovingSquare) {
  MovingSquareTake t(3);
  TakeMasks masks(take::OpenTake(t.dir), MaskOptions{});
  const auto& instants = masks.take().instants;
  for (const auto& cam : t.rig.cameras) {
    EXPECT_EQ(masks.Source(cam.model.id), MaskSource::kMedian);
    for (size_t k = 0; k < instants.size(); ++k) {
      MaskInfo info;
      const cv::Mat mask = masks.Mask(instants[k], cam.model.id, &info);
      EXPECT_GT(MaskIoU(mask, t.truth[k]), 0.98) << cam.model.id << " " << instants[k];
      EXPECT_NEAR(info.fraction, 25.0 * 60 / (160 * 120), 0.01);
    }
    // The three squares' pixels disagree; the median is right there and stands.
    const ConsensusStats b = masks.BackgroundConsensus(cam.model.id);
    EXPECT_NEAR(b.settled_fraction, 1.0 - 3 * 25.0 * 60 / (160 * 120), 0.02) << cam.model.id;
    EXPECT_LT(b.changed_fraction, 0.005) << cam.model.id;
  }
}

// A reader given to TakeMasks is how it reads every frame: the median background reads
// each camera's three instants through it, each mask its own frame again (the session's
// derivation hands out each decoded frame once, pipeline/derive.cc), and the masks are
// those of the files read directly. The frames seen are those the masks are made from.
TEST(TakeMasks, FramesAreReadThroughTheGivenReader) {
  MovingSquareTake t(3);
  TakeMasks plain(take::OpenTake(t.dir), MaskOptions{});
  TakeMasks read(take::OpenTake(t.dir), MaskOptions{});
  std::map<std::string, int> reads, seen;
  read.SetFrameReader([&reads](const fs::path& path) {
    ++reads[path.filename().string() + "@" + path.parent_path().filename().string()];
    return io::ReadImage(path, io::ImageMode::kUnchanged);
  });
  read.SetFrameSeen([&seen](const fs::path& path, const cv::Mat& image) {
    EXPECT_EQ(image.size(), cv::Size(160, 120)) << path;
    ++seen[path.filename().string() + "@" + path.parent_path().filename().string()];
  });
  const auto& instants = plain.take().instants;
  const std::string& camera = t.rig.cameras[1].model.id;
  for (const auto& instant : instants) {
    const cv::Mat a = plain.Mask(instant, camera), b = read.Mask(instant, camera);
    EXPECT_EQ(cv::countNonZero(a != b), 0) << instant;
  }
  ASSERT_EQ(reads.size(), 3u);
  for (const auto& instant : instants) {
    const std::string key = camera + ".png@" + instant;
    EXPECT_EQ(reads[key], 2) << key;  // the median's, then the mask's
    EXPECT_EQ(seen[key], 1) << key;
  }
}

TEST(TakeMasks, TwoInstantsWithoutPlatesOrMasksIsANamedError) {
  MovingSquareTake t(2);
  ExpectInputError([&] { TakeMasks(take::OpenTake(t.dir), MaskOptions{}); },
                   {(t.dir / "frames").string(), "2 instant(s)", "at least 3", "background/c0.png",
                    "masks/<instant>/c0.png"});
  // A plate for every camera makes the same take work.
  const cv::Mat plate = TexturedBackground({160, 120}, 11);
  fs::create_directories(t.dir / "background");
  for (const auto& cam : t.rig.cameras)
    io::WriteImage(t.dir / "background" / (cam.model.id + ".png"), plate);
  TakeMasks masks(take::OpenTake(t.dir), MaskOptions{});
  EXPECT_EQ(masks.Source("c1"), MaskSource::kPlate);
  EXPECT_GT(MaskIoU(masks.Mask(masks.take().instants[1], "c1"), t.truth[1]), 0.98);
}

TEST(TakeMasks, GivenMasksComeFirstAndAreCheckedForSize) {
  MovingSquareTake t(3);
  const take::Take take = take::OpenTake(t.dir);
  for (size_t k = 0; k < take.instants.size(); ++k) {
    fs::create_directories(t.dir / "masks" / take.instants[k]);
    io::WriteImage(t.dir / "masks" / take.instants[k] / "c2.png", t.truth[k] / 255);  // 0/1
  }
  {
    TakeMasks masks(take, MaskOptions{});
    EXPECT_EQ(masks.Source("c2"), MaskSource::kGiven);
    EXPECT_EQ(masks.Source("c0"), MaskSource::kMedian);
    const cv::Mat m = masks.Mask(take.instants[1], "c2");
    EXPECT_EQ(cv::countNonZero(m != t.truth[1]), 0);  // nonzero reads as 255
  }
  const fs::path bad = t.dir / "masks" / take.instants[2] / "c2.png";
  io::WriteImage(bad, cv::Mat::zeros(100, 160, CV_8UC1));
  ExpectInputError([&] { TakeMasks(take, MaskOptions{}); },
                   {bad.string(), "image is 160x100", "camera 'c2' is 160x120"});
  fs::remove(bad);
  ExpectInputError([&] { TakeMasks(take, MaskOptions{}); },
                   {bad.string(), "missing", "every instant needs one"});
  // take validation names it too
  io::WriteImage(bad, cv::Mat::zeros(100, 160, CV_8UC1));
  const take::TakeReport report = take::ValidateTake(t.dir);
  ASSERT_EQ(report.problems.size(), 1u) << report.Summary();
  EXPECT_EQ(report.problems[0].where, bad.string());
  EXPECT_EQ(report.mask_instants, 3);
}

TEST(TakeMasks, PlateOfTheWrongSizeIsANamedError) {
  MovingSquareTake t(3);
  const fs::path plate = t.dir / "background" / "c1.png";
  fs::create_directories(plate.parent_path());
  io::WriteImage(plate, cv::Mat::zeros(120, 161, CV_8UC3));
  ExpectInputError([&] { TakeMasks(take::OpenTake(t.dir), MaskOptions{}); },
                   {plate.string(), "image is 161x120", "camera 'c1' is 160x120"});
  const take::TakeReport report = take::ValidateTake(t.dir);
  ASSERT_EQ(report.problems.size(), 1u) << report.Summary();
  EXPECT_EQ(report.problems[0].Text(),
            plate.string() + ": image is 161x120, rig.json says camera 'c1' is 160x120");
}

// The synthetic dome's small preset: masks from its background plates against the
// truth masks, every camera and instant. The images are gray 160x120 and the person
// ~700 pixels: what the masks miss is at the silhouette's edge (pixels half person,
// half a background of similar grey), so the issue's goal of 0.98 is not reached here;
// the figures measured are 0.93-0.98 per camera and instant, mean 0.96.
TEST(TakeMasks, SyntheticPlatesGiveTheTruthMasks) {
  dome::testing::TempDir temp;
  synth::SynthOptions options;
  options.preset = "small";
  options.threads = 2;
  options.write_tape = false;
  options.write_calibration = false;
  synth::GenerateTake(options, temp / "take");
  const take::TakeReport report = take::ValidateTake(temp / "take");
  EXPECT_TRUE(report.ok()) << report.Summary();
  EXPECT_EQ(report.background_plates, 6);
  TakeMasks masks(take::OpenTake(temp / "take"), MaskOptions{});
  double sum = 0.0;
  int count = 0;
  for (const auto& cam : masks.take().rig.cameras) {
    const std::string& id = cam.model.id;
    EXPECT_EQ(masks.Source(id), MaskSource::kPlate);
    for (const auto& instant : masks.take().instants) {
      const cv::Mat truth = io::ReadImage(
          temp / "take" / "truth" / instant / "mask" / (id + ".png"), io::ImageMode::kGray8);
      ASSERT_GT(cv::countNonZero(truth), 400) << id << " sees the person";
      const cv::Mat mask = masks.Mask(instant, id);
      const double iou = MaskIoU(mask, truth);
      cv::Mat inner, outer;
      cv::erode(truth, inner, cv::Mat());
      cv::dilate(truth, outer, cv::Mat());
      const cv::Mat boundary = outer & ~inner;
      std::printf("%s %s IoU %.4f  truth %d  false fg %d (%d at the boundary)  missed %d (%d)\n",
                  instant.c_str(), id.c_str(), iou, cv::countNonZero(truth),
                  cv::countNonZero(mask & ~truth), cv::countNonZero(mask & ~truth & boundary),
                  cv::countNonZero(truth & ~mask), cv::countNonZero(truth & ~mask & boundary));
      EXPECT_GE(iou, 0.92) << id << " " << instant;
      // Nearly all false foreground is at the edge: nothing far from the person.
      EXPECT_LE(cv::countNonZero(mask & ~outer), 2) << id << " " << instant;
      sum += iou;
      ++count;
    }
  }
  EXPECT_GE(sum / count, 0.95);
}

}  // namespace
}  // namespace dome::silhouette
