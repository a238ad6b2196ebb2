#include "capture/digitizer.h"

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "video/video.h"

namespace dome::capture {

struct OpenCvDigitizer::Impl {
  std::unique_ptr<video::Source> source;
};

OpenCvDigitizer::OpenCvDigitizer(const std::string& spec)
    : spec_(spec), impl_(std::make_unique<Impl>()) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon),
                    target = colon == std::string::npos ? "" : spec.substr(colon + 1);
  core::Require((kind == "file" || kind == "v4l2") && !target.empty(), spec,
                "expected file:PATH or v4l2:/dev/videoN");
  if (kind == "file") {
    core::Require(std::filesystem::is_regular_file(target), spec, "no such video file");
  }
  try {
    impl_->source = kind == "file" ? video::OpenFile(target) : video::OpenDevice(target);
  } catch (const core::InputError& e) {
    throw e.Under(spec);
  }
}

OpenCvDigitizer::~OpenCvDigitizer() = default;

bool OpenCvDigitizer::Next(cv::Mat* frame) {
  cv::Mat raw;
  if (!impl_->source->Read(&raw)) return false;
  if (raw.channels() == 3) {
    cv::extractChannel(raw, last_, 0);  // grey video arrives as equal B, G, R
  } else if (raw.channels() == 1) {
    last_ = raw.clone();
  } else {
    cv::cvtColor(raw, last_, cv::COLOR_BGRA2GRAY);
  }
  *frame = last_;
  return true;
}

bool OpenCvDigitizer::Keep(cv::Mat* stored) {
  if (last_.empty()) return false;
  *stored = last_.clone();
  return true;
}

void SimDigitizerOptions::Check() const {
  core::Require(keep_per_second >= 0.0, "keep_per_second", "must be >= 0 (0 = every frame)");
  core::Require(drop_probability >= 0.0 && drop_probability < 1.0, "drop_probability",
                "must be in [0, 1)");
}

SimDigitizer::SimDigitizer(VideoSignal* signal, const SimDigitizerOptions& options)
    : signal_(signal), options_(options), rng_(options.seed) {
  options_.Check();
}

bool SimDigitizer::Next(cv::Mat* frame) {
  if (!signal_->NextFrame(&last_, &last_time_s_)) {
    last_.release();
    return false;
  }
  *frame = last_;
  return true;
}

bool SimDigitizer::Keep(cv::Mat* stored) {
  if (last_.empty()) return false;
  // 1 ms of slack against rounding, so 10 frames/s of a 29.97 Hz signal is one in three.
  if (last_time_s_ < busy_until_s_ - 1e-3) return false;
  if (options_.drop_probability > 0.0 &&
      std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < options_.drop_probability) {
    ++dropped_;
    return false;
  }
  if (options_.keep_per_second > 0.0) busy_until_s_ = last_time_s_ + 1.0 / options_.keep_per_second;
  *stored = last_.clone();
  ++kept_;
  return true;
}

}  // namespace dome::capture
