// A digitizer behind one interface (seed §2.1: "the digitizer captures as many frames
// as it can"; "the computer interprets the time code at video rate").
//
// Watching the signal is free -- every frame comes by with its vertical interval, so
// its VITC can be read at video rate -- but storing a frame costs the digitizer and
// the host time: Keep() stores the frame last returned by Next(), or refuses when the
// digitizer is still busy with the previous one or drops it.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <random>
#include <string>

#include "capture/deck.h"

namespace dome::capture {

class Digitizer {
 public:
  virtual ~Digitizer() = default;
  virtual std::string Name() const = 0;
  // The next frame of the signal (8-bit grey, vertical interval included); false when
  // the signal ended (deck stopped, end of file).
  virtual bool Next(cv::Mat* frame) = 0;
  // Stores the frame last returned by Next(): true if it was stored (then *stored is
  // the frame), false if the digitizer could not take it.
  virtual bool Keep(cv::Mat* stored) = 0;
};

// OpenCV VideoCapture on a file or a V4L2 device ("file:PATH", "v4l2:/dev/video0"),
// converted to 8-bit grey. Frames must come with the vertical interval (a capture
// card set to keep the VBI lines, or a tape file). Keep always succeeds. Throws
// core::InputError naming the source when it cannot be opened.
class OpenCvDigitizer : public Digitizer {
 public:
  explicit OpenCvDigitizer(const std::string& spec);
  ~OpenCvDigitizer() override;
  std::string Name() const override { return spec_; }
  bool Next(cv::Mat* frame) override;
  bool Keep(cv::Mat* stored) override;

 private:
  struct Impl;
  std::string spec_;
  std::unique_ptr<Impl> impl_;
  cv::Mat last_;
};

struct SimDigitizerOptions {
  double keep_per_second = 0.0;   // frames it can store per second of signal; 0 = every frame
  double drop_probability = 0.0;  // chance a frame it tries to store is lost, 0..1
  uint64_t seed = 1;              // of the drops

  // Throws core::InputError naming the option out of range.
  void Check() const;
};

// A digitizer of limited bandwidth on a deck's signal: after storing a frame it is busy
// for 1 / keep_per_second seconds of signal time, and it loses a frame now and then.
class SimDigitizer : public Digitizer {
 public:
  SimDigitizer(VideoSignal* signal, const SimDigitizerOptions& options);
  std::string Name() const override { return "sim"; }
  bool Next(cv::Mat* frame) override;
  bool Keep(cv::Mat* stored) override;

  int64_t kept() const { return kept_; }
  int64_t dropped() const { return dropped_; }

 private:
  VideoSignal* signal_;
  SimDigitizerOptions options_;
  std::mt19937_64 rng_;
  cv::Mat last_;
  double last_time_s_ = 0.0;
  double busy_until_s_ = -1.0;
  int64_t kept_ = 0, dropped_ = 0;
};

}  // namespace dome::capture
