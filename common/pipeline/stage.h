// What the scheduler knows of a stage: a descriptor (SPEC.md "Pipeline"). The master
// (master/master.h) builds each session's job graph from a StageSet and runs it without
// knowing any stage by name; adding a stage is adding a descriptor to the set (a test
// adds one: tests/runtime/stage_set_test.cc).
//
// Per instant, a stage has parts (the cameras of stereo, the slabs of fusion, one part
// for the rest); every part of a stage waits for every part of the stages it comes
// `after` in the same instant, and, when its descriptor says so for the session, for
// its own part of the previous instant (time-aware stereo: a camera's search at t is
// bounded by its depths at t-1). A worker stage's part is a job (proto/runtime.proto Job:
// the stage's name, its settings message serialized, its input blobs): the descriptor
// makes it on the master, runs it on a worker, and checks and stores its result on the
// master. A master stage runs in the master, fed the outputs of its one input stage as
// they finish (the surface: slabs stitched in plane order as they come).
//
// Job keys: "<instant>/<stage>/<part name>", "<instant>/<stage>" for one-part stages
// (the journal's keys, master/journal.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <typeindex>
#include <typeinfo>
#include <vector>

#include "pipeline/session.h"
#include "runtime.pb.h"
#include "take/take.h"

namespace dome::pipeline {

// The bytes of a job's blobs, in the job's order (shared with a worker's blob cache).
using JobBlobs = std::vector<std::shared_ptr<const std::string>>;

// Blobs by content address, shared by the master's threads (its blob store).
class BlobAccess {
 public:
  virtual ~BlobAccess() = default;
  // The bytes, or nothing when unknown or unreadable.
  virtual std::optional<std::string> Read(const std::string& sha256) const = 0;
  // Stores the bytes as a session output and returns its reference (name set).
  virtual runtime::BlobRef Keep(const std::string& bytes, const std::string& name) = 0;
  // The same for bytes just written whole to the output file `written` (OUT/<instant>/
  // textured.obj): a store on the same disk may make its copy a second name of that file
  // (a hard link) instead of writing the bytes again. This default keeps them as Keep.
  virtual runtime::BlobRef KeepWritten(const std::string& bytes, const std::string& name,
                                       const std::filesystem::path& written) {
    (void)written;
    return Keep(bytes, name);
  }
};

// What a job is made from: one part of one instant of a session.
struct JobContext {
  const SessionPlan& plan;
  int instant = 0;  // index into plan.instants
  int part = 0;     // index into the stage's parts
  // The outputs of part `part` of stage `stage` of this instant (a stage this one comes
  // after, so done).
  std::function<const std::vector<runtime::BlobRef>&(const std::string& stage, int part)> outputs;
  // For a stage that waits for its own part of the previous instant (instant > 0): the
  // outputs of that job.
  std::function<const std::vector<runtime::BlobRef>&()> previous_outputs;
};

// Where a finished job's outputs go (beside the master's loop: reads only the plan).
struct StoreContext {
  const SessionPlan& plan;
  int instant = 0;
  int part = 0;
  std::filesystem::path dir;  // OUT/<instant>
  std::string where;          // "<peer> result of <job id>", for errors
  BlobAccess* blobs = nullptr;
};

struct StoredResult {
  std::vector<runtime::BlobRef> outputs;  // journalled, and the inputs of later stages
  // What checking decoded (a slab), handed on to a master stage that reads this output,
  // so that it is not read and decoded again; may be null.
  std::shared_ptr<const void> decoded;
};

// One instant's run of a master stage: a thread of its own, fed by the master's loop.
class MasterStageRun {
 public:
  virtual ~MasterStageRun() = default;
  // Part `part` of the input stage is done with `outputs` (and `decoded`, from storing
  // it). Feeding a part twice keeps the first.
  virtual void Feed(int part, const std::vector<runtime::BlobRef>& outputs,
                    std::shared_ptr<const void> decoded) = 0;
  // Stops waiting for input; the run then ends with an error.
  virtual void Abort() = 0;
  // True once the run has ended (outputs stored, or an error).
  virtual bool Finished() const = 0;
  // After Finished(): its outputs; throws core::InputError with the run's error.
  virtual std::vector<runtime::BlobRef> Result() = 0;
  // Seconds it spent working, waits excluded.
  virtual double busy_seconds() const = 0;
};

struct MasterStageContext {
  const SessionPlan& plan;
  int instant = 0;
  std::filesystem::path dir;  // OUT/<instant>
  BlobAccess* blobs = nullptr;
  // Called from the run's own thread once Finished() is true, so that the master's loop
  // completes it at once rather than at its next turn; may be empty.
  std::function<void()> finished;
};

class JobMemo;

struct StageDescriptor {
  std::string name;  // in job keys, jobs, status and report.json
  // The names of its parts in one instant of `plan` (an empty name: the stage's only
  // part); none: the stage does not run in this session.
  std::function<std::vector<std::string>(const SessionPlan& plan)> parts;
  std::vector<std::string> after;  // stages whose every part of the instant comes first
  // True for a session where part p of instant t > 0 also waits for part p of this stage
  // in instant t-1 (parts must then be the same in every instant); unset: never.
  std::function<bool(const SessionPlan& plan)> after_previous_instant;

  // A worker stage: makes a job (settings and blobs; the master sets the rest), runs it
  // (on a worker: pure, no sockets or files), checks and stores its result (on the
  // master; throws core::InputError naming ctx.where for a bad result).
  std::function<void(const JobContext& ctx, runtime::Job* job)> make_job;
  std::function<std::vector<runtime::Output>(const runtime::Job& job, const JobBlobs& blobs,
                                             JobMemo* memo)>
      run;
  std::function<StoredResult(const StoreContext& ctx, const runtime::JobResult& result)> store;
  // Many jobs an instant: one may wait on a busy worker behind its running job
  // (master/master.h MasterOptions::jobs_ahead).
  bool send_ahead = false;
  // One job that ends an instant: it runs on the threads the process's idle workers
  // lend as well as its worker's own (shared_hulls.h LentThreads). Stages of many parts
  // keep their own: the master keeps every worker busy with them, and their shared hulls
  // and tables are keyed by the job's threads.
  bool borrows_idle_threads = false;

  // A master stage instead (one `after` stage, whose outputs it is fed).
  std::function<std::unique_ptr<MasterStageRun>(const MasterStageContext& ctx)> start_on_master;
  // Once this stage's part of an instant is done and journalled, the outputs of the
  // stages it comes after are dropped (the slabs, once the surface holds them); a
  // resumed session then takes their journal records as done without outputs.
  bool consumes_inputs = false;

  bool on_master() const { return static_cast<bool>(start_on_master); }
};

// The stages of a pipeline in order (a stage comes after earlier ones only).
struct StageSet {
  std::vector<StageDescriptor> stages;
  // Index of the stage named `name`, or -1.
  int Find(const std::string& name) const;
};

// stereo, fusion, surface (master), decimate, texture, and noop (the no-op jobs of
// dispatch benchmarks: a session with noop_jobs runs only those).
std::shared_ptr<const StageSet> DefaultStages();

// Runs `job` with the stage it names; `blobs` are the bytes of job.blobs, in order.
// Throws core::InputError naming the job when no stage of `stages` has its name.
std::vector<runtime::Output> RunJob(const StageSet& stages, const runtime::Job& job,
                                    const JobBlobs& blobs, JobMemo* memo = nullptr);

// What a worker keeps from one job for the next, so that work shared by jobs is done
// once: the decoded range images and tables of the instant whose slabs it fuses, the
// decoded frames of its stereo and texture jobs. One entry of each kind (type), keyed by what it
// was built from, so that a job's outputs are the same bytes with or without a memo;
// kinds apart, so that stereo jobs of the next instant between an instant's slab jobs
// do not drop the slabs' tables. Not thread-safe: one job at a time.
class JobMemo {
 public:
  // The entry of kind T for `key`, built by `build` unless it is the one kept.
  template <class T>
  T* Get(const std::string& key, const std::function<std::unique_ptr<T>()>& build) {
    Entry& e = entries_[std::type_index(typeid(T))];
    if (!e.value || e.key != key) {
      e.value.reset();  // the old entry goes before the new one is built: one in memory
      e.key.clear();
      e.value = std::shared_ptr<void>(build().release(), [](void* p) { delete static_cast<T*>(p); });
      e.key = key;
      ++builds_;
    }
    return static_cast<T*>(e.value.get());
  }
  // How many entries were built (a figure for tests and logs).
  int64_t builds() const { return builds_; }

 private:
  struct Entry {
    std::string key;
    std::shared_ptr<void> value;
  };
  std::map<std::type_index, Entry> entries_;
  int64_t builds_ = 0;
};


// Helpers for descriptors: the output named `name` of `result` (throws InputError
// naming `where` when missing), and the blob-layout checks of a job.
const std::string& OutputBytes(const runtime::JobResult& result, const std::string& name,
                               const std::string& where);

}  // namespace dome::pipeline
