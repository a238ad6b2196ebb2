// Foreground masks from a background image: a colour model robust to lighting and
// shadows, and the morphological clean-up of its raw decisions.
//
// Images: 8-bit gray (CV_8UC1) or BGR (CV_8UC3), the camera's own pixel grid (no
// undistortion: a mask is used where its image is). A mask is CV_8UC1, 255 = foreground
// (what moves: the people), 0 = background, the size of its image.
//
// The model (after Horprasert, Harwood and Davis, "A statistical approach for real-time
// robust background subtraction and shadow detection", ICCV FRAME-RATE workshop 1999).
// Each pixel's colour I (one value per channel) is compared with the background's B:
//   brightness distortion  alpha = argmin_a |(I - a B) / sigma|^2   (1 = as bright as B)
//   chromaticity distortion CD   = |(I - alpha B) / sigma|          (noise units)
// where sigma (per channel, grey levels) is the noise of I - B estimated from the image
// pair itself (NoiseSigma below). A shadow or a dimmer lamp scales B (alpha < 1) without
// changing its colour (small CD); a person changes the colour, or the brightness by more
// than a shadow can. The whole image's brightness may change between the plate and the
// frame (exposure, lamps): alpha is taken relative to the global gain g (GlobalGain:
// the median brightness ratio, which the background, most of the image, fixes).
//
// A pixel is strongly foreground when, with t1 and t2 the thresholds of ForegroundOptions:
//   CD > t2                                   (colour changed; BGR only), or
//   alpha / g outside [shadow_min, 1 / shadow_min] and |alpha / g - 1| |B / sigma| > t1
//                                             (darker than a shadow, or brighter than a
//                                             shadow's removal can make it).
// Brightening is tolerated like darkening (Horprasert's "highlighted background"): a
// median background can hold the shadow a person cast in most of the instants, and the
// lit floor where that shadow has gone is background.
// A grey image has no chromaticity (CD is 0), so nothing tells a shadow from a darker
// person: on gray images any brightness change beyond t1 noise units is foreground. Pixels past
// the weak thresholds join the foreground when connected to a strong pixel (hysteresis).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace dome::silhouette {

struct ForegroundOptions {
  // Probability that a background pixel with Gaussian noise is called foreground, per
  // pixel (dimensionless). The thresholds follow from it: t1 the two-sided normal
  // quantile (brightness, 1 degree of freedom), t2 = sqrt(-2 ln p) the chi quantile with
  // 2 degrees of freedom (chromaticity of BGR: 3 channels less the brightness).
  // 1e-4 leaves ~2 isolated false pixels in a 160x120 image and ~200 in a 1920x1080 one,
  // which the clean-up's component rule removes.
  double false_alarm_per_pixel = 1e-4;
  // The same for the weak thresholds of the hysteresis: a pixel past them is
  // foreground when 8-connected to one past the strong thresholds. Background pixels
  // next to the person pass them at this rate (1 in 100 of the silhouette's outer
  // ring); the person's edge pixels, half person and half background, show only half
  // the contrast and need them. The weak thresholds are the strong ones times
  // WeakRatio() (the ratio of the normal quantiles, used for both tests).
  double weak_false_alarm_per_pixel = 0.01;
  // Smallest brightness ratio alpha / g a shadow leaves (dimensionless, 0..1): a pixel
  // darkened below this is foreground whatever its colour. The dome is lit from many
  // directions, so a person's shadow dims the floor by a third at most: in the Panoptic
  // dome the pixels a bound of 0.85 adds to the masks are the floor beside the feet,
  // those 0.7 adds are dark clothes of the floor's colour (trousers, a jacket), which a
  // bound of 0.5 left out of the hull (Panoptic leave-one-camera-out IoU 0.551 with 0.5,
  // 0.567 with 0.7; 0.582 with 0.85 and 0.511 with 0.95, the shadows in the masks).
  double shadow_min = 0.7;
  // Lowest noise estimate, grey levels: 8-bit quantisation alone leaves a difference of
  // two images a spread of ~0.4 levels, and compression or resampling more; a noise-free
  // synthetic pair must not make every one-level difference foreground.
  double sigma_floor = 1.0;

  // Throws core::InputError naming the field when out of range.
  void Check() const;
  // t1 and t2 above, noise units.
  double BrightnessThreshold() const;
  double ChromaThreshold() const;
  double WeakRatio() const;
};

// What ClassifyForeground found, for reports.
struct ForegroundStats {
  std::vector<double> sigma;  // per channel, grey levels
  double gain = 1.0;          // g: median brightness ratio image / background
  double fraction = 0.0;      // raw foreground pixels / valid pixels
};

// The global gain g: the median over `valid` pixels (empty = all) of the brightness
// ratio (I.B) / (B.B), pixels with a background under 16 grey levels left out.
// Robust while the foreground is under half the valid pixels.
double GlobalGain(const cv::Mat& image, const cv::Mat& background, const cv::Mat& valid);

// The noise of image - gain x background per channel, grey levels: 1.4826 x the median
// absolute deviation of the difference (rounded to whole levels, the median interpolated
// within its level) over `valid` pixels (empty = all), floored at `floor`. Robust while
// the foreground is under half the valid pixels. `skip_zero`: differences of exactly 0
// are left out -- for a background that is a median of few images including `image`,
// where the image *is* the median at many background pixels (a third of them for three
// images) and those zeros would halve the estimate; what remains is the image's spread
// about the median when it is not the middle value, an over-estimate that errs towards
// fewer false foreground pixels.
std::vector<double> NoiseSigma(const cv::Mat& image, const cv::Mat& background,
                               const cv::Mat& valid, double gain, double floor, bool skip_zero);

// The raw decision per pixel (255 foreground) of `image` against `background` (same
// size and type, CV_8UC1 or CV_8UC3). `valid` (CV_8UC1, nonzero = has data, or empty
// for all) excludes pixels without data: they are background. `background_includes_image`:
// the background is a median over images that include this one (NoiseSigma's
// skip_zero). Throws core::InputError when the sizes or types differ.
cv::Mat ClassifyForeground(const cv::Mat& image, const cv::Mat& background, const cv::Mat& valid,
                           const ForegroundOptions& options, bool background_includes_image,
                           ForegroundStats* stats = nullptr);

struct CleanupOptions {
  // Connected foreground pieces (8-connected) smaller than this fraction of the image's
  // pixels are dropped: the false-alarm rate makes isolated false pixels and pairs, and
  // a person in a dome camera covers far more. Dropping by area instead of opening
  // keeps thin parts (a bat or an arm two pixels across).
  double min_component_fraction = 2e-4;
  // Radius, pixels, of the closing (dilate then erode with a disc) that bridges cracks
  // where the person's colour matches the background, as a fraction of the image
  // diagonal, at least 1 pixel.
  double close_radius_fraction = 0.002;
  // Background holes (4-connected, not touching the border) smaller than this fraction
  // of the image's pixels are filled: camouflage inside the body. Larger holes (the gap
  // between an arm and the body, between legs) stay.
  double max_hole_fraction = 2e-4;

  void Check() const;
  int CloseRadiusPx(cv::Size size) const;
};

// The clean-up in this order: drop small components, close, fill small holes. Returns
// a new mask (255 / 0). `valid`, when given, clears pixels without data at the end.
cv::Mat CleanMask(const cv::Mat& raw, const cv::Mat& valid, const CleanupOptions& options);

// The per-pixel median over `images` (same size and type, CV_8UC1 or CV_8UC3, at least
// one): for an odd count the middle value, for an even count the lower middle one (a
// value that occurs). Per channel.
cv::Mat MedianImage(const std::vector<cv::Mat>& images);

// The background of a few images of one camera (the median background's instants):
//
//   1. M = MedianImage(images), and sigma per channel = the median over the images of
//      NoiseSigma(image, M, skip_zero).
//   2. A pixel is settled where at least three quarters of the images (rounded up) lie
//      within t noise units of M in every channel, t the two-sided normal quantile of
//      agree_false_alarm / channels: there M is the background, as a plain median.
//   3. Elsewhere the median may be wrong: with three images, two people (or one
//      standing still) at a pixel in two of them make the median a person's colour,
//      which hides them and marks the third image's floor as foreground. The settled
//      pixels' M, less the settled parts narrower than a limb (fill_open_fraction), is
//      filled smoothly into the others (push-pull over an image pyramid,
//      FillFromSettled), and the background there is the image whose colour is nearest
//      that fill (largest channel difference in noise units), if it lies within
//      fill_tolerance x t of it; else the median stands (a texture the fill cannot
//      follow, or people in every image). Where no pixel is settled the median stands.
// The dome's floor and walls are smooth over the extent of a person, which is what
// makes the fill a fair arbiter. It errs where the background is not smooth at that
// scale: a person in front of a dark doorway in one image, the doorway in two, and the
// fill a blend of doorway and wall nearer the person's colour. On Panoptic's five
// cameras (three instants; bench/silhouette/panoptic_loo.sh) the reconstructions'
// mean leave-one-out IoU was 0.453 with this background against 0.393 with the plain
// median (the plain visual hull's 0.448 against 0.384), before the fill's data were
// opened (fill_open_fraction: 0.551, the plain hull 0.550). The figures below are
// from before the opening. Letting the median stand
// wherever it lies within a band widened by the settled pixels' local spread (which
// keeps the doorway) gave 0.415-0.429: the spread is taken over the fill's whole
// reach, a person's size, and holds walls, doors and light bars that the floor lacks.
// Arbitrating by the other cameras instead (a pixel whose ray misses, at an instant,
// everything the other cameras' first masks place in the room takes that instant's
// colour) gave 0.469 on Panoptic, but it cannot tell which cameras are wrong: with a person
// still at two of three instants, every camera's median holds them, their first masks
// place a phantom where the person went and clear the rays where the person is, and on
// the small synthetic dome the pixels found to be the room fell from 55-63 % to 43-57 %
// of the person's (four of its cameras). Leaving the fill's choices alone removed the
// harm with the gain (0.451); counting background votes only where a camera's instants
// agree lost the gain (0.446) and kept the harm (40-57 % from 55-68 %, six cameras).
struct ConsensusOptions {
  // Probability, per pixel and image, that noise alone puts an image that shows the
  // background outside the agreement band of step 2 (dimensionless).
  double agree_false_alarm = 1e-3;
  // How far from the fill (in multiples of t) an image's colour may be and still be
  // taken as the background at an unsettled pixel: the background's own texture
  // departs from a smooth fill by more than noise (dimensionless).
  double fill_tolerance = 4.0;
  double sigma_floor = 1.0;  // grey levels, as ForegroundOptions::sigma_floor
  // Radius of the opening (erode then dilate with a disc) of the settled pixels before
  // they are filled from, as a fraction of the image diagonal (0: no opening). Inside
  // the region the people crossed, pixels where every instant happens to agree (dark
  // clothes of two people over a third's shadow, a dark mark under a dark shirt) are
  // settled in specks and strips; as the fill's only data there they pull it to a
  // person's colour, which then picks the person as the background (on Panoptic camera
  // 00_03 the fill held dark blobs where a person stood in one of three instants). The
  // rule: the fill takes only settled parts at least a limb's width across, and a limb
  // is about 3 % of a dome camera's diagonal for a person standing in the middle (a
  // person is a fifth to a half of the frame's height), so the radius is half that.
  // Panoptic's leave-one-out IoU (bench/silhouette/panoptic_loo.sh) by radius: 0:
  // 0.453, 0.002: 0.477, 0.004: 0.508, 0.008: 0.533, 0.016: 0.551, 0.03: 0.536. The
  // synthetic dome's median masks against the truth (plates hidden): 0.723 -> 0.752
  // (paper take, 11 instants), 0.523 -> 0.530 (3 instants), 0.474 -> 0.466 (small).
  double fill_open_fraction = 0.016;

  void Check() const;
  int FillOpenRadiusPx(cv::Size size) const;
};

// What ConsensusBackground found, for reports and tests.
struct ConsensusStats {
  double settled_fraction = 0.0;  // pixels settled by agreement
  double chosen_fraction = 0.0;   // unsettled pixels that took the image nearest the fill
  double changed_fraction = 0.0;  // of those, where it is more than t noise units from M
};

// `images`: at least one, same size and type (CV_8UC1 or CV_8UC3).
cv::Mat ConsensusBackground(const std::vector<cv::Mat>& images, const ConsensusOptions& options,
                            ConsensusStats* stats = nullptr);

// `values` (CV_32FC(n)) filled where `known` (CV_8UC1, nonzero) is 0 from the known
// values around: averaged down an image pyramid (2x2 blocks, weighted by knownness)
// until every level-pixel has data, then blended back up with bilinear upsampling.
// Known pixels keep their values exactly. No known pixel at all: zeros.
cv::Mat FillFromSettled(const cv::Mat& values, const cv::Mat& known);

// Intersection over union of two masks (nonzero = foreground); 1 when both are empty.
double MaskIoU(const cv::Mat& a, const cv::Mat& b);

}  // namespace dome::silhouette
