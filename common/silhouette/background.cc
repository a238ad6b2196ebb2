#include "silhouette/background.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/error.h"

namespace dome::silhouette {
namespace {

using core::Require;

std::string SizeText(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " with " +
         std::to_string(m.channels()) + " channel(s)";
}

bool IsValid(const cv::Mat& valid, int y, int x) {
  return valid.empty() || valid.at<uint8_t>(y, x) != 0;
}

// The median of a histogram of `count` values (lower middle for even counts).
int HistogramMedian(const std::vector<int64_t>& histogram, int64_t count) {
  const int64_t rank = (count - 1) / 2;
  int64_t seen = 0;
  for (size_t v = 0; v < histogram.size(); ++v) {
    seen += histogram[v];
    if (seen > rank) return static_cast<int>(v);
  }
  return static_cast<int>(histogram.size()) - 1;
}

// A radius given as a fraction of the image diagonal, in whole pixels: 0 for 0, else at
// least one pixel.
int DiagonalFractionPx(double fraction, cv::Size size) {
  if (fraction == 0.0) return 0;
  return std::max(1, static_cast<int>(std::lround(fraction * std::hypot(size.width, size.height))));
}

// The two-sided standard normal quantile: t with P(|z| > t) = p, by bisection on erfc.
double TwoSidedNormalQuantile(double p) {
  double lo = 0.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

void ForegroundOptions::Check() const {
  Require(false_alarm_per_pixel > 0.0 && false_alarm_per_pixel < 0.5,
          "ForegroundOptions: false_alarm_per_pixel",
          "expected a probability in (0, 0.5), got " + std::to_string(false_alarm_per_pixel));
  Require(weak_false_alarm_per_pixel >= false_alarm_per_pixel && weak_false_alarm_per_pixel < 0.5,
          "ForegroundOptions: weak_false_alarm_per_pixel",
          "expected a probability in [false_alarm_per_pixel, 0.5), got " +
              std::to_string(weak_false_alarm_per_pixel));
  Require(shadow_min > 0.0 && shadow_min < 1.0, "ForegroundOptions: shadow_min",
          "expected a brightness ratio in (0, 1), got " + std::to_string(shadow_min));
  Require(sigma_floor > 0.0 && sigma_floor < 64.0, "ForegroundOptions: sigma_floor",
          "expected grey levels in (0, 64), got " + std::to_string(sigma_floor));
}

double ForegroundOptions::BrightnessThreshold() const {
  return TwoSidedNormalQuantile(false_alarm_per_pixel);
}

double ForegroundOptions::WeakRatio() const {
  return TwoSidedNormalQuantile(weak_false_alarm_per_pixel) / BrightnessThreshold();
}

double ForegroundOptions::ChromaThreshold() const {
  // P(chi_2 > t) = exp(-t^2 / 2).
  return std::sqrt(-2.0 * std::log(false_alarm_per_pixel));
}

void CleanupOptions::Check() const {
  Require(min_component_fraction >= 0.0 && min_component_fraction < 0.1,
          "CleanupOptions: min_component_fraction",
          "expected a fraction of the image in [0, 0.1), got " +
              std::to_string(min_component_fraction));
  Require(close_radius_fraction >= 0.0 && close_radius_fraction < 0.05,
          "CleanupOptions: close_radius_fraction",
          "expected a fraction of the image diagonal in [0, 0.05), got " +
              std::to_string(close_radius_fraction));
  Require(max_hole_fraction >= 0.0 && max_hole_fraction < 0.1, "CleanupOptions: max_hole_fraction",
          "expected a fraction of the image in [0, 0.1), got " + std::to_string(max_hole_fraction));
}

int CleanupOptions::CloseRadiusPx(cv::Size size) const {
  return DiagonalFractionPx(close_radius_fraction, size);
}

double GlobalGain(const cv::Mat& image, const cv::Mat& background, const cv::Mat& valid) {
  const int channels = image.channels();
  std::vector<float> ratios;
  ratios.reserve(static_cast<size_t>(image.rows) * image.cols);
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* ip = image.ptr<uint8_t>(y);
    const uint8_t* bp = background.ptr<uint8_t>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (!IsValid(valid, y, x)) continue;
      double ib = 0.0, bb = 0.0;
      for (int c = 0; c < channels; ++c) {
        ib += double(ip[x * channels + c]) * bp[x * channels + c];
        bb += double(bp[x * channels + c]) * bp[x * channels + c];
      }
      // Below 16 grey levels a ratio is mostly noise.
      if (bb >= 256.0 * channels) ratios.push_back(static_cast<float>(ib / bb));
    }
  }
  if (ratios.empty()) return 1.0;
  auto mid = ratios.begin() + static_cast<std::ptrdiff_t>((ratios.size() - 1) / 2);
  std::nth_element(ratios.begin(), mid, ratios.end());
  return *mid > 0.0f ? *mid : 1.0;
}

std::vector<double> NoiseSigma(const cv::Mat& image, const cv::Mat& background,
                               const cv::Mat& valid, double gain, double floor, bool skip_zero) {
  const int channels = image.channels();
  std::vector<double> sigma(channels, floor);
  // The histogram bin of every (background, image) level pair: the difference rounded,
  // clamped to -255..255, plus 255. A table of 64 k entries instead of a rounding per
  // pixel and channel (6 M of them for a 1920x1080 BGR image); the same bins.
  std::vector<uint16_t> bin(256 * 256);
  for (int bv = 0; bv < 256; ++bv) {
    for (int iv = 0; iv < 256; ++iv) {
      bin[size_t(bv) * 256 + size_t(iv)] =
          uint16_t(std::clamp<long>(std::lround(iv - gain * bv), -255, 255) + 255);
    }
  }
  const int zero_bin = 255;
  for (int c = 0; c < channels; ++c) {
    // Differences -255..255 in a histogram, then their absolute deviations.
    std::vector<int64_t> diff(511, 0);
    int64_t count = 0;
    for (int y = 0; y < image.rows; ++y) {
      const uint8_t* i = image.ptr<uint8_t>(y);
      const uint8_t* b = background.ptr<uint8_t>(y);
      const uint8_t* v = valid.empty() ? nullptr : valid.ptr<uint8_t>(y);
      for (int x = 0; x < image.cols; ++x) {
        if (v != nullptr && v[x] == 0) continue;
        const int k = bin[size_t(b[x * channels + c]) * 256 + i[x * channels + c]];
        if (skip_zero && k == zero_bin) continue;
        ++diff[size_t(k)];
        ++count;
      }
    }
    if (count == 0) continue;
    const int median = HistogramMedian(diff, count) - 255;
    std::vector<int64_t> deviation(511, 0);
    for (int d = 0; d < 511; ++d) deviation[std::abs(d - 255 - median)] += diff[d];
    // The median deviation, interpolated within its one-level bin (values spread
    // evenly over [v - 0.5, v + 0.5], the bin of 0 over [0, 0.5]): integer medians alone
    // would make sigma jump between multiples of 1.48.
    const int v = HistogramMedian(deviation, count);
    int64_t below = 0;
    for (int u = 0; u < v; ++u) below += deviation[u];
    const double rank = 0.5 * static_cast<double>(count);
    const double f = std::clamp((rank - below) / std::max<int64_t>(1, deviation[v]), 0.0, 1.0);
    const double mad = v == 0 ? 0.5 * f : v - 0.5 + f;
    sigma[c] = std::max(floor, 1.4826 * mad);
  }
  return sigma;
}

cv::Mat ClassifyForeground(const cv::Mat& image, const cv::Mat& background, const cv::Mat& valid,
                           const ForegroundOptions& options, bool background_includes_image,
                           ForegroundStats* stats) {
  options.Check();
  Require(image.type() == CV_8UC1 || image.type() == CV_8UC3, "ClassifyForeground: image",
          "expected an 8-bit gray or BGR image, got " + SizeText(image));
  Require(background.type() == image.type() && background.size() == image.size(),
          "ClassifyForeground: background",
          "expected the image's size and channels (" + SizeText(image) + "), got " +
              SizeText(background));
  Require(valid.empty() || (valid.type() == CV_8UC1 && valid.size() == image.size()),
          "ClassifyForeground: valid", "expected an 8-bit mask of the image's size");
  const int channels = image.channels();
  const double gain = GlobalGain(image, background, valid);
  const std::vector<double> sigma =
      NoiseSigma(image, background, valid, gain, options.sigma_floor, background_includes_image);
  std::vector<double> inv_sigma(channels);
  for (int c = 0; c < channels; ++c) inv_sigma[c] = 1.0 / sigma[c];

  // Per pixel, its score: how far past the strong thresholds its distortion is (> 1 is
  // foreground at the strong false-alarm rate), in noise units divided by the threshold.
  const double t1 = options.BrightnessThreshold();
  const double t2 = options.ChromaThreshold();
  cv::Mat score = cv::Mat::zeros(image.size(), CV_32FC1);
  int64_t valid_count = 0;
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* ip = image.ptr<uint8_t>(y);
    const uint8_t* bp = background.ptr<uint8_t>(y);
    float* sp = score.ptr<float>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (!IsValid(valid, y, x)) continue;
      ++valid_count;
      double ib = 0.0, bb = 0.0, ii = 0.0;
      for (int c = 0; c < channels; ++c) {
        const double iv = ip[x * channels + c] * inv_sigma[c];
        const double bv = bp[x * channels + c] * inv_sigma[c];
        ib += iv * bv;
        bb += bv * bv;
        ii += iv * iv;
      }
      double cd, change, ratio;
      if (bb > 1.0) {
        const double alpha = ib / bb;
        ratio = alpha / gain;
        cd = std::sqrt(std::max(0.0, ii - ib * ib / bb));
        change = (ratio - 1.0) * std::sqrt(bb);  // brightness change, noise units
      } else {
        // A background within noise of black has no colour to keep: the image's own
        // brightness is the change.
        ratio = 1.0;
        cd = 0.0;
        change = std::sqrt(ii);
      }
      double s;
      if (channels == 1) {
        s = std::abs(change) / t1;
      } else {
        // Within the shadow band [shadow_min, 1 / shadow_min] only the colour decides.
        s = cd / t2;
        if (ratio < options.shadow_min || ratio * options.shadow_min > 1.0)
          s = std::max(s, std::abs(change) / t1);
      }
      sp[x] = static_cast<float>(s);
    }
  }
  // Hysteresis (as Canny's edges): pixels past the weak thresholds are foreground when
  // 8-connected to one past the strong ones -- the person's edge pixels, half person and
  // half background, and low-contrast parts next to clear ones.
  const double weak = options.WeakRatio();
  cv::Mat candidate = score > weak;
  cv::Mat labels;
  const int count = cv::connectedComponents(candidate, labels, 8, CV_32S);
  std::vector<uint8_t> strong(count, 0);
  for (int y = 0; y < image.rows; ++y) {
    const float* sp = score.ptr<float>(y);
    const int* lp = labels.ptr<int>(y);
    for (int x = 0; x < image.cols; ++x) {
      if (sp[x] > 1.0f) strong[lp[x]] = 255;
    }
  }
  strong[0] = 0;
  cv::Mat mask(image.size(), CV_8UC1);
  int64_t foreground = 0;
  for (int y = 0; y < image.rows; ++y) {
    const int* lp = labels.ptr<int>(y);
    uint8_t* m = mask.ptr<uint8_t>(y);
    for (int x = 0; x < image.cols; ++x) {
      m[x] = strong[lp[x]];
      foreground += m[x] != 0;
    }
  }
  if (stats != nullptr) {
    stats->sigma = sigma;
    stats->gain = gain;
    stats->fraction = valid_count > 0 ? static_cast<double>(foreground) / valid_count : 0.0;
  }
  return mask;
}

cv::Mat CleanMask(const cv::Mat& raw, const cv::Mat& valid, const CleanupOptions& options) {
  options.Check();
  DOME_CHECK(raw.type() == CV_8UC1, "CleanMask: an 8-bit mask");
  const double pixels = static_cast<double>(raw.rows) * raw.cols;
  cv::Mat mask = raw.clone();
  // 1. Small components (8-connected) go: isolated false alarms.
  {
    cv::Mat labels, component_stats, centroids;
    const int count = cv::connectedComponentsWithStats(mask, labels, component_stats, centroids, 8);
    const double min_area = options.min_component_fraction * pixels;
    std::vector<uint8_t> keep(count, 0);
    for (int i = 1; i < count; ++i)
      keep[i] = component_stats.at<int>(i, cv::CC_STAT_AREA) >= min_area ? 255 : 0;
    for (int y = 0; y < mask.rows; ++y) {
      const int* l = labels.ptr<int>(y);
      uint8_t* m = mask.ptr<uint8_t>(y);
      for (int x = 0; x < mask.cols; ++x) m[x] = keep[l[x]];
    }
  }
  // 2. Closing with a disc: bridges cracks where the person matches the background.
  // The image is padded by the radius (with background) so that the closing does not
  // glue the silhouette to the border.
  {
    const int r = options.CloseRadiusPx(mask.size());
    const cv::Mat disc =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
    cv::Mat padded;
    cv::copyMakeBorder(mask, padded, r, r, r, r, cv::BORDER_CONSTANT, cv::Scalar(0));
    cv::morphologyEx(padded, padded, cv::MORPH_CLOSE, disc, cv::Point(-1, -1), 1,
                     cv::BORDER_CONSTANT, cv::Scalar(0));
    mask = padded(cv::Rect(r, r, mask.cols, mask.rows)).clone();
  }
  // 3. Small holes (4-connected background pieces off the border) are filled.
  {
    cv::Mat background = 255 - mask;
    cv::Mat labels, component_stats, centroids;
    const int count =
        cv::connectedComponentsWithStats(background, labels, component_stats, centroids, 4);
    const double max_area = options.max_hole_fraction * pixels;
    std::vector<uint8_t> fill(count, 0);
    for (int i = 1; i < count; ++i) {
      const int x = component_stats.at<int>(i, cv::CC_STAT_LEFT);
      const int y = component_stats.at<int>(i, cv::CC_STAT_TOP);
      const int w = component_stats.at<int>(i, cv::CC_STAT_WIDTH);
      const int h = component_stats.at<int>(i, cv::CC_STAT_HEIGHT);
      const bool touches_border = x == 0 || y == 0 || x + w == mask.cols || y + h == mask.rows;
      fill[i] = !touches_border && component_stats.at<int>(i, cv::CC_STAT_AREA) <= max_area;
    }
    for (int y = 0; y < mask.rows; ++y) {
      const int* l = labels.ptr<int>(y);
      uint8_t* m = mask.ptr<uint8_t>(y);
      for (int x = 0; x < mask.cols; ++x) {
        if (fill[l[x]]) m[x] = 255;
      }
    }
  }
  if (!valid.empty()) mask.setTo(0, valid == 0);
  return mask;
}

cv::Mat MedianImage(const std::vector<cv::Mat>& images) {
  DOME_CHECK(!images.empty(), "MedianImage: at least one image");
  const cv::Mat& first = images.front();
  for (const auto& m : images)
    DOME_CHECK(m.type() == first.type() && m.size() == first.size(),
               "MedianImage: images of one size and type");
  const int values = first.cols * first.channels();
  const size_t count = images.size();
  const size_t rank = (count - 1) / 2;
  cv::Mat out(first.size(), first.type());
  std::vector<uint8_t> samples(count);
  for (int y = 0; y < first.rows; ++y) {
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int v = 0; v < values; ++v) {
      for (size_t i = 0; i < count; ++i) samples[i] = images[i].ptr<uint8_t>(y)[v];
      std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(rank),
                       samples.end());
      o[v] = samples[rank];
    }
  }
  return out;
}

void ConsensusOptions::Check() const {
  Require(agree_false_alarm > 0.0 && agree_false_alarm < 0.5, "ConsensusOptions: agree_false_alarm",
          "expected a probability in (0, 0.5), got " + std::to_string(agree_false_alarm));
  Require(fill_tolerance >= 1.0 && fill_tolerance < 100.0, "ConsensusOptions: fill_tolerance",
          "expected a multiple of the agreement threshold in [1, 100), got " +
              std::to_string(fill_tolerance));
  Require(sigma_floor > 0.0 && sigma_floor < 64.0, "ConsensusOptions: sigma_floor",
          "expected grey levels in (0, 64), got " + std::to_string(sigma_floor));
  Require(fill_open_fraction >= 0.0 && fill_open_fraction <= 0.05,
          "ConsensusOptions: fill_open_fraction",
          "expected a fraction of the image diagonal in [0, 0.05], got " +
              std::to_string(fill_open_fraction));
}

int ConsensusOptions::FillOpenRadiusPx(cv::Size size) const {
  return DiagonalFractionPx(fill_open_fraction, size);
}

cv::Mat FillFromSettled(const cv::Mat& values, const cv::Mat& known) {
  DOME_CHECK(values.depth() == CV_32F && known.type() == CV_8UC1 && known.size() == values.size(),
             "FillFromSettled: float values and an 8-bit mask of their size");
  // Push: premultiplied values and weights averaged down the pyramid (the same filter
  // for both, so V / W is a normalized convolution) until no level-pixel lacks data.
  std::vector<cv::Mat> v_levels, w_levels;
  cv::Mat w;
  known.convertTo(w, CV_32F, 1.0 / 255.0);
  cv::threshold(w, w, 0.0, 1.0, cv::THRESH_BINARY);
  std::vector<cv::Mat> planes;
  cv::split(values, planes);
  for (auto& p : planes) p = p.mul(w);
  cv::Mat v;
  cv::merge(planes, v);
  v_levels.push_back(v);
  w_levels.push_back(w);
  double least = 0.0;
  cv::minMaxLoc(w, &least);
  while (least <= 0.0 && (w.cols > 1 || w.rows > 1)) {
    cv::Mat v2, w2;
    cv::pyrDown(v_levels.back(), v2);
    cv::pyrDown(w_levels.back(), w2);
    v_levels.push_back(v2);
    w_levels.push_back(w2);
    cv::minMaxLoc(w2, &least);
    w = w2;
  }
  // Pull: the top level normalized, then each level is its own data where it has it
  // and the coarser estimate where not: V + (1 - W) up (W is the share of data, 0..1).
  cv::Mat estimate;
  {
    const cv::Mat& vt = v_levels.back();
    const cv::Mat& wt = w_levels.back();
    cv::split(vt, planes);
    for (auto& p : planes) {
      cv::Mat safe = cv::max(wt, 1e-12);
      p = p / safe;
      p.setTo(0.0, wt <= 0.0);
    }
    cv::merge(planes, estimate);
  }
  for (int l = static_cast<int>(v_levels.size()) - 2; l >= 0; --l) {
    cv::Mat up;
    cv::resize(estimate, up, v_levels[l].size(), 0, 0, cv::INTER_LINEAR);
    cv::Mat rest = 1.0 - cv::min(w_levels[l], 1.0);
    cv::split(up, planes);
    for (auto& p : planes) p = p.mul(rest);
    cv::merge(planes, up);
    estimate = v_levels[l] + up;
  }
  return estimate;
}

cv::Mat ConsensusBackground(const std::vector<cv::Mat>& images, const ConsensusOptions& options,
                            ConsensusStats* stats) {
  options.Check();
  const cv::Mat median = MedianImage(images);  // checks sizes and types
  const int channels = median.channels();
  const int n = static_cast<int>(images.size());
  // The noise of one image about the median, per channel: the median over the images.
  std::vector<double> sigma(channels, options.sigma_floor);
  {
    std::vector<std::vector<double>> per_image(channels);
    for (const auto& image : images) {
      const std::vector<double> s =
          NoiseSigma(image, median, cv::Mat(), 1.0, options.sigma_floor, /*skip_zero=*/true);
      for (int c = 0; c < channels; ++c) per_image[c].push_back(s[c]);
    }
    for (int c = 0; c < channels; ++c) {
      auto& s = per_image[c];
      std::nth_element(s.begin(), s.begin() + (n - 1) / 2, s.end());
      sigma[c] = s[(n - 1) / 2];
    }
  }
  std::vector<float> inv_sigma(channels);
  for (int c = 0; c < channels; ++c) inv_sigma[c] = static_cast<float>(1.0 / sigma[c]);
  const float t = static_cast<float>(TwoSidedNormalQuantile(options.agree_false_alarm / channels));
  const int need = (3 * n + 3) / 4;  // three quarters, rounded up

  // Per pixel, the largest channel distance in noise units.
  auto distance = [&](const uint8_t* a, const float* b) {
    float d = 0.0f;
    for (int c = 0; c < channels; ++c) d = std::max(d, std::abs(float(a[c]) - b[c]) * inv_sigma[c]);
    return d;
  };
  cv::Mat settled(median.size(), CV_8UC1);
  int64_t settled_count = 0;
  for (int y = 0; y < median.rows; ++y) {
    const uint8_t* m = median.ptr<uint8_t>(y);
    uint8_t* s = settled.ptr<uint8_t>(y);
    for (int x = 0; x < median.cols; ++x) {
      float mf[4];
      for (int c = 0; c < channels; ++c) mf[c] = m[x * channels + c];
      int agree = 0;
      for (const auto& image : images)
        agree += distance(image.ptr<uint8_t>(y) + x * channels, mf) <= t;
      s[x] = agree >= need ? 255 : 0;
      settled_count += agree >= need;
    }
  }
  if (stats != nullptr) *stats = ConsensusStats{settled_count / double(median.total()), 0.0, 0.0};
  // No pixel agreed (the camera moved between the instants, or the light changed
  // everywhere): nothing to fill from, the median stands.
  if (settled_count == 0) return median;
  // The fill's data: the settled pixels less their specks (ConsensusOptions::
  // fill_open_fraction). An opening that leaves nothing (an image of specks) keeps them.
  cv::Mat fill_from = settled;
  if (const int r = options.FillOpenRadiusPx(settled.size()); r > 0) {
    const cv::Mat disc =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
    cv::Mat opened;
    // OpenCV's default border neither erodes nor dilates: the image's edge keeps its
    // settled pixels.
    cv::morphologyEx(settled, opened, cv::MORPH_OPEN, disc);
    if (cv::countNonZero(opened) > 0) fill_from = opened;
  }
  cv::Mat median_f;
  median.convertTo(median_f, CV_32F);
  const cv::Mat fill = FillFromSettled(median_f, fill_from);
  cv::Mat out = median.clone();
  int64_t chosen = 0, changed = 0;
  const float band = static_cast<float>(options.fill_tolerance) * t;
  for (int y = 0; y < median.rows; ++y) {
    const uint8_t* s = settled.ptr<uint8_t>(y);
    const float* f = fill.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < median.cols; ++x) {
      if (s[x] != 0) continue;
      const float* fx = f + x * channels;
      float best = std::numeric_limits<float>::infinity();
      const uint8_t* best_value = nullptr;
      for (const auto& image : images) {
        const uint8_t* v = image.ptr<uint8_t>(y) + x * channels;
        const float d = distance(v, fx);
        if (d < best) best = d, best_value = v;
      }
      // None within the band: a texture the fill cannot follow (or people in every
      // image); the median stands.
      if (best <= band) {
        float m[4];
        for (int c = 0; c < channels; ++c) m[c] = o[x * channels + c];
        changed += distance(best_value, m) > t;
        for (int c = 0; c < channels; ++c) o[x * channels + c] = best_value[c];
        ++chosen;
      }
    }
  }
  if (stats != nullptr) {
    const double pixels = static_cast<double>(median.total());
    stats->settled_fraction = settled_count / pixels;
    stats->chosen_fraction = chosen / pixels;
    stats->changed_fraction = changed / pixels;
  }
  return out;
}

double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  DOME_CHECK(a.size() == b.size() && a.type() == CV_8UC1 && b.type() == CV_8UC1,
             "MaskIoU: two 8-bit masks of one size");
  const int inter = cv::countNonZero((a != 0) & (b != 0));
  const int uni = cv::countNonZero((a != 0) | (b != 0));
  return uni == 0 ? 1.0 : static_cast<double>(inter) / uni;
}

}  // namespace dome::silhouette
