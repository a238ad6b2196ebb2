#include "pipeline/frame_handoff.h"

#include "pipeline/mat_store.h"

namespace dome::pipeline {
namespace {

MatStore& Process() {
  // Never destroyed: workers may outlive statics.
  static MatStore* store = new MatStore(kFrameHandoffBudgetBytes);
  return *store;
}

}  // namespace

void OfferDecodedFrame(const std::string& sha256, const cv::Mat& image) {
  Process().Put(sha256, image);  // the same bytes decode to the same image
}

cv::Mat TakeDecodedFrame(const std::string& sha256) { return Process().Take(sha256); }

size_t HeldDecodedFrames() { return Process().size(); }

namespace {

MatStore& Masks() {
  static MatStore* store = new MatStore(kMaskHandoffBudgetBytes);  // as Process()
  return *store;
}

}  // namespace

std::string MaskHandoffKey(const std::string& camera, const std::string& source,
                           const std::vector<std::string>& input_sha256) {
  std::string key = camera + '\n' + source;
  for (const auto& sha : input_sha256) key += '\n' + sha;
  return key;
}

void OfferMask(const std::string& key, const cv::Mat& mask) { Masks().Put(key, mask); }

cv::Mat TakeMask(const std::string& key) { return Masks().Take(key); }

}  // namespace dome::pipeline
