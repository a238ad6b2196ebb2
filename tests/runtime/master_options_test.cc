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
}

}  // namespace
}  // namespace dome::scheduler
