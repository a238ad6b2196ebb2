#include "pipeline/ideal_greys.h"

#include "pipeline/mat_store.h"

namespace dome::pipeline {
namespace {

MatStore& Process() {
  // Never destroyed: workers may outlive statics.
  static MatStore* store = new MatStore(kIdealGreysBudgetBytes);
  return *store;
}

}  // namespace

std::string IdealGreyKey(const std::string& frame_sha256, const std::string& rig_sha256,
                         const std::string& camera, const stereo::StereoOptions& options) {
  return frame_sha256 + ' ' + rig_sha256 + ' ' + camera + ' ' +
         (options.normalize_contrast ? '1' : '0') + (options.sqrt_greys ? '1' : '0');
}

std::string CutGreyKey(const std::string& frame_key, const cv::Rect& rect) {
  return frame_key + " cut " + std::to_string(rect.x) + ' ' + std::to_string(rect.y) + ' ' +
         std::to_string(rect.width) + ' ' + std::to_string(rect.height);
}

cv::Mat SharedIdealGrey(const std::string& key, const stereo::StereoView& view,
                        const stereo::StereoOptions& options, const std::string& where) {
  const cv::Mat kept = Process().Find(key);
  if (!kept.empty()) return kept;
  // Made outside the store's lock: two workers may both make a grey first needed at
  // once (the same bits); the first one kept is the one found from then on.
  return Process().Put(key, stereo::IdealGrey(view, options, where));
}

size_t HeldIdealGreys() { return Process().size(); }

void DropIdealGreys() { Process().Clear(); }

}  // namespace dome::pipeline
