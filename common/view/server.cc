#include "view/server.h"

#include <httplib.h>
#include <pthread.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <map>
#include <mutex>
#include <thread>

#include "core/error.h"
#include "io/file_util.h"
#include "view/derived.h"
#include "view/path_safety.h"

namespace dome::view {

namespace fs = std::filesystem;

namespace {

std::string ContentType(const fs::path& path) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".tiff", "image/tiff"},
      {".glb", "model/gltf-binary"},
      {".obj", "text/plain; charset=utf-8"},
      {".mtl", "text/plain; charset=utf-8"},
  };
  const auto it = types.find(path.extension().string());
  return it == types.end() ? "application/octet-stream" : it->second;
}

void Refuse(httplib::Response& res, int status, const std::string& why) {
  res.status = status;
  res.set_content(why + "\n", "text/plain; charset=utf-8");
}

}  // namespace

struct ViewerServer::Impl {
  fs::path out_dir;
  std::optional<fs::path> take_dir;
  fs::path assets_dir;
  ServerOptions options;
  httplib::Server http;

  std::mutex mutex;  // guards index and cache
  std::shared_ptr<const ViewerIndex> index;
  std::map<std::string, std::shared_ptr<const std::string>> cache;  // derived files by URL

  std::shared_ptr<const ViewerIndex> CurrentIndex() {
    std::lock_guard<std::mutex> lock(mutex);
    return index;
  }

  std::shared_ptr<const ViewerIndex> Rescan() {
    try {
      auto fresh =
          std::make_shared<const ViewerIndex>(BuildIndex(out_dir, take_dir, options.index));
      std::lock_guard<std::mutex> lock(mutex);
      index = fresh;
      return index;
    } catch (const core::InputError& e) {
      spdlog::warn("dome view: rescan failed, keeping the previous index: {}", e.what());
      return CurrentIndex();
    }
  }

  void ServeFile(const fs::path& root, const std::string& relative, httplib::Response& res) {
    const ResolvedPath r = ResolveUnder(root, relative);
    if (!r.ok) {
      Refuse(res, r.why == "no such file" ? 404 : 403, relative + ": " + r.why);
      return;
    }
    try {
      SendUncompressed(std::make_shared<const std::string>(io::ReadFileBytes(r.path)),
                       ContentType(r.path), res);
    } catch (const core::InputError& e) {
      Refuse(res, 404, e.what());
    }
  }

  // A body sent as it is: cpp-httplib compresses set_content() bodies for clients that
  // accept it, with Brotli at its slowest quality first (1.3 s for three.min.js's 850 kB,
  // most of the page's time to its first frame on loopback); a response of known length
  // from a content provider goes out uncompressed.
  static void SendUncompressed(std::shared_ptr<const std::string> bytes, const std::string& type,
                               httplib::Response& res) {
    const size_t size = bytes->size();
    res.set_content_provider(
        size, type.c_str(),
        [bytes](size_t offset, size_t length, httplib::DataSink& sink) {
          return sink.write(bytes->data() + offset, std::min(length, bytes->size() - offset));
        });
  }

  // A derived file: computed once per index generation and URL, then kept.
  template <typename Fn>
  void ServeDerived(const std::string& url, const char* type, Fn&& compute,
                    httplib::Response& res) {
    std::shared_ptr<const std::string> bytes;
    {
      std::lock_guard<std::mutex> lock(mutex);
      const auto it = cache.find(url);
      if (it != cache.end()) bytes = it->second;
    }
    if (!bytes) {
      try {
        bytes = std::make_shared<const std::string>(compute());
      } catch (const core::InputError& e) {
        Refuse(res, 422, e.what());
        return;
      }
      std::lock_guard<std::mutex> lock(mutex);
      cache[url] = bytes;
    }
    SendUncompressed(bytes, type, res);
  }

  void Routes() {
    http.Get("/", [this](const httplib::Request&, httplib::Response& res) {
      ServeFile(assets_dir, "index.html", res);
    });
    auto index_json = [this](bool script, httplib::Response& res) {
      const auto idx = Rescan();
      {
        // Derived files of a rescanned folder may have changed.
        std::lock_guard<std::mutex> lock(mutex);
        cache.clear();
      }
      const std::string json = IndexJson(*idx, false);
      res.set_header("Cache-Control", "no-store");
      if (script)
        res.set_content("window.DOME_INDEX = " + json + ";\n", "text/javascript; charset=utf-8");
      else
        res.set_content(json + "\n", "application/json");
    };
    http.Get("/index.js", [index_json](const httplib::Request&, httplib::Response& res) {
      index_json(true, res);
    });
    http.Get("/index.json", [index_json](const httplib::Request&, httplib::Response& res) {
      index_json(false, res);
    });
    http.Get(R"(/out/(.*))", [this](const httplib::Request& req, httplib::Response& res) {
      ServeFile(out_dir, req.matches[1], res);
    });
    http.Get(R"(/take/(.*))", [this](const httplib::Request& req, httplib::Response& res) {
      if (!take_dir) return Refuse(res, 404, "dome view was started without --take");
      ServeFile(*take_dir, req.matches[1], res);
    });
    // A camera's derived PNG at an instant: derived/<kind>/<instant>/<camera>.png.
    using CameraFile = std::string (*)(const ViewerIndex&, int, int);
    for (const auto& [kind, file] : {std::pair<const char*, CameraFile>{"depth", DepthPreviewFile},
                                     std::pair<const char*, CameraFile>{"mask", MaskPreviewFile}}) {
      http.Get(std::string("/derived/") + kind + R"(/([^/]+)/([^/]+)\.png)",
               [this, file = file](const httplib::Request& req, httplib::Response& res) {
                 const auto idx = CurrentIndex();
                 const int i = idx->FindInstant(req.matches[1]);
                 const int c = idx->FindCamera(req.matches[2]);
                 if (i < 0 || c < 0) return Refuse(res, 404, "no such instant or camera");
                 ServeDerived(req.path, "image/png", [&] { return file(*idx, i, c); }, res);
               });
    }
    http.Get(R"(/derived/error/([^/]+)/(fused|decimated)\.f32)", [this](const httplib::Request& req,
                                                                        httplib::Response& res) {
      const auto idx = CurrentIndex();
      const int i = idx->FindInstant(req.matches[1]);
      if (i < 0) return Refuse(res, 404, "no such instant");
      const MeshVariant v =
          req.matches[2] == "fused" ? MeshVariant::kFused : MeshVariant::kDecimated;
      ServeDerived(
          req.path, "application/octet-stream", [&] { return VertexErrorFile(*idx, i, v); }, res);
    });
    http.Get(R"(/(.*))", [this](const httplib::Request& req, httplib::Response& res) {
      ServeFile(assets_dir, req.matches[1], res);
    });
    // Only SO_REUSEADDR: cpp-httplib's default also sets SO_REUSEPORT, which would let
    // a second `dome view` on the same port share it silently instead of failing.
    http.set_socket_options([](int sock) {
      const int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    });
    http.set_logger([](const httplib::Request& req, const httplib::Response& res) {
      spdlog::debug("dome view: {} {} -> {}", req.method, req.path, res.status);
    });
  }
};

ViewerServer::ViewerServer(fs::path out_dir, std::optional<fs::path> take_dir, fs::path assets_dir,
                           ServerOptions options)
    : impl_(std::make_unique<Impl>()) {
  impl_->out_dir = std::move(out_dir);
  impl_->take_dir = std::move(take_dir);
  impl_->assets_dir = fs::canonical(assets_dir);
  impl_->options = std::move(options);
  impl_->index = std::make_shared<const ViewerIndex>(
      BuildIndex(impl_->out_dir, impl_->take_dir, impl_->options.index));
  impl_->Routes();
}

ViewerServer::~ViewerServer() { Stop(); }

int ViewerServer::Bind() {
  const ServerOptions& o = impl_->options;
  const std::string where = "--bind " + o.bind_address + " --port " + std::to_string(o.port);
  core::Require(o.port >= 0 && o.port <= 65535, where, "port must be in 0..65535");
  if (o.port == 0) {
    const int port = impl_->http.bind_to_any_port(o.bind_address);
    core::Require(port > 0, where, "cannot listen there");
    return port;
  }
  core::Require(impl_->http.bind_to_port(o.bind_address, o.port), where,
                "cannot listen there (address in use, or not an address of this machine)");
  return o.port;
}

void ViewerServer::Run() { impl_->http.listen_after_bind(); }

void ViewerServer::RunUntilInterrupted() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // The waiter owns the signals; the server's threads inherit the blocked mask.
  std::thread waiter([this, signals] {
    int sig = 0;
    sigwait(&signals, &sig);
    Stop();
  });
  Run();
  // Run() also ends when the listener fails: wake the waiter.
  pthread_kill(waiter.native_handle(), SIGTERM);
  waiter.join();
}

void ViewerServer::Stop() {
  if (impl_ && impl_->http.is_running()) impl_->http.stop();
}

}  // namespace dome::view
