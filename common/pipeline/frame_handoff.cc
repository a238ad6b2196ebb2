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

}  // namespace dome::pipeline
