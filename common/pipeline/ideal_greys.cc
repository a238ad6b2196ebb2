#include "pipeline/ideal_greys.h"

#include <deque>
#include <mutex>

namespace dome::pipeline {
namespace {

struct Held {
  std::string key;
  cv::Mat grey;
};

struct Greys {
  std::mutex mutex;
  std::deque<Held> greys;
  size_t bytes = 0;
};

Greys& Process() {
  static Greys* greys = new Greys;  // never destroyed: workers may outlive statics
  return *greys;
}

size_t Bytes(const cv::Mat& m) { return m.total() * m.elemSize(); }

}  // namespace

std::string IdealGreyKey(const std::string& frame_sha256, const std::string& rig_sha256,
                         const std::string& camera, const stereo::StereoOptions& options) {
  return frame_sha256 + ' ' + rig_sha256 + ' ' + camera + ' ' +
         (options.normalize_contrast ? '1' : '0') + (options.sqrt_greys ? '1' : '0');
}

cv::Mat SharedIdealGrey(const std::string& key, const stereo::StereoView& view,
                        const stereo::StereoOptions& options, const std::string& where) {
  Greys& g = Process();
  {
    std::lock_guard<std::mutex> lock(g.mutex);
    for (const Held& h : g.greys)
      if (h.key == key) return h.grey;
  }
  // Made outside the lock: two workers may both make a grey first needed at once (the
  // same bits); the first one kept is the one found from then on.
  const cv::Mat grey = stereo::IdealGrey(view, options, where);
  if (Bytes(grey) > kIdealGreysBudgetBytes) return grey;
  std::lock_guard<std::mutex> lock(g.mutex);
  for (const Held& h : g.greys)
    if (h.key == key) return h.grey;
  g.greys.push_back({key, grey});
  g.bytes += Bytes(grey);
  while (g.bytes > kIdealGreysBudgetBytes) {
    g.bytes -= Bytes(g.greys.front().grey);
    g.greys.pop_front();
  }
  return grey;
}

size_t HeldIdealGreys() {
  Greys& g = Process();
  std::lock_guard<std::mutex> lock(g.mutex);
  return g.greys.size();
}

void DropIdealGreys() {
  Greys& g = Process();
  std::lock_guard<std::mutex> lock(g.mutex);
  g.greys.clear();
  g.bytes = 0;
}

}  // namespace dome::pipeline
