// The viewer's HTTP server (cpp-httplib): the page, its index, and the files of the
// output folder and take, nothing else.
//
//   GET /                                  the page (assets/index.html)
//   GET /index.js                          window.DOME_INDEX = <IndexJson>; (rescanned
//                                          on every request, so a running `dome run`
//                                          shows its new instants on reload)
//   GET /index.json                        the same JSON
//   GET /out/<path>                        a file of OUT
//   GET /take/<path>                       a file of TAKE
//   GET /derived/depth/<instant>/<camera>.png   colour-mapped depth (view/derived.h)
//   GET /derived/error/<instant>/<fused|decimated>.f32   per-vertex error, float32 mm
//   GET /derived/mask/<instant>/<camera>.png    the image with its mask (view/derived.h)
//   GET /<path>                            a page asset (viewer.js, three/...)
// Paths are confined with view/path_safety.h: a refused path answers 403, a file that
// is not there 404, a derived file whose input is malformed 422 with the reason;
// every refusal's body says why.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "view/output_index.h"

namespace dome::view {

struct ServerOptions {
  std::string bind_address = "127.0.0.1";  // interface to listen on
  int port = 8080;                         // TCP port; 0 = any free port
  IndexOptions index;                      // passed to BuildIndex on every rescan
};

class ViewerServer {
 public:
  // Builds the index once (throws core::InputError as BuildIndex does).
  ViewerServer(std::filesystem::path out_dir, std::optional<std::filesystem::path> take_dir,
               std::filesystem::path assets_dir, ServerOptions options);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  // Binds the listening socket; returns the port. Throws core::InputError naming the
  // address and port when it cannot bind.
  int Bind();
  // Serves until Stop() (from any thread). Bind() first.
  void Run();
  // Serves until SIGINT or SIGTERM, then returns. Bind() first; call from the main
  // thread before any other thread is started (it blocks those signals for all).
  void RunUntilInterrupted();
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dome::view
