#include "pipeline/frame_handoff.h"

#include <deque>
#include <mutex>

namespace dome::pipeline {
namespace {

struct Held {
  std::string sha256;
  cv::Mat image;
};

struct Handoff {
  std::mutex mutex;
  std::deque<Held> frames;
  size_t bytes = 0;
};

Handoff& Process() {
  static Handoff* handoff = new Handoff;  // never destroyed: workers may outlive statics
  return *handoff;
}

size_t Bytes(const cv::Mat& m) { return m.total() * m.elemSize(); }

}  // namespace

void OfferDecodedFrame(const std::string& sha256, const cv::Mat& image) {
  if (image.empty() || Bytes(image) > kFrameHandoffBudgetBytes) return;
  Handoff& h = Process();
  std::lock_guard<std::mutex> lock(h.mutex);
  for (const Held& f : h.frames)
    if (f.sha256 == sha256) return;  // the same bytes decode to the same image
  h.frames.push_back({sha256, image});
  h.bytes += Bytes(image);
  while (h.bytes > kFrameHandoffBudgetBytes) {
    h.bytes -= Bytes(h.frames.front().image);
    h.frames.pop_front();
  }
}

cv::Mat TakeDecodedFrame(const std::string& sha256) {
  Handoff& h = Process();
  std::lock_guard<std::mutex> lock(h.mutex);
  for (auto it = h.frames.begin(); it != h.frames.end(); ++it) {
    if (it->sha256 != sha256) continue;
    cv::Mat image = it->image;
    h.bytes -= Bytes(image);
    h.frames.erase(it);
    return image;
  }
  return cv::Mat();
}

size_t HeldDecodedFrames() {
  Handoff& h = Process();
  std::lock_guard<std::mutex> lock(h.mutex);
  return h.frames.size();
}

}  // namespace dome::pipeline
