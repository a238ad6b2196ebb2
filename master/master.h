// The scheduler (SPEC.md "Components"; the ZeroMQ guide's Majordomo broker and
// Paranoid Pirate heartbeating): one thread polls three sockets and does only
// bookkeeping, so that it answers heartbeats, blob requests and control requests at
// once. Checking and writing a result's files runs on a thread beside it (the worker
// gets its next job meanwhile), each instant's surface on a thread of its own fed the
// slabs in plane order as they finish (surface_stream.h), and the journal is fsync'd
// in groups (journal.h).
//
//   workers  ROUTER: dome-workers (DEALER) say Hello with their capacity, get Jobs,
//            fetch blobs, return JobResults; heartbeats both ways.
//   control  ROUTER: clients (REQ) submit, ask status, cancel, list.
//   events   ROUTER: a StatusEvent to every subscriber (DEALER) whenever a job finishes
//            or a session changes state; one subscription per peer, freed when the
//            peer goes (net/events.h).
//
// Each session is a job graph (graph.h) built from the master's stages
// (pipeline/stage.h: the master knows no stage by name) with a journal in its output folder
// (journal.h); a restarted master given the same session resumes from it. A worker
// silent for heartbeat_liveness intervals is dropped and its job re-queued; results
// for finished jobs are dropped as duplicates; anything malformed is logged with the
// peer and refused while the master keeps serving. `dome-master` and the embedded
// `dome run` both run this class.
//
// Outputs of a session (OUT = Session.out):
//   OUT/<instant>/depth/<camera>.tiff, reliability/, preview/   (stereo/take_stereo.h)
//   OUT/<instant>/mesh.ply            marching cubes, binary PLY, world mm
//   OUT/<instant>/mesh_decimated.ply  decimated, per-vertex colours
//   OUT/<instant>/textured.obj/.mtl/.png   when Session.texture
//   OUT/report.json                   per-stage and per-instant seconds and counts
//                                     (JSON, written by core/json.h), the instants
//                                     whose surface has no vertex (empty_surfaces:
//                                     count, instants; per_instant: surface_vertices,
//                                     empty_surface),
//                                     bytes to and from workers per stage, results
//                                     accepted per worker (jobs_by_worker), the
//                                     workers' job seconds (worker_job_seconds), the
//                                     loop's busy fraction and longest turn, s
//                                     (master_loop)
//   OUT/journal.log, OUT/.blobs/      the journal and the job outputs it names
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <zmq.hpp>

#include "net/wire.h"
#include "pipeline/stage.h"

namespace dome::scheduler {

struct MasterOptions {
  std::string worker_endpoint = "tcp://*:5555";   // ROUTER for dome-workers
  std::string control_endpoint = "tcp://*:5556";  // ROUTER for clients
  std::string events_endpoint = "tcp://*:5557";   // ROUTER of StatusEvents (net/events.h)
  int heartbeat_interval_ms = 1000;               // between heartbeats to each worker, ms
  int heartbeat_liveness = 3;  // intervals without a message before a worker is lost
  int max_job_losses = 5;      // a job lost (worker lost, timed out, bad result) this often fails
                               // its session
  // A worker job (not the master's stages) that has not answered this long after it
  // started on its worker is dropped there and re-queued elsewhere, counting as a loss.
  // 0 derives it from the job's kind and size: before any job of its stage finished in
  // the session, job_timeout_min_s + job_timeout_first_s_per_mib per MiB of its inputs;
  // after, job_timeout_factor times the slowest seconds per input MiB seen for that stage
  // times its inputs' MiB, and at least job_timeout_min_s. Seconds.
  double job_timeout_s = 0;
  double job_timeout_min_s = 60;
  double job_timeout_first_s_per_mib = 10;
  double job_timeout_factor = 10;
  // The memory one worker job may need, MiB; a session whose fusion slab (voxels of
  // slab_planes planes, 8 bytes each) needs more is refused at submit with the figure.
  // 0: this machine's physical memory.
  int64_t max_job_mb = 0;
  // Jobs sent to a busy worker beyond the one it runs (count), so that it fetches
  // their inputs while it computes and starts the next without a round trip; only jobs
  // of stages that may be sent ahead (StageDescriptor::send_ahead: stereo, fusion), and
  // only while more are ready than idle workers take.
  int jobs_ahead = 1;
  // Threads that check, hash and write results beside the loop (count): about 0.8 CPU
  // seconds per instant of the paper take, so with many workers one thread bounds the
  // rate; 0 = half the hardware threads (at least 1).
  int writer_threads = 0;
  net::SocketOptions socket;
  // ROUTER for capture agents (capture_host.h); "" = no capture. Frames go into
  // capture_take (required with it).
  std::string capture_endpoint;
  std::string capture_take;
  // Every this many seconds the loop returns the heap's free pages to the system
  // (core::ReleaseFreedMemory), so that what peers sent does not stay resident; 0:
  // never (the embedded `dome run`, whose workers reuse their freed buffers).
  double release_memory_s = 0;
  // When set, the master keeps each session it was given here (STATE/sessions/<id>.json,
  // the Session as submitted; <id>.end, its final state and reason once it ended) and,
  // started again on the same folder, resumes the sessions that had not ended under
  // their ids (from their journals) and answers status for the ended ones. "": none.
  std::string state_dir;
  // When set, every session's output folder must lie inside this folder (after
  // following symbolic links and ".."); others are refused at submit. "": anywhere this
  // process may write (the embedded `dome run`; dome-master warns at start).
  std::string out_root;
  // The stages every session runs (the workers must run the same set).
  std::shared_ptr<const pipeline::StageSet> stages = pipeline::DefaultStages();

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct MasterEndpoints {
  std::string workers, control, events;  // as bound (ports resolved)
  std::string capture;                   // "" without capture_endpoint
};

class Master {
 public:
  // Binds the three sockets (errors name the endpoint).
  Master(zmq::context_t* context, const MasterOptions& options);
  ~Master();
  Master(const Master&) = delete;
  Master& operator=(const Master&) = delete;

  const MasterEndpoints& endpoints() const;

  // Serves until *stop becomes true (checked every few ms).
  void Run(const std::atomic<bool>* stop);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dome::scheduler
