// The master's frame ingest (dome-master --capture-bind ADDR --take DIR): capture
// agents (dome-capture --master ADDR) publish VITC-tagged frames into the take
// (ingest/publish.h FrameIngest, stored exactly as `dome-capture ingest` stores them)
// and their progress, which the master republishes as StatusEvents with `capture` set
// and no session id. The ingest socket is set up by net::ConfigureSocket like every
// other master socket, in the master's context, and served from its poll loop.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <zmq.hpp>

#include "ingest/publish.h"
#include "net/wire.h"
#include "runtime.pb.h"

namespace dome::scheduler {

// The StatusEvent for one camera's progress: capture filled in, a one-line message.
runtime::StatusEvent CaptureStatusEvent(const ingest::IngestProgress& progress);

// Binds the ingest at `bind` storing into `take_dir` (errors name --capture-bind or
// --take); `publish` gets each progress StatusEvent.
std::unique_ptr<ingest::FrameIngest> HostCaptureIngest(
    zmq::context_t* context, const std::string& bind, const std::filesystem::path& take_dir,
    const net::SocketOptions& socket_options,
    std::function<void(const runtime::StatusEvent&)> publish);

}  // namespace dome::scheduler
