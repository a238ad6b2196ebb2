#include "io/image_codecs.h"

#include <jpeglib.h>
#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "io/tiff_memory.h"

namespace dome::io::codecs {
namespace {

// Guards against headers that claim absurd sizes (corrupt or hostile files): 2^28 pixels
// is 16k x 16k, far above any camera's frame or texture atlas.
constexpr int64_t kMaxPixels = int64_t{1} << 28;

void RequireSize(int64_t width, int64_t height, const std::string& where) {
  core::Require(width > 0 && height > 0 && width * height <= kMaxPixels, where,
                "implausible image size " + std::to_string(width) + "x" + std::to_string(height) +
                    " (at most 2^28 pixels)");
}

bool StartsWith(std::string_view bytes, const char* magic, size_t n) {
  return bytes.size() >= n && std::memcmp(bytes.data(), magic, n) == 0;
}

// ---- PNG (libpng). libpng reports errors by longjmp, so the functions that call setjmp
// hold no object with a destructor: the buffers they fill are made by their callers.

struct PngReader {
  std::string_view bytes;
  size_t pos = 0;
  std::string error;  // libpng's message
};

void PngRead(png_structp png, png_bytep out, png_size_t n) {
  auto* r = static_cast<PngReader*>(png_get_io_ptr(png));
  if (n > r->bytes.size() - r->pos) png_error(png, "file ends early (truncated)");
  std::memcpy(out, r->bytes.data() + r->pos, n);
  r->pos += n;
}

void PngError(png_structp png, png_const_charp message) {
  auto* r = static_cast<PngReader*>(png_get_error_ptr(png));
  if (r->error.empty()) r->error = message;
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}

// The header, and the transformations to OpenCV's layout. false on a libpng error.
bool PngReadHeader(png_structp png, png_infop info, png_uint_32* width, png_uint_32* height,
                   int* depth, int* channels) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  int bit_depth = 0, colour = 0;
  png_get_IHDR(png, info, width, height, &bit_depth, &colour, nullptr, nullptr, nullptr);
  if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (colour == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  // Grey + alpha comes out as BGRA, as OpenCV gives it.
  if (colour == PNG_COLOR_TYPE_GRAY_ALPHA ||
      (colour == PNG_COLOR_TYPE_GRAY && png_get_valid(png, info, PNG_INFO_tRNS))) {
    png_set_gray_to_rgb(png);
  }
  if (bit_depth == 16) png_set_swap(png);  // PNG is big-endian; cv::Mat holds host order
  png_set_bgr(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  *depth = png_get_bit_depth(png, info);
  *channels = png_get_channels(png, info);
  return true;
}

bool PngReadRows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

cv::Mat DecodePng(std::string_view bytes, const std::string& where) {
  PngReader reader{bytes, 0, {}};
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &reader, PngError, PngWarning);
  DOME_CHECK(png != nullptr, "DecodePng: out of memory");
  png_infop info = png_create_info_struct(png);
  struct Cleanup {
    png_structp* png;
    png_infop* info;
    ~Cleanup() { png_destroy_read_struct(png, info, nullptr); }
  } cleanup{&png, &info};
  DOME_CHECK(info != nullptr, "DecodePng: out of memory");
  png_set_read_fn(png, &reader, PngRead);
  // Our own limit instead of libpng's (1,000,000 per side): the pixel count is checked
  // below, before anything is allocated.
  png_set_user_limits(png, 1u << 24, 1u << 24);
  png_uint_32 width = 0, height = 0;
  int depth = 0, channels = 0;
  const auto fail = [&] {
    throw core::InputError(
        where, "not a decodable image (corrupt or truncated PNG: " + reader.error + ")");
  };
  if (!PngReadHeader(png, info, &width, &height, &depth, &channels)) fail();
  RequireSize(width, height, where);
  core::Require((depth == 8 || depth == 16) && channels >= 1 && channels <= 4, where,
                "PNG of an unexpected layout after expansion (" + std::to_string(depth) + "-bit, " +
                    std::to_string(channels) + " channels)");
  cv::Mat out(int(height), int(width), CV_MAKETYPE(depth == 16 ? CV_16U : CV_8U, channels));
  std::vector<png_bytep> rows(height);
  for (png_uint_32 y = 0; y < height; ++y) rows[y] = out.ptr(int(y));
  if (!PngReadRows(png, info, rows.data())) fail();
  return out;
}

struct PngWriter {
  std::string bytes;
  std::string error;
};

void PngWrite(png_structp png, png_bytep data, png_size_t n) {
  static_cast<PngWriter*>(png_get_io_ptr(png))->bytes.append(reinterpret_cast<char*>(data), n);
}

void PngFlush(png_structp) {}

void PngWriteError(png_structp png, png_const_charp message) {
  auto* w = static_cast<PngWriter*>(png_get_error_ptr(png));
  if (w->error.empty()) w->error = message;
  png_longjmp(png, 1);
}

// zlib and filter settings: see EncodePng in image_codecs.h.
void PngCompression(png_structp png, bool small) {
  if (small) {
    png_set_compression_level(png, 3);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
  } else {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level(png, Z_BEST_SPEED);
    png_set_compression_strategy(png, Z_RLE);
  }
}

bool PngWriteAll(png_structp png, png_infop info, const cv::Mat& image, bool small,
                 png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  PngCompression(png, small);
  const int channels = image.channels();
  png_set_IHDR(png, info, png_uint_32(image.cols), png_uint_32(image.rows),
               image.depth() == CV_16U ? 16 : 8,
               channels == 1   ? PNG_COLOR_TYPE_GRAY
               : channels == 3 ? PNG_COLOR_TYPE_RGB
                               : PNG_COLOR_TYPE_RGBA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_bgr(png);
  if (image.depth() == CV_16U) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

bool PngWritePalette(png_structp png, png_infop info, const cv::Mat& indices,
                     const std::vector<png_color>& palette, bool small, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  PngCompression(png, small);
  png_set_IHDR(png, info, png_uint_32(indices.cols), png_uint_32(indices.rows), 8,
               PNG_COLOR_TYPE_PALETTE, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_PLTE(png, info, palette.data(), int(palette.size()));
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

// ---- JPEG (libjpeg-turbo): errors also by longjmp.

struct JpegError {
  jpeg_error_mgr mgr;
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

void OnJpegError(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegError*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

void OnJpegMessage(j_common_ptr, int) {}  // warnings (a truncated file among them)

// Reads the header and starts decompressing to grey or BGR. false on a libjpeg error.
bool JpegStart(jpeg_decompress_struct* cinfo, JpegError* err, std::string_view bytes) {
  if (setjmp(err->jump)) return false;
  jpeg_mem_src(cinfo, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(cinfo, TRUE);
  if (cinfo->jpeg_color_space == JCS_CMYK || cinfo->jpeg_color_space == JCS_YCCK) {
    std::snprintf(err->message, sizeof(err->message), "a CMYK JPEG; expected grey or colour");
    return false;
  }
  cinfo->out_color_space = cinfo->num_components == 1 ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_calc_output_dimensions(cinfo);
  return true;
}

bool JpegRead(jpeg_decompress_struct* cinfo, JpegError* err, cv::Mat* out) {
  if (setjmp(err->jump)) return false;
  jpeg_start_decompress(cinfo);
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = out->ptr(int(cinfo->output_scanline));
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  return true;
}

cv::Mat DecodeJpeg(std::string_view bytes, const std::string& where) {
  jpeg_decompress_struct cinfo;
  JpegError err;
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = OnJpegError;
  err.mgr.emit_message = OnJpegMessage;
  jpeg_create_decompress(&cinfo);
  struct Cleanup {
    jpeg_decompress_struct* c;
    ~Cleanup() { jpeg_destroy_decompress(c); }
  } cleanup{&cinfo};
  const auto fail = [&] {
    throw core::InputError(where, std::string("not a decodable image (JPEG: ") + err.message + ")");
  };
  if (!JpegStart(&cinfo, &err, bytes)) fail();
  RequireSize(cinfo.output_width, cinfo.output_height, where);
  cv::Mat out(int(cinfo.output_height), int(cinfo.output_width),
              cinfo.out_color_space == JCS_GRAYSCALE ? CV_8UC1 : CV_8UC3);
  if (!JpegRead(&cinfo, &err, &out)) fail();
  return out;
}

// ---- TIFF (libtiff).

cv::Mat DecodeTiff(std::string_view bytes, const std::string& where) {
  TiffMessages messages;
  MemoryFile file{std::string(bytes), 0};
  TiffHandle tif = OpenMemoryTiff(&file, "r", "image", kMaxPixels * 8, &messages);
  core::Require(tif != nullptr, where,
                "not a decodable image (TIFF: " +
                    (messages.error.empty() ? std::string("cannot open") : messages.error) + ")");
  TIFF* t = tif.get();
  uint32_t width = 0, height = 0;
  uint16_t spp = 1, bps = 1, format = SAMPLEFORMAT_UINT, photometric = 0,
           planar = PLANARCONFIG_CONTIG;
  core::Require(TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &width) == 1 &&
                    TIFFGetField(t, TIFFTAG_IMAGELENGTH, &height) == 1,
                where, "TIFF without image width/length tags");
  RequireSize(width, height, where);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(t, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetField(t, TIFFTAG_PHOTOMETRIC, &photometric);
  const auto fail = [&](const std::string& what) {
    throw core::InputError(where, "not a decodable image (corrupt TIFF data: " + what +
                                      (messages.error.empty() ? "" : ", " + messages.error) + ")");
  };
  const bool grey = photometric == PHOTOMETRIC_MINISBLACK && (spp == 1 || spp == 2);
  const bool rgb = photometric == PHOTOMETRIC_RGB && (spp == 3 || spp == 4);
  const bool samples = (format == SAMPLEFORMAT_UINT && (bps == 8 || bps == 16)) ||
                       (format == SAMPLEFORMAT_IEEEFP && bps == 32);
  if ((grey || rgb) && samples && planar == PLANARCONFIG_CONTIG) {
    // Read as stored: rows (or tiles) straight into the image.
    const int depth = bps == 8 ? CV_8U : bps == 16 ? CV_16U : CV_32F;
    cv::Mat out(int(height), int(width), CV_MAKETYPE(depth, spp));
    const std::string failed = ReadTiffPixels(t, size_t(spp) * bps / 8, &out);
    if (!failed.empty()) fail(failed);
    if (spp == 3) cv::cvtColor(out, out, cv::COLOR_RGB2BGR);
    if (spp == 4) cv::cvtColor(out, out, cv::COLOR_RGBA2BGRA);
    return out;
  }
  // Every other layout through libtiff's RGBA reader, as 8-bit.
  std::vector<uint32_t> raster(size_t(width) * height);
  if (TIFFReadRGBAImageOriented(t, width, height, raster.data(), ORIENTATION_TOPLEFT, 0) != 1) {
    fail("libtiff could not read this layout (" + std::to_string(spp) + " samples of " +
         std::to_string(bps) + " bits, photometric " + std::to_string(photometric) + ")");
  }
  // The raster holds R, G, B, A bytes in that order in memory.
  const cv::Mat rgba(int(height), int(width), CV_8UC4, raster.data());
  cv::Mat out;
  uint16_t extra = 0;
  uint16_t* extra_types = nullptr;
  TIFFGetField(t, TIFFTAG_EXTRASAMPLES, &extra, &extra_types);
  if ((photometric == PHOTOMETRIC_MINISBLACK || photometric == PHOTOMETRIC_MINISWHITE) &&
      spp == 1) {
    cv::extractChannel(rgba, out, 0);
  } else if (extra > 0) {
    cv::cvtColor(rgba, out, cv::COLOR_RGBA2BGRA);
  } else {
    cv::cvtColor(rgba, out, cv::COLOR_RGBA2BGR);
  }
  return out;
}

// ---- BMP: the uncompressed kinds (the format is a header and rows, no library needed).

cv::Mat DecodeBmp(std::string_view bytes, const std::string& where) {
  const auto* b = reinterpret_cast<const uint8_t*>(bytes.data());
  const size_t n = bytes.size();
  const auto u16 = [&](size_t at) { return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8; };
  const auto u32 = [&](size_t at) { return u16(at) | u16(at + 2) << 16; };
  core::Require(n >= 54, where, "not a decodable image (BMP header truncated)");
  const uint32_t data_at = u32(10), header = u32(14);
  core::Require(header >= 40 && 14 + header <= n, where,
                "BMP with a " + std::to_string(header) +
                    "-byte info header; expected Windows 3 or later (40 bytes or more)");
  const int32_t width = int32_t(u32(18)), signed_height = int32_t(u32(22));
  const uint32_t bits = u16(28), compression = u32(30), colours_used = u32(46);
  const bool top_down = signed_height < 0;
  const int64_t height = top_down ? -int64_t(signed_height) : signed_height;
  RequireSize(width, height, where);
  const bool masks = compression == 3 && bits == 32;  // BI_BITFIELDS
  core::Require(compression == 0 || masks, where,
                "compressed BMP (compression " + std::to_string(compression) +
                    "); expected an uncompressed one");
  core::Require(bits == 1 || bits == 4 || bits == 8 || bits == 24 || bits == 32, where,
                "BMP of " + std::to_string(bits) + " bits a pixel; expected 1, 4, 8, 24 or 32");
  const size_t stride = (size_t(width) * bits + 31) / 32 * 4;
  core::Require(data_at <= n && stride * size_t(height) <= n - data_at, where,
                "not a decodable image (BMP pixel data truncated)");
  std::vector<cv::Vec3b> palette;
  bool grey_palette = true;
  if (bits <= 8) {
    const size_t count = colours_used ? colours_used : size_t(1) << bits;
    core::Require(count <= 256 && 14 + header + 4 * count <= data_at, where,
                  "BMP palette of " + std::to_string(count) + " colours out of place");
    for (size_t i = 0; i < count; ++i) {
      const uint8_t* p = b + 14 + header + 4 * i;
      palette.emplace_back(p[0], p[1], p[2]);
      grey_palette = grey_palette && p[0] == p[1] && p[1] == p[2];
    }
  }
  // Bit fields: the usual byte order only; alpha only where the file says which bits
  // hold it.
  core::Require(
      !masks || (n >= 70 && u32(54) == 0xff0000u && u32(58) == 0xff00u && u32(62) == 0xffu), where,
      "BMP with colour masks other than 8-bit B, G, R");
  const bool alpha = masks && header >= 56 && u32(54 + 12) == 0xff000000u;
  const int type = bits <= 8 ? (grey_palette ? CV_8UC1 : CV_8UC3) : alpha ? CV_8UC4 : CV_8UC3;
  cv::Mat out(int(height), width, type);
  for (int64_t y = 0; y < height; ++y) {
    const uint8_t* row = b + data_at + stride * size_t(top_down ? y : height - 1 - y);
    uint8_t* o = out.ptr(int(y));
    for (int x = 0; x < width; ++x) {
      if (bits <= 8) {
        const size_t bit = size_t(x) * bits;
        const uint32_t index = (row[bit / 8] >> (8 - bits - bit % 8)) & ((1u << bits) - 1);
        core::Require(index < palette.size(), where, "BMP pixel outside its palette");
        if (type == CV_8UC1) {
          o[x] = palette[index][0];
        } else {
          std::memcpy(o + 3 * x, &palette[index], 3);
        }
      } else {
        const size_t k = size_t(bits / 8);
        std::memcpy(o + out.channels() * x, row + k * x, size_t(out.channels()));
      }
    }
  }
  return out;
}

}  // namespace

cv::Mat Decode(std::string_view bytes, const std::string& where) {
  core::Require(!bytes.empty(), where, "is empty, expected an image");
  if (StartsWith(bytes, "\x89PNG\r\n\x1a\n", 8)) return DecodePng(bytes, where);
  if (StartsWith(bytes, "\xff\xd8\xff", 3)) return DecodeJpeg(bytes, where);
  if (StartsWith(bytes, "II*\0", 4) || StartsWith(bytes, "MM\0*", 4)) {
    return DecodeTiff(bytes, where);
  }
  if (StartsWith(bytes, "BM", 2)) return DecodeBmp(bytes, where);
  throw core::InputError(where,
                         "not a decodable image (corrupt, truncated or unsupported format; "
                         "expected PNG, JPEG, TIFF or BMP)");
}

namespace {

// A new libpng write struct over `image`'s rows, handed to `write(png, info, rows)`
// (false on a libpng error, named with `who`); the file's bytes.
template <typename Write>
std::string WritePngBytes(const cv::Mat& image, const std::string& who, Write&& write) {
  PngWriter writer;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &writer, PngWriteError, PngWarning);
  DOME_CHECK(png != nullptr, who + ": out of memory");
  png_infop info = png_create_info_struct(png);
  struct Cleanup {
    png_structp* png;
    png_infop* info;
    ~Cleanup() { png_destroy_write_struct(png, info); }
  } cleanup{&png, &info};
  DOME_CHECK(info != nullptr, who + ": out of memory");
  png_set_write_fn(png, &writer, PngWrite, PngFlush);
  std::vector<png_bytep> rows(size_t(image.rows));
  for (int y = 0; y < image.rows; ++y) rows[size_t(y)] = const_cast<uint8_t*>(image.ptr(y));
  DOME_CHECK(write(png, info, rows.data()), who + ": libpng failed: " + writer.error);
  return std::move(writer.bytes);
}

}  // namespace

std::string EncodePng(const cv::Mat& image, bool small) {
  return WritePngBytes(image, "EncodePng", [&](png_structp png, png_infop info, png_bytepp rows) {
    return PngWriteAll(png, info, image, small, rows);
  });
}

std::string EncodePalettePng(const cv::Mat& indices, const std::vector<cv::Vec3b>& palette,
                             bool small) {
  DOME_CHECK(!indices.empty() && indices.type() == CV_8UC1,
             "EncodePalettePng: indices must be a non-empty CV_8UC1 image");
  DOME_CHECK(!palette.empty() && palette.size() <= 256,
             "EncodePalettePng: 1 to 256 colours, got " + std::to_string(palette.size()));
  double top = 0;
  cv::minMaxLoc(indices, nullptr, &top);
  DOME_CHECK(size_t(top) < palette.size(), "EncodePalettePng: an index past the palette");
  std::vector<png_color> colours(palette.size());
  for (size_t i = 0; i < palette.size(); ++i)
    colours[i] = {palette[i][2], palette[i][1], palette[i][0]};  // BGR -> RGB
  return WritePngBytes(indices, "EncodePalettePng",
                       [&](png_structp png, png_infop info, png_bytepp rows) {
                         return PngWritePalette(png, info, indices, colours, small, rows);
                       });
}

}  // namespace dome::io::codecs
