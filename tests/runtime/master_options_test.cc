#include <gtest/gtest.h>

#include "master/master.h"
#include "testing/expect_error.h"

namespace dome::scheduler {
namespace {

TEST(MasterOptions, OutOfRangeValuesAreNamed) {
  MasterOptions ok;
  ok.Check();
  MasterOptions o = ok;
  o.writer_threads = -1;
  testing::ExpectInputError([&] { o.Check(); }, {"writer_threads", "0..256", "got -1"});
  o = ok;
  o.jobs_ahead = 17;
  testing::ExpectInputError([&] { o.Check(); }, {"jobs_ahead", "got 17"});
  o = ok;
  o.heartbeat_liveness = 0;
  testing::ExpectInputError([&] { o.Check(); }, {"heartbeat_liveness", "positive"});
  // The time-outs, memory bound and memory release of the never-hang rules.
  o = ok;
  o.job_timeout_s = -1;
  testing::ExpectInputError([&] { o.Check(); }, {"job_timeout_s", "0 (derived)"});
  o = ok;
  o.job_timeout_min_s = 0;
  testing::ExpectInputError([&] { o.Check(); }, {"job_timeout_min_s", "positive"});
  o = ok;
  o.job_timeout_first_s_per_mib = -2;
  testing::ExpectInputError([&] { o.Check(); }, {"job_timeout_first_s_per_mib", "negative"});
  o = ok;
  o.job_timeout_factor = 0.5;
  testing::ExpectInputError([&] { o.Check(); }, {"job_timeout_factor", "at least 1"});
  o = ok;
  o.max_job_mb = -1;
  testing::ExpectInputError([&] { o.Check(); }, {"max_job_mb", "got -1"});
  o = ok;
  o.release_memory_s = -1;
  testing::ExpectInputError([&] { o.Check(); }, {"release_memory_s", "0 (never)"});
}

}  // namespace
}  // namespace dome::scheduler
