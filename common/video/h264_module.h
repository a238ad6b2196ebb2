// The module's H.264 coders (h264_module.cc), for its Backend table (video_module.cc).
#pragma once

#include <string>

#include "video/video.h"

namespace dome::video {

H264Encoder* NewH264Encoder(const H264Settings& settings, std::string* error);
H264Decoder* NewH264Decoder(std::string* error);

}  // namespace dome::video
