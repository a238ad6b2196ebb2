#include "master/capture_host.h"

#include <spdlog/spdlog.h>

#include "core/error.h"

namespace dome::scheduler {

runtime::StatusEvent CaptureStatusEvent(const ingest::IngestProgress& progress) {
  const ingest::AgentProgress& a = progress.agent;
  runtime::StatusEvent ev;
  runtime::CaptureStatus* c = ev.mutable_capture();
  c->set_camera_id(progress.camera_id);
  c->set_pass(a.pass);
  c->set_captured(a.captured);
  c->set_wanted(a.wanted);
  c->set_pass_yield(a.pass_yield);
  c->set_acknowledged(static_cast<int32_t>(a.acknowledged));
  c->set_error(a.error);
  c->set_stored(progress.stored);
  const bool complete = a.done && a.captured == a.wanted;
  c->set_state(!a.done ? "capturing" : complete ? "complete" : "failed");
  ev.set_state(c->state());
  ev.set_done(a.captured);
  ev.set_total(a.wanted);
  ev.set_message("capture " + progress.camera_id + " pass " + std::to_string(a.pass) + ": " +
                 std::to_string(a.captured) + "/" + std::to_string(a.wanted) + " frames" +
                 (a.error.empty() ? "" : " (" + a.error + ")"));
  return ev;
}

std::unique_ptr<ingest::FrameIngest> HostCaptureIngest(
    zmq::context_t* context, const std::string& bind, const std::filesystem::path& take_dir,
    const net::SocketOptions& socket_options,
    std::function<void(const runtime::StatusEvent&)> publish) {
  core::Require(!take_dir.empty(), "--take",
                "required with --capture-bind: the take the captured frames go into");
  ingest::IngestOptions o;
  o.bind = bind;
  o.take_dir = take_dir;
  o.context = context;
  o.socket = socket_options;
  o.on_progress = [publish = std::move(publish)](const ingest::IngestProgress& p) {
    if (p.agent.done) {
      spdlog::info("capture: {} finished: {}/{} frames in {} passes, {} stored here{}", p.camera_id,
                   p.agent.captured, p.agent.wanted, p.agent.pass, p.stored,
                   p.agent.error.empty() ? "" : "; " + p.agent.error);
    }
    publish(CaptureStatusEvent(p));
  };
  std::unique_ptr<ingest::FrameIngest> ingest;
  try {
    ingest = std::make_unique<ingest::FrameIngest>(o);
  } catch (const core::InputError& e) {
    throw e.Under("--capture-bind");
  }
  spdlog::info("capture: frames from agents on {} go into {}", ingest->endpoint(),
               take_dir.string());
  return ingest;
}

}  // namespace dome::scheduler
