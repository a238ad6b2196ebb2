// Texture from the instant's images (seed §1/§4.5: "by reprojecting the intensity
// images for that time instant onto the recovered model"): each surface point takes
// the weighted mean colour of the cameras that see it, with
//  * visibility: a depth test against the mesh itself rendered from that camera (a
//    z-buffer at the camera's resolution; camera z in mm, Tsai projection with
//    distortion, geometry/tsai_camera.h), so occluded cameras do not paint;
//  * view-angle weighting: weight = cos(angle between the surface normal and the
//    direction to the camera centre)^2, cameras below min_cos_angle ignored.
// Outputs: per-vertex colours (io::Mesh::colors) and a texture atlas written as
// OBJ + MTL + PNG (each triangle gets its own half-cell of a square grid of cells).
// Speed: the atlas decides per triangle which cameras can paint any of its texels (a
// conservative test of the cosine, image bounds and depth over the whole triangle),
// shades its texels against those only, a few at a time in vector registers, and
// projects with a Newton root of Tsai's distortion cubic instead of sinh/asinh. The
// colours equal those of TextureOptions::exhaustive to within floating-point rounding
// (identical on the paper rig's instant, tested on a synthetic scene).
#pragma once

#include <filesystem>
#include <optional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"
#include "io/mesh.h"
#include "take/take.h"

namespace dome::mesh {

struct TextureView {
  geometry::TsaiCamera camera;
  cv::Mat image;      // CV_8UC1 or CV_8UC3 (BGR), camera.height_px x camera.width_px
  std::string where;  // the image's file, for errors
};

// The frames of every rig camera at `instant` of `take`, as BGR views in rig order.
// Throws core::InputError naming an unreadable frame.
std::vector<TextureView> LoadTextureViews(const take::Take& take, const std::string& instant);

struct TextureOptions {
  // A point is visible from a camera when its camera depth is within this of the
  // z-buffer's, in mm.
  double depth_tolerance_mm = 30.0;
  // Cameras seeing the surface more obliquely than this cosine do not contribute.
  double min_cos_angle = 0.1;
  // Edge of an atlas cell (two triangles per cell), in texels.
  int atlas_cell_px = 8;
  // Threads over cameras / texels; <= 0: all hardware threads.
  int num_threads = 0;
  // true: every camera is tested at every texel and vertex with
  // TsaiCamera::ProjectCamera, without the per-face culling (slow; the reference the
  // default path is tested against).
  bool exhaustive = false;
  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// Throws core::InputError naming the view when the image does not match its camera.
void CheckTextureView(const TextureView& view);

// Sets mesh->colors (RGB); vertices no camera sees get grey 128.
void ColorVertices(io::Mesh* mesh, const std::vector<TextureView>& views,
                   const TextureOptions& options);

// The atlas layout of BuildTextureAtlas: triangle f fills half f % 2 of cell f / 2 of a
// grid of `columns` x `rows` square cells of `cell_px` texels, filled row by row from
// the top-left; half 0 is the triangle above the cell's anti-diagonal. Corner texel
// positions sit half a texel inside the cell so bilinear sampling stays in it.
struct GridAtlasLayout {
  int cell_px = 8;
  int columns = 1;
  int rows = 1;
  int width_px() const { return columns * cell_px; }
  int height_px() const { return rows * cell_px; }
  // The layout BuildTextureAtlas uses for `faces` triangles: the smallest grid of
  // ceil(sqrt(cells)) columns.
  static GridAtlasLayout For(int64_t faces, int cell_px);
  // Corner m (0..2) of triangle f, in texels from the atlas's top-left corner.
  Eigen::Vector2d CornerTexel(int64_t f, int m) const;
};

struct TexturedMesh {
  io::Mesh mesh;                    // positions and faces
  std::vector<Eigen::Vector2f> uv;  // 3 per face, OBJ convention (v up), in [0, 1]
  cv::Mat atlas;                    // CV_8UC3 BGR
};

TexturedMesh BuildTextureAtlas(const io::Mesh& mesh, const std::vector<TextureView>& views,
                               const TextureOptions& options);

// ColorVertices and, with `atlas`, BuildTextureAtlas from one preparation of the views
// (their z-buffers are the same): the same colours and atlas as the two calls.
std::optional<TexturedMesh> ColourAndAtlas(io::Mesh* mesh, const std::vector<TextureView>& views,
                                           const TextureOptions& options, bool atlas);

// The OBJ + MTL + PNG of a textured mesh whose files are named <stem>.obj, <stem>.mtl
// and <stem>.png (the OBJ names the MTL, the MTL the PNG): world frame, mm; per-face
// texture coordinates, OBJ convention.
// The PNG (PngEncoding::kSmall: the atlas is delivered) is encoded beside the OBJ text
// when `num_threads` is 2 or more (<= 0: the hardware's); the bytes do not depend on it.
struct TexturedObjFiles {
  std::string obj, mtl, png;
};
TexturedObjFiles EncodeTexturedObj(const TexturedMesh& textured, const std::string& stem,
                                   int num_threads = 1);

// Writes `obj_path` (.obj), the .mtl and the .png beside it (same stem), atomically.
void WriteTexturedObj(const std::filesystem::path& obj_path, const TexturedMesh& textured);

}  // namespace dome::mesh
