// Makes docs/synth.png from a synthetic take: for a few cameras the take image next to
// its truth depth map, and a crop of one taped NTSC frame next to the same region of
// the take image (the second field shows the moving bat displaced, seed Figure 10).
//
//   dome synth --preset paper --out /tmp/paper
//   synth_figure /tmp/paper 00-00-10-25 docs/synth.png c07 100 190 c07 c20 c40
//     (instant, output, tape camera, tape crop x y, then the cameras to show)
// Not a test: built on request (`cmake --build build --target synth_figure`, then
// build/bin/synth_figure).
#include <algorithm>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace {

cv::Mat Label(cv::Mat m, const std::string& text) {
  cv::putText(m, text, {8, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 4);
  cv::putText(m, text, {8, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 255, 255}, 1);
  return m;
}

cv::Mat Bgr(const cv::Mat& gray) {
  cv::Mat c;
  cv::cvtColor(gray, c, cv::COLOR_GRAY2BGR);
  return c;
}

cv::Mat Read(const std::string& path, int flags) {
  cv::Mat m = cv::imread(path, flags);
  if (m.empty()) {
    std::fprintf(stderr, "synth_figure: cannot read %s\n", path.c_str());
    std::exit(1);
  }
  return m;
}

// Depth (mm) as colours: 750 mm red .. 6000 mm blue, no surface black.
cv::Mat DepthColours(const cv::Mat& depth) {
  cv::Mat d8(depth.size(), CV_8UC1);
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const float z = depth.at<float>(y, x);
      d8.at<uint8_t>(y, x) =
          z <= 0
              ? 0
              : static_cast<uint8_t>(std::clamp(255.0 * (1.0 - (z - 750.0) / 5250.0), 1.0, 255.0));
    }
  }
  cv::Mat colours;
  cv::applyColorMap(d8, colours, cv::COLORMAP_TURBO);
  colours.setTo(cv::Scalar(0, 0, 0), depth <= 0);
  return colours;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 8) {
    std::fprintf(stderr, "usage: synth_figure TAKE INSTANT OUT.png TAPE_CAMERA X Y CAMERA...\n");
    return 2;
  }
  const std::string take = argv[1], instant = argv[2], out = argv[3], tape_camera = argv[4];
  const cv::Rect tape_roi(std::stoi(argv[5]), std::stoi(argv[6]), 320, 244);
  const cv::Scalar white(255, 255, 255);
  std::vector<cv::Mat> rows;
  for (int i = 7; i < argc; ++i) {
    const std::string camera = argv[i];
    const cv::Mat image =
        Read(take + "/frames/" + instant + "/" + camera + ".png", cv::IMREAD_GRAYSCALE);
    const cv::Mat depth =
        Read(take + "/truth/" + instant + "/depth/" + camera + ".tiff", cv::IMREAD_UNCHANGED);
    cv::Mat left, right, row;
    cv::resize(Bgr(image), left, cv::Size(), 2, 2, cv::INTER_NEAREST);
    cv::resize(DepthColours(depth), right, cv::Size(), 2, 2, cv::INTER_NEAREST);
    Label(left, camera + " " + instant + ": take image " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows));
    Label(right, "truth depth: 750 mm red .. 6000 mm blue, black = none");
    cv::hconcat(std::vector<cv::Mat>{left, cv::Mat(left.rows, 12, CV_8UC3, white), right}, row);
    rows.push_back(row);
    rows.push_back(cv::Mat(6, row.cols, CV_8UC3, white));
  }
  const cv::Mat tape =
      Read(take + "/tape/" + instant + "/" + tape_camera + ".png", cv::IMREAD_GRAYSCALE);
  const cv::Mat image =
      Read(take + "/frames/" + instant + "/" + tape_camera + ".png", cv::IMREAD_GRAYSCALE);
  cv::Mat a, b, row;
  cv::resize(tape(tape_roi & cv::Rect(0, 0, tape.cols, tape.rows)), a, cv::Size(640, 488), 0, 0,
             cv::INTER_NEAREST);
  const cv::Rect image_roi(tape_roi.x / 2, tape_roi.y / 2, 160, 122);
  cv::resize(image(image_roi & cv::Rect(0, 0, image.cols, image.rows)), b, cv::Size(640, 488), 0, 0,
             cv::INTER_NEAREST);
  const int gap = std::max(0, rows[0].cols - 1280);
  cv::hconcat(
      std::vector<cv::Mat>{Label(Bgr(a), tape_camera + " taped frame: two fields 1/60 s apart"),
                           cv::Mat(488, gap, CV_8UC3, white),
                           Label(Bgr(b), "same region of the take image (first field)")},
      row);
  rows.push_back(row);
  cv::Mat all;
  cv::vconcat(rows, all);
  if (!cv::imwrite(out, all, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
    std::fprintf(stderr, "synth_figure: cannot write %s\n", out.c_str());
    return 1;
  }
  return 0;
}
