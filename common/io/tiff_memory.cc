#include "io/tiff_memory.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <vector>

namespace dome::io {
namespace {

int OnTiffError(TIFF*, void* user_data, const char* module, const char* fmt, va_list ap) {
  auto* messages = static_cast<TiffMessages*>(user_data);
  if (messages->error.empty()) {
    char buf[512];
    std::vsnprintf(buf, sizeof(buf), fmt, ap);
    messages->error = buf;
  }
  return 1;  // handled: do not call the global handler (which prints to stderr)
}

int OnTiffWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

tmsize_t MemRead(thandle_t h, void* buf, tmsize_t n) {
  auto* f = static_cast<MemoryFile*>(h);
  const toff_t left = f->pos < f->bytes.size() ? f->bytes.size() - f->pos : 0;
  const tmsize_t k = static_cast<tmsize_t>(std::min<toff_t>(left, static_cast<toff_t>(n)));
  if (k > 0) std::memcpy(buf, f->bytes.data() + f->pos, static_cast<size_t>(k));
  f->pos += static_cast<toff_t>(k);
  return k;
}

tmsize_t MemWrite(thandle_t h, void* buf, tmsize_t n) {
  auto* f = static_cast<MemoryFile*>(h);
  if (n < 0) return -1;
  const size_t end = static_cast<size_t>(f->pos) + static_cast<size_t>(n);
  if (end > f->bytes.size()) f->bytes.resize(end);
  std::memcpy(f->bytes.data() + f->pos, buf, static_cast<size_t>(n));
  f->pos = end;
  return n;
}

toff_t MemSeek(thandle_t h, toff_t off, int whence) {
  auto* f = static_cast<MemoryFile*>(h);
  const toff_t base = whence == SEEK_CUR ? f->pos : (whence == SEEK_END ? f->bytes.size() : 0);
  f->pos = base + off;
  return f->pos;
}

int MemClose(thandle_t) { return 0; }
toff_t MemSize(thandle_t h) { return static_cast<MemoryFile*>(h)->bytes.size(); }
int MemMap(thandle_t, void**, toff_t*) { return 0; }
void MemUnmap(thandle_t, void*, toff_t) {}

}  // namespace

std::string ReadTiffPixels(TIFF* t, size_t pixel, cv::Mat* out) {
  const uint32_t width = uint32_t(out->cols), height = uint32_t(out->rows);
  if (!TIFFIsTiled(t)) {
    if (TIFFScanlineSize(t) != tmsize_t(width * pixel)) return "bad scanline size";
    for (uint32_t y = 0; y < height; ++y) {
      if (TIFFReadScanline(t, out->ptr(int(y)), y, 0) != 1) return "row " + std::to_string(y);
    }
    return "";
  }
  uint32_t tw = 0, th = 0;
  TIFFGetField(t, TIFFTAG_TILEWIDTH, &tw);
  TIFFGetField(t, TIFFTAG_TILELENGTH, &th);
  if (tw == 0 || th == 0 || TIFFTileSize(t) != tmsize_t(size_t(tw) * th * pixel)) {
    return "bad tile geometry";
  }
  std::vector<uint8_t> tile(size_t(tw) * th * pixel);
  for (uint32_t ty = 0; ty < height; ty += th) {
    for (uint32_t tx = 0; tx < width; tx += tw) {
      if (TIFFReadTile(t, tile.data(), tx, ty, 0, 0) < 0) {
        return "tile at (" + std::to_string(tx) + ", " + std::to_string(ty) + ")";
      }
      const uint32_t h = std::min(th, height - ty), w = std::min(tw, width - tx);
      for (uint32_t r = 0; r < h; ++r) {
        std::memcpy(out->ptr(int(ty + r)) + tx * pixel, tile.data() + size_t(r) * tw * pixel,
                    w * pixel);
      }
    }
  }
  return "";
}

TiffHandle OpenMemoryTiff(MemoryFile* file, const char* mode, const char* name,
                          int64_t max_alloc_bytes, TiffMessages* messages) {
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(opts, OnTiffError, messages);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, OnTiffWarning, messages);
  TIFFOpenOptionsSetMaxSingleMemAlloc(opts, static_cast<tmsize_t>(max_alloc_bytes));
  TiffHandle tif(TIFFClientOpenExt(name, mode, file, MemRead, MemWrite, MemSeek, MemClose, MemSize,
                                   MemMap, MemUnmap, opts));
  TIFFOpenOptionsFree(opts);
  return tif;
}

}  // namespace dome::io
