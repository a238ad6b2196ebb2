// `dome view OUT [--take TAKE] [--port P] [--bind ADDR] [--export DIR]`: serves the
// viewer page for an output folder (view/server.h), or writes it as a static folder
// (view/export.h).
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "cli/commands.h"
#include "core/json.h"
#include "view/assets.h"
#include "view/export.h"
#include "view/output_index.h"
#include "view/server.h"

namespace dome::cli {

void AddViewCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "view", "Play an output folder's meshes in a web page (served on localhost, or exported)");
  struct Args {
    std::string out, take, export_dir;
    view::ServerOptions server;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("OUT", a->out, "output folder (OUT/<instant>/mesh.ply, ...)")->required();
  cmd->add_option("--take", a->take, "take folder: cameras, images, masks, truth");
  cmd->add_option("--port", a->server.port, "TCP port (0: any free port)")->capture_default_str();
  cmd->add_option("--bind", a->server.bind_address, "address to listen on")->capture_default_str();
  cmd->add_option("--export", a->export_dir,
                  "write the page as a static folder that opens without a server");
  cmd->add_option("--error-range-mm", a->server.index.error_range_mm,
                  "distance to truth at the top of the colour scale, mm")
      ->capture_default_str();
  cmd->add_option("--frustum-mm", a->server.index.frustum_depth_mm,
                  "drawn frustum depth, mm (default: 8% of the rig's extent)");
  cmd->add_option("--rate", a->server.index.play_rate_hz, "playback rate, instants per second")
      ->capture_default_str();
  cmd->callback([=] {
    const std::filesystem::path assets = view::FindViewerAssets();
    std::optional<std::filesystem::path> take;
    if (!a->take.empty()) take = a->take;
    if (!a->export_dir.empty()) {
      const view::ViewerIndex index = view::BuildIndex(a->out, take, a->server.index);
      const view::ExportSummary s = view::ExportStatic(index, assets, a->export_dir);
      // Unreadable meshes are not fatal: the page shows those instants as missing.
      const core::Json line = {{"export", a->export_dir},
                               {"instants", index.instants.size()},
                               {"files", s.files},
                               {"bytes", s.bytes},
                               {"unreadable", s.failed_derived}};
      std::printf("%s\n", core::DumpJson(line).c_str());
      *exit_code = 0;
      return;
    }
    view::ViewerServer server(a->out, take, assets, a->server);
    const int port = server.Bind();
    std::printf("dome view: serving http://%s:%d/ (Ctrl-C to stop)\n",
                a->server.bind_address.c_str(), port);
    std::fflush(stdout);
    server.RunUntilInterrupted();
    *exit_code = 0;
  });
}

}  // namespace dome::cli
