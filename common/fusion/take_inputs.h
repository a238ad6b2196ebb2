// Range images of one instant of a take, as fusion inputs.
//
//  * Truth depth (until stereo depth exists, and for fidelity experiments):
//    TAKE/truth/<instant>/depth/<camera>.tiff (take/take.h), optionally with added
//    zero-mean Gaussian noise of noise_sigma_mm on every valid pixel (a stand-in for
//    stereo error; deterministic for a seed, camera by camera). Rendered through each
//    camera's lens: on its distorted pixels (RangeImage::distorted_pixels).
//  * A depth folder: DIR/<camera>.tiff (or .png, 16-bit mm) for every camera of the rig
//    that has one (stereo output): on the ideal camera's pixels.
// Errors are core::InputError naming the file (size not matching the camera, NaN...).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fusion/integrate.h"
#include "take/take.h"

namespace dome::fusion {

struct TruthDepthOptions {
  double noise_sigma_mm = 0.0;  // standard deviation of the added noise, in mm
  uint64_t seed = 1;            // noise seed
  void Check() const;
};

std::vector<RangeImage> LoadTruthRangeImages(const take::Take& take, const std::string& instant,
                                             const TruthDepthOptions& options);

// Every rig camera with DIR/<camera>.tiff or DIR/<camera>.png; at least one required.
std::vector<RangeImage> LoadRangeImagesFromDir(const take::Take& take,
                                               const std::filesystem::path& dir);

}  // namespace dome::fusion
