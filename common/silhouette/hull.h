// The visual hull of one instant's foreground masks (silhouette/take_masks.h): the
// region of space every camera that sees it places in its silhouette.
//
// Frames and units: points in the world frame, mm; depths z along a camera's optical
// axis, mm. Masks come in each camera's own (distorted) pixel grid, CV_8UC1, nonzero =
// foreground, the camera's size; the hull resamples them once into the ideal
// (distortion-free) pinhole grid of the camera (geometry/undistort.h), where stereo
// matches, so that every test is a 3x4 projection.
//
// The rule (HullOptions): each mask is first dilated by `margin` (calibration error and
// the mask's own edge error); a point is *seen* by a camera when it lies in front of it
// and projects inside its image (where the undistorted image has data); a camera *votes
// background* for it when it sees it outside its dilated mask. A point is in the hull
// when at least min_views cameras (two: stereo needs two views) see it in their
// foreground and fewer than carve_votes vote background. With carve_votes = 2 (the default) one
// camera whose mask misses a part (a limb the colour of the background behind it, a person a median
// background holds) never removes it.
//
// Distances: per camera the signed distance (pixels) to its dilated mask's edge,
// positive outside the mask, from two distance transforms. A point's distance to the
// border of one camera's cone is about that many pixels times z / f (f the focal length
// in pixels); the hull is the intersection of the cones, so an inside point's distance
// to the hull's border is the least of its distances to the cones (exact for the cones'
// lateral distance), and an outside point's is at least the largest of them.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"

namespace dome::silhouette {

struct HullOptions {
  // Dilation of each mask before any test, as a fraction of its image diagonal (at
  // least one pixel): covers a pixel of calibration error and the mask's edge, where a
  // pixel half person and half background may fall either way.
  double margin_fraction = 0.002;
  // Background votes that carve a point (count, >= 1; see above).
  int carve_votes = 2;
  // Cameras that must see a point in their foreground for it to be inside (count, >= 2).
  // With a few far-apart cameras the space that only two or three of them see (near the
  // edges of their views) is mostly ghosts: two silhouettes alone place a person
  // anywhere along two cones (pipeline/derive.cc derives it per rig).
  int min_views = 2;
  int num_threads = 0;  // <= 0: all hardware threads
  // Compute the distances (two distance transforms per camera). false: only the votes
  // (Inside, RayBounds; Sample's distances are 0 and its radius must be 0), for a stereo
  // job, which builds the hull of every camera for one ray image.
  bool distances = true;
  // RayBounds tests rays in blocks of ray_block_px x ray_block_px pixels first: a depth
  // sample where the ball around the block's points at that depth (the points of all
  // its rays) lies wholly in the background of carve_votes cameras is outside for every
  // pixel of the block; the block's remaining samples [first, last] go to its quarters,
  // tested the same way, down to single pixels, whose own scan covers only what is left.
  // The result is the same as every pixel's scan over all samples (1: that scan alone);
  // the cost drops from pixels x samples x cameras to about blocks x samples x cameras
  // plus, per level, the samples near the hull's border. 8: an 8x8 block's rays stay
  // within a few pixels of each other in the other cameras at a dome's distances.
  // Blocks need a distance transform per camera at construction: a hull never asked for
  // ray bounds (fusion's free space, the derived volume's box) sets 1 and skips it.
  int ray_block_px = 8;
  // The halving stops at blocks of at most ray_leaf_px x ray_leaf_px pixels (used only
  // when below ray_block_px): each pixel of such a block that is in the camera's own
  // mask takes the block's remaining samples [first, last], which hold every one of its
  // rays' inside samples: bounds that contain the pixel's own, and a pixel whose own
  // ray misses the hull may be searched. 1: every pixel's own scan (the exact bounds).
  // 2: the pixels' own scans were about 60 % of the cost. On the paper take at a stereo
  // job's levels the bounds of 2x2 blocks come 2.3x faster, 1.44x as wide in sum, with 4 %
  // more pixels searched, and the reconstruction is as accurate (README "Silhouettes").
  int ray_leaf_px = 2;

  // Throws core::InputError naming the field when out of range.
  void Check() const;
  int MarginPx(cv::Size size) const;
};

// What the cameras say of one point (or of a ball around it, radius_mm).
struct HullSample {
  int seen = 0;               // cameras that see it
  int background = 0;         // of them, those that vote background
  double inside_mm = 0.0;     // least distance to the border of a foreground camera's cone
  double outside_mm = 0.0;    // largest distance outside a background camera's cone
  bool inside = false;        // the rule above: seen - background >= 2, background < votes
};

class VisualHull {
 public:
  // One mask per camera, in the cameras' order. Throws core::InputError naming the
  // camera when a mask is not CV_8UC1 of its camera's size.
  VisualHull(const std::vector<geometry::TsaiCamera>& cameras, const std::vector<cv::Mat>& masks,
             const HullOptions& options);

  int num_cameras() const { return int(views_.size()); }
  const HullOptions& options() const { return options_; }

  // The cameras' votes on `world_mm`. With radius_mm > 0, on the ball of that radius:
  // a camera votes background only when the whole ball projects outside its mask
  // (conservative: a ball that touches the hull is inside). `skip` (a camera index, or
  // -1) is left out of the vote.
  // `enough_outside_mm`: the cameras are asked in turn until carve_votes of them vote
  // background and one places the point at least that far outside (a caller that caps
  // the distance there, fusion's free space, needs no more); seen and inside_mm are then
  // those of the cameras asked, background >= carve_votes and inside false as with all.
  HullSample Sample(const Eigen::Vector3d& world_mm, double radius_mm = 0.0, int skip = -1,
                    double enough_outside_mm = std::numeric_limits<double>::infinity()) const;
  bool Inside(const Eigen::Vector3d& world_mm) const { return Sample(world_mm).inside; }

  // The bounding box of the hull within the box [lo, hi] (world mm): the box cut into
  // `cells` cells along its longest axis (cubes), each tested as its enclosing ball
  // (conservative, so thin parts are not lost between cell centres; Sample's verdict
  // with the ball's radius); the box of the cells inside, as cells. False when no cell
  // is inside. Needs the distances (HullOptions::distances). `min_views` > 0: a cell
  // must also be seen in the foreground of at least that many cameras (a stricter
  // count than the options', e.g. every camera).
  bool BoundingBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int cells,
                   Eigen::Vector3d* hull_lo, Eigen::Vector3d* hull_hi, int min_views = 0) const;

  // True when every point of the box [lo, hi] (world mm) is seen as background at least
  // `outside_mm` outside the dilated mask of each of carve_votes cameras or more. Each
  // Sample(p, 0, -1, outside_mm) of a point p in the box then ends carved, with
  // background >= carve_votes and outside_mm >= `outside_mm` (the cameras asked in turn
  // stop at such a camera): fusion's free space without sampling the box's voxels one by
  // one. Conservative (false is always right): the box's corners bound its image in each
  // camera, and per 8x8-pixel tile the least signed distance of its seen pixels bounds
  // theirs. Needs the distances (HullOptions::distances); `outside_mm` > 0.
  bool CarvedBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double outside_mm) const;

  // Per pixel of camera `index`'s ideal grid, the depths (z, mm) along its ray where the
  // ray is in the hull, within [z_min, z_max]: CV_32FC2 (near, far), (0, 0) where the
  // pixel is outside the camera's own dilated mask or its ray misses the hull. The ray
  // is tested at depths uniform in inverse depth, spaced so that its projection moves
  // at most one pixel per step in every other camera (the ray's first and last samples
  // inside, widened by one step each way): exact to a pixel of the other masks. The
  // camera itself counts as seeing every sample and voting foreground.
  // `samples` > 0: that many samples instead (a stereo search's level count, so that the
  // bounds are exact at its levels). Blocks of options().ray_block_px pixels skip the
  // samples no ray of the block can have inside (above); the bounds are the same. With
  // options().ray_leaf_px > 1 a pixel's bounds are those of its leaf block (above): they
  // contain its own.
  cv::Mat RayBounds(int index, double z_min_mm, double z_max_mm, int samples = 0) const;

  // Camera `index`'s dilated mask in its ideal grid (CV_8UC1, 255 / 0).
  cv::Mat IdealMask(int index) const;

 private:
  struct View {
    Eigen::Matrix<double, 3, 4> P;  // ideal pixel ~ P [world; 1]
    Eigen::Matrix3d K, R;
    Eigen::Vector3d t;
    double f_px = 1.0;  // focal length, pixels (the mean of fx and fy)
    int width = 0, height = 0;
    cv::Mat fg;         // CV_8UC1: the dilated mask, 255 = foreground
    cv::Mat signed_px;  // CV_32FC1: distance to the dilated mask's edge, > 0 outside
                        // (empty without distances)
    cv::Mat seen;       // CV_8UC1: 255 where the ideal image has data
    // CV_32FC1: distance (pixels) from each pixel to the nearest pixel that is
    // foreground, has no data, or lies outside the image: a disc of a smaller radius
    // around it is background seen by the camera (RayBounds' block test).
    cv::Mat clear_px;
    // CarvedBox: per tile of kTilePx x kTilePx pixels, the least signed_px of its pixels,
    // -infinity where one has no data (CV_32FC1, ceil(height / kTilePx) x ceil(width /
    // kTilePx); empty without distances).
    cv::Mat tile_min_px;
  };
  static constexpr int kTilePx = 8;
  HullOptions options_;
  std::vector<View> views_;
};

}  // namespace dome::silhouette
