#include "pipeline/frame_handoff.h"

#include <opencv2/imgproc.hpp>

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

MatStore& Kept() {
  static MatStore* store = new MatStore(kKeptFramesBudgetBytes);  // as Process()
  return *store;
}

std::string KeptKey(const std::string& sha256, io::ImageMode mode) {
  return sha256 + ' ' + std::to_string(int(mode));
}

}  // namespace

cv::Mat FindKeptFrame(const std::string& sha256, io::ImageMode mode) {
  cv::Mat found = Kept().Find(KeptKey(sha256, mode));
  if (!found.empty() || mode != io::ImageMode::kBgr8) return found;
  const cv::Mat unchanged = Kept().Find(KeptKey(sha256, io::ImageMode::kUnchanged));
  if (unchanged.type() == CV_8UC3) return unchanged;
  if (unchanged.type() == CV_8UC4) {
    cv::Mat bgr;
    cv::cvtColor(unchanged, bgr, cv::COLOR_BGRA2BGR);
    return bgr;
  }
  return cv::Mat();
}

cv::Mat KeepFrame(const std::string& sha256, io::ImageMode mode, const cv::Mat& image) {
  return Kept().Put(KeptKey(sha256, mode), image);
}

size_t KeptFrames() { return Kept().size(); }

void DropKeptFrames() { Kept().Clear(); }

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
