#include "video/video.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>

#include "core/error.h"

namespace dome::video {
namespace {

// The module's path: $DOME_VIDEO_MODULE, else lib/dome/libdome_video.so beside the
// program's folder (bin/../lib/dome; tests/../lib/dome in the build tree).
std::string ModulePath() {
  if (const char* given = std::getenv("DOME_VIDEO_MODULE"); given && *given) return given;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return (exe.parent_path().parent_path() / "lib" / "dome" / "libdome_video.so").string();
}

const Backend& Load() {
  static std::once_flag once;
  static const Backend* backend = nullptr;
  static std::string problem;
  std::call_once(once, [] {
    const std::string path = ModulePath();
    // Never closed: the objects it makes live as long as their owners.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = dlerror();
      problem = path + ": cannot load dome's video module (" + (why ? why : "?") +
                "); reinstall dome, or set DOME_VIDEO_MODULE to the module's path";
      return;
    }
    using Entry = const Backend* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(handle, "dome_video_backend"));
    const Backend* b = entry ? entry() : nullptr;
    if (!b || b->abi != Backend::kAbi) {
      problem = path + ": not dome's video module of this version (interface " +
                std::to_string(b ? b->abi : -1) + ", expected " + std::to_string(Backend::kAbi) +
                ")";
      return;
    }
    backend = b;
  });
  core::Require(backend != nullptr, "video support", problem);
  return *backend;
}

template <typename T>
std::unique_ptr<T> Made(T* made, const std::string& where, const std::string& error) {
  core::Require(made != nullptr, where, error);
  return std::unique_ptr<T>(made);
}

}  // namespace

std::unique_ptr<Source> OpenFile(const std::string& path) {
  std::string error;
  Source* s = Load().open_file(path, &error);
  return Made(s, path, error);
}

std::unique_ptr<Source> OpenDevice(const std::string& device) {
  std::string error;
  Source* s = Load().open_device(device, &error);
  return Made(s, device, error);
}

std::unique_ptr<Sink> CreateFfv1(const std::string& path, cv::Size size, double fps, bool colour) {
  std::string error;
  Sink* s = Load().create_ffv1(path, size, fps, colour, &error);
  return Made(s, path, error);
}

std::unique_ptr<H264Encoder> CreateH264Encoder(const H264Settings& settings,
                                               const std::string& where) {
  std::string error;
  H264Encoder* e = Load().create_h264_encoder(settings, &error);
  return Made(e, where, error);
}

std::unique_ptr<H264Decoder> CreateH264Decoder(const std::string& where) {
  std::string error;
  H264Decoder* d = Load().create_h264_decoder(&error);
  return Made(d, where, error);
}

}  // namespace dome::video
