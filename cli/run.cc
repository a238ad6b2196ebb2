// The runtime's client commands (cli/client.h, master/master.h):
//   dome run TAKE|SESSION.json --out OUT [--workers N] [--master ADDR]
//   dome submit TAKE|SESSION.json [--out OUT] --master ADDR   prints the session id
//   dome status [ID] --master ADDR                            instant answer
//   dome watch ID --master ADDR [--events ADDR]               live progress
//   dome watch --capture [--cameras N] --master ADDR           capture agents' progress
//   dome cancel ID --master ADDR
//   dome list --master ADDR
// status, submit, cancel and list wait --timeout-s (default 10) for the master's answer.
// ADDR is the master's control endpoint (dome-master --control, default port 5556);
// the status events are read from the next port unless --events names them. Without
// --master, `dome run` starts an embedded master with N in-process workers.
// Talking to a dome-master needs --master-key FILE (its .pub) and --key FILE (this
// side's .key, its .pub on the master's allow-list), or --insecure for a plaintext
// master; the embedded master of `dome run` is in-process and needs no keys.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/client.h"
#include "cli/commands.h"
#include "cli/setting_flags.h"
#include "core/error.h"
#include "net/security.h"
#include "pipeline/defaults.h"
#include "pipeline/derive.h"
#include "pipeline/session.h"

namespace dome::cli {
namespace {

// The flags that make or amend a session: its own fields, and every stereo and fusion
// option (pipeline/settings.h), each set in the session only when given.
struct SessionArgs {
  std::string source, out;
  std::vector<std::string> instants;
  std::vector<double> box;  // --box: x0 y0 z0 x1 y1 z1, world mm
  double voxel_mm = 0, decimate_ratio = 0;
  int slab_planes = 0, smooth_iterations = 0;
  bool no_texture = false, no_preview = false, no_masks = false;
  CLI::Option *voxel = nullptr, *slabs = nullptr, *ratio = nullptr, *smooth = nullptr;
  std::unique_ptr<SettingFlags<stereo::TakeStereoOptions>> stereo;
  std::unique_ptr<SettingFlags<fusion::FusionOptions>> fusion;
  std::unique_ptr<SettingFlags<pipeline::SilhouetteUse>> silhouettes;
  std::unique_ptr<SettingFlags<pipeline::TemporalUse>> temporal;
};

void AddSessionFlags(CLI::App* cmd, SessionArgs* a, bool out_required) {
  cmd->add_option("TAKE", a->source, "take folder, or SESSION.json (proto/runtime.proto Session)")
      ->required();
  auto* out =
      cmd->add_option("--out", a->out, "output folder (OUT/<instant>/..., OUT/report.json)");
  if (out_required) out->required();
  cmd->add_option("--instant", a->instants, "instants HH-MM-SS-FF (default: all)");
  a->voxel = cmd->add_option("--voxel-mm", a->voxel_mm,
                             "voxel edge, mm (default: derived from the take, pipeline/derive.h)");
  a->slabs =
      cmd->add_option("--slab-planes", a->slab_planes, "voxel planes per fusion job (default 16)");
  a->ratio = cmd->add_option("--decimate-ratio", a->decimate_ratio,
                             "fraction of triangles kept (default 0.1)");
  a->smooth = cmd->add_option("--smooth-iterations", a->smooth_iterations,
                              "Taubin smoothing of mesh.ply, lambda|mu pairs (default 0: none)");
  cmd->add_option("--box", a->box,
                  "the volume XMIN YMIN ZMIN XMAX YMAX ZMAX (mm) instead of the derived one")
      ->expected(6);
  cmd->add_flag("--no-texture", a->no_texture, "skip the textured OBJ");
  cmd->add_flag("--no-preview", a->no_preview, "skip depth preview PNGs");
  cmd->add_flag("--no-masks", a->no_masks,
                "no silhouettes: --no-volume-masks --no-stereo-masks --no-fusion-masks");
  a->silhouettes = std::make_unique<SettingFlags<pipeline::SilhouetteUse>>(
      cmd, pipeline::SilhouetteSettingFields());
  a->temporal = std::make_unique<SettingFlags<pipeline::TemporalUse>>(
      cmd, pipeline::TemporalSettingFields());
  a->stereo = std::make_unique<SettingFlags<stereo::TakeStereoOptions>>(
      cmd, pipeline::StereoSettingFields());
  a->fusion = std::make_unique<SettingFlags<fusion::FusionOptions>>(
      cmd, pipeline::FusionSettingFields(),
      pipeline::DefaultFusionOptions(pipeline::kDefaultVoxelMm));
}

// A Session from a take folder and flags, or from SESSION.json with flags overriding.
// OUT/session.json (written by the master when the session started) when it was derived
// from a session given as `given_sha256` (pipeline::GivenSessionDigest); nothing when
// there is none, another, or one that does not parse (said, and derived again).
std::optional<runtime::Session> KeptSession(const std::string& out, const std::string& given_sha256) {
  const std::filesystem::path path = std::filesystem::path(out) / "session.json";
  if (!std::filesystem::is_regular_file(path)) return std::nullopt;
  try {
    runtime::Session kept = pipeline::ReadSessionJson(path);
    if (kept.given_sha256() != given_sha256) return std::nullopt;
    spdlog::info("{}: the same take and options: its session kept, derived values included "
                 "({} note(s); a new output folder derives them again)",
                 path.string(), kept.derived_size());
    for (const auto& n : kept.derived()) spdlog::info("derived (kept) {}", n);
    return kept;
  } catch (const core::InputError& e) {
    spdlog::warn("{}: not kept ({}): the session is derived again", path.string(), e.what());
    return std::nullopt;
  }
}

// `embedded`: the session runs on this process's workers (frames derived from are
// handed to their jobs).
runtime::Session MakeSession(const SessionArgs& a, bool embedded = false) {
  namespace fs = std::filesystem;
  runtime::Session s;
  if (fs::is_regular_file(a.source)) {
    s = pipeline::ReadSessionJson(a.source);
  } else {
    s.set_take(a.source);
  }
  if (!a.out.empty()) s.set_out(a.out);
  core::Require(!s.out().empty(), "--out", "names no output folder (nor does the session file)");
  // The master may run elsewhere, but the usual case is this machine: absolute paths.
  if (!s.take().empty()) s.set_take(fs::absolute(s.take()).lexically_normal().string());
  s.set_out(fs::absolute(s.out()).lexically_normal().string());
  if (!a.instants.empty()) {
    s.clear_instants();
    for (const auto& i : a.instants) s.add_instants(i);
  }
  // Any value given, a bad one included, goes to the session: checked below by name.
  if (a.voxel->count()) s.mutable_volume()->set_voxel_size_mm(a.voxel_mm);
  if (a.slabs->count()) s.set_slab_planes(a.slab_planes);
  if (a.ratio->count()) s.set_decimate_ratio(a.decimate_ratio);
  if (a.smooth->count()) s.set_smooth_iterations(a.smooth_iterations);
  if (a.no_texture) s.set_texture(false);
  if (a.no_preview) s.set_write_previews(false);
  a.stereo->Apply(s.mutable_stereo());
  a.fusion->Apply(s.mutable_fusion());
  a.silhouettes->Apply(s.mutable_silhouettes());
  a.temporal->Apply(s.mutable_temporal());
  if (a.no_masks) *s.mutable_silhouettes() = pipeline::ToSilhouetteSettings({});
  // Bad options fail here, not remotely, with the messages of the same values in a
  // session file (one place: pipeline::ResolveSessionOptions). A take derived here has
  // them checked by DeriveSession first, against the volume derived for it rather than
  // the seed's cube.
  const bool derive = !s.has_noop_jobs() && fs::is_directory(s.take());
  if (!derive) pipeline::ResolveSessionOptions(s, "session");
  // What the user left unset, derived from the take (pipeline/derive.h) here, so that
  // the master and the journal see explicit values.
  // A take this machine cannot read (a remote master's path) is submitted as it is.
  if (!s.has_noop_jobs() && !derive) {
    core::Require(a.box.empty(), "--box", "needs the take readable on this machine");
    spdlog::warn(
        "{}: not a folder here, so nothing is derived from it: the master's defaults "
        "(the seed's volume) apply unless --box and the options are given",
        s.take());
  } else if (!s.has_noop_jobs()) {
    std::string box;
    for (double v : a.box) box += fmt::format("{} ", v);
    const std::string given = pipeline::GivenSessionDigest(s, "box " + box);
    // The same take and options into the same folder again (a resume): the session the
    // folder holds, derived values included. They come from the frames (the scene's
    // extent, the masks' hull), so deriving again after a frame was rewritten would
    // change every instant's session, and the journal would redo them all rather than
    // the instant whose inputs changed (master/journal.h).
    if (auto kept = KeptSession(s.out(), given)) return *kept;
    pipeline::DeriveRequest r;
    r.offer_frames = embedded;
    if (!a.box.empty()) r.box = {{a.box[0], a.box[1], a.box[2]}, {a.box[3], a.box[4], a.box[5]}};
    const pipeline::Derivation d = pipeline::DeriveSession(r, &s);
    for (const auto& n : d.notes) s.add_derived(n);
    s.set_given_sha256(given);
  }
  return s;
}

struct MasterArgs {
  std::string master = "tcp://localhost:5556", events;
  std::string master_key, key;  // CURVE key files
  bool insecure = false;
  double timeout_s = 10;  // wait for a control reply, s
  // The control time-out in ms (throws naming --timeout-s when not positive).
  int TimeoutMs() const {
    core::Require(timeout_s > 0 && timeout_s <= 86400, "--timeout-s",
                  "must be in (0, 86400] seconds, got " + std::to_string(timeout_s));
    return std::max(1, static_cast<int>(timeout_s * 1000 + 0.5));
  }
  std::string Events() const { return events.empty() ? client::EventsEndpointFor(master) : events; }
  // The client sockets' options from the key flags (throws naming a missing flag).
  net::SocketOptions Socket() const {
    net::SocketOptions o;
    net::ApplyClientKeys(master_key, key, insecure, &o);
    return o;
  }
};

void AddKeyFlags(CLI::App* cmd, MasterArgs* m) {
  cmd->add_option("--master-key", m->master_key, "the master's public key file (CURVE)")
      ->envname("DOME_MASTER_KEY");
  cmd->add_option("--key", m->key, "this client's secret key file, its .pub allowed by the master")
      ->envname("DOME_KEY");
  cmd->add_flag("--insecure", m->insecure, "plaintext, for a master started with --insecure");
}

void AddMasterFlags(CLI::App* cmd, MasterArgs* m) {
  cmd->add_option("--master", m->master, "the master's control endpoint")->capture_default_str();
  cmd->add_option("--timeout-s", m->timeout_s,
                  "seconds to wait for the master's answer (status, submit, cancel, list)")
      ->capture_default_str();
  cmd->add_option("--events", m->events,
                  "the master's status endpoint (default: control port + 1)");
  AddKeyFlags(cmd, m);
}

int ExitCodeFor(const runtime::SessionStatus& st) {
  std::fputs(client::FormatStatus(st).c_str(), stdout);
  return st.state() == "done" ? 0 : 1;
}

// The end of `dome run`: the status, then a warning when instants ended with an empty
// surface (not an error, but usually a volume that misses the scene: said last, where
// the user looks, from OUT/report.json when this machine can read it).
int EndOfRun(const runtime::SessionStatus& st, const std::string& out) {
  const int code = ExitCodeFor(st);
  if (const std::string w = client::EmptySurfaceWarning(out); !w.empty()) {
    spdlog::warn("{}: {}", out, w);
  }
  return code;
}

// Sends one control request and prints the sessions of the reply; the exit code.
int RequestAndPrintSessions(const MasterArgs& m, const runtime::ControlRequest& req) {
  const net::SocketOptions socket = m.Socket();
  zmq::context_t context;
  // The reply must outlive the loop (a range-for over a temporary's member dangles).
  const runtime::ControlReply reply =
      client::Request(&context, m.master, req, m.TimeoutMs(), socket);
  for (const auto& s : reply.sessions()) {
    std::fputs(client::FormatStatus(s).c_str(), stdout);
  }
  return 0;
}

}  // namespace

void AddRunCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "run", "Reconstruct a take: stereo, fusion, marching cubes, decimation, texture per instant");
  auto a = std::make_shared<SessionArgs>();
  auto m = std::make_shared<MasterArgs>();
  auto e = std::make_shared<client::EmbeddedOptions>();
  AddSessionFlags(cmd, a.get(), false);
  cmd->add_option("--workers", e->workers,
                  "in-process workers when no --master (0: two, each with every thread for a "
                  "session of one instant, else with half)")
      ->capture_default_str();
  cmd->add_option("--threads", e->threads_per_worker,
                  "threads per in-process worker (0: with --workers 0 as it says, else share)")
      ->capture_default_str();
  cmd->add_option("--heartbeat-liveness", e->master.heartbeat_liveness,
                  "heartbeat intervals (1 s) of silence before an in-process worker or the "
                  "master is presumed gone; raise it on a heavily loaded machine")
      ->capture_default_str();
  auto* master = cmd->add_option("--master", m->master,
                                 "a dome-master's control endpoint (default: embedded master)");
  cmd->add_option("--events", m->events,
                  "the master's status endpoint (default: control port + 1)");
  AddKeyFlags(cmd, m.get());
  cmd->callback([=] {
    // Before the take is read: a bad count fails at once.
    core::Require(e->workers >= 0, "--workers", "must be 0 (from the session) or more");
    const runtime::Session session = MakeSession(*a, master->count() == 0);
    if (master->count() == 0) {
      *exit_code = EndOfRun(client::RunEmbedded(session, *e, stdout), session.out());
      return;
    }
    const net::SocketOptions socket = m->Socket();
    zmq::context_t context;
    runtime::ControlRequest req;
    *req.mutable_submit()->mutable_session() = session;
    const auto reply = client::Request(&context, m->master, req, 10000, socket);
    std::printf("session %s\n", reply.session_id().c_str());
    *exit_code = EndOfRun(client::WaitForSession(&context, m->master, m->Events(),
                                                 reply.session_id(), stdout, 500, socket),
                          session.out());
  });
}

void AddSubmitCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("submit", "Submit a session to a dome-master; prints its id");
  auto a = std::make_shared<SessionArgs>();
  auto m = std::make_shared<MasterArgs>();
  AddSessionFlags(cmd, a.get(), false);
  AddMasterFlags(cmd, m.get());
  cmd->callback([=] {
    const net::SocketOptions socket = m->Socket();
    zmq::context_t context;
    runtime::ControlRequest req;
    *req.mutable_submit()->mutable_session() = MakeSession(*a);
    std::printf(
        "%s\n",
        client::Request(&context, m->master, req, m->TimeoutMs(), socket).session_id().c_str());
    *exit_code = 0;
  });
}

void AddStatusCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("status", "A session's progress (every session without ID)");
  auto id = std::make_shared<std::string>();
  auto m = std::make_shared<MasterArgs>();
  cmd->add_option("ID", *id, "session id");
  AddMasterFlags(cmd, m.get());
  cmd->callback([=] {
    runtime::ControlRequest req;
    req.mutable_status()->set_session_id(*id);
    *exit_code = RequestAndPrintSessions(*m, req);
  });
}

void AddWatchCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("watch", "Live progress of a session until it ends");
  auto id = std::make_shared<std::string>();
  auto m = std::make_shared<MasterArgs>();
  cmd->add_option("ID", *id, "session id (capture progress shows too)");
  AddMasterFlags(cmd, m.get());
  // Capture progress alone (dome-master --capture-bind), no session.
  auto capture = std::make_shared<bool>(false);
  auto cameras = std::make_shared<int>(0);
  auto timeout_s = std::make_shared<double>(0);
  cmd->add_flag("--capture", *capture, "capture agents' progress, a line per camera and update");
  cmd->add_option("--cameras", *cameras, "--capture: end once this many cameras have finished");
  cmd->add_option("--timeout", *timeout_s, "--capture: end after this many seconds (0: never)");
  cmd->callback([=] {
    const net::SocketOptions socket = m->Socket();
    zmq::context_t context;
    if (*capture) {
      const auto last = client::WatchCapture(&context, m->Events(), stdout, *cameras,
                                             static_cast<int>(*timeout_s * 1000), socket);
      int complete = 0;
      for (const auto& [camera, c] : last) complete += c.state() == "complete";
      *exit_code = complete == int(last.size()) && complete >= *cameras ? 0 : 1;
      return;
    }
    core::Require(!id->empty(), "ID", "required: the session to watch (or --capture)");
    *exit_code = ExitCodeFor(
        client::WaitForSession(&context, m->master, m->Events(), *id, stdout, 500, socket));
  });
}

void AddCancelCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("cancel", "Cancel a session");
  auto id = std::make_shared<std::string>();
  auto m = std::make_shared<MasterArgs>();
  cmd->add_option("ID", *id, "session id")->required();
  AddMasterFlags(cmd, m.get());
  cmd->callback([=] {
    runtime::ControlRequest req;
    req.mutable_cancel()->set_session_id(*id);
    *exit_code = RequestAndPrintSessions(*m, req);
  });
}

void AddListCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("list", "The master's sessions, one line each");
  auto m = std::make_shared<MasterArgs>();
  AddMasterFlags(cmd, m.get());
  cmd->callback([=] {
    const net::SocketOptions socket = m->Socket();
    zmq::context_t context;
    runtime::ControlRequest req;
    req.mutable_list();
    const runtime::ControlReply reply =
        client::Request(&context, m->master, req, m->TimeoutMs(), socket);
    for (const auto& s : reply.sessions()) {
      std::printf("%s  %-9s  %d/%d jobs  %.1f s  %s\n", s.id().c_str(), s.state().c_str(),
                  s.jobs_done(), s.jobs_total(), s.elapsed_s(), s.out().c_str());
    }
    *exit_code = 0;
  });
}

}  // namespace dome::cli
