// Process memory settings (core/memory.h): the pages of fresh memory, as the environment
// says or as the machine's first touches measure.
#include "core/memory.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace dome::core {
namespace {

// The process flag the kernel reads when it places a fresh mapping's pages, and that
// the processes this one starts inherit.
int HugePagesOff() { return prctl(PR_GET_THP_DISABLE, 0, 0, 0, 0); }

// The VmFlags line of the mapping of /proc/self/smaps that holds `address` ("" if none).
std::string VmFlags(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  const auto at = reinterpret_cast<uintptr_t>(address);
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = lo <= at && at < hi;
    } else if (inside && line.rfind("VmFlags:", 0) == 0) {
      return line;
    }
  }
  return "";
}

// Whether the kernel's huge-page advice ("hg") is on the mapping holding `address`.
bool AdvisedHuge(const void* address) {
  std::istringstream flags(VmFlags(address));
  std::string flag;
  while (flags >> flag)
    if (flag == "hg") return true;
  return false;
}

// A fresh anonymous mapping of 8 MB, with what AdviseHugePages makes of it.
bool FreshMappingAdvisedHuge() {
  const size_t bytes = size_t{8} << 20;
  void* m = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  EXPECT_NE(m, MAP_FAILED);
  AdviseHugePages(m, bytes);
  // The middle of the mapping: the advice covers the whole 2 MB pages inside it.
  const bool advised = AdvisedHuge(static_cast<char*>(m) + bytes / 2);
  munmap(m, bytes);
  return advised;
}

TEST(Memory, TheEnvironmentChoosesSmallOrHugePages) {
  RetainFreedMemory();
  ::setenv("DOME_TRANSPARENT_HUGEPAGES", "0", 1);
  EXPECT_EQ(ChoosePageSize(), PageSize::kSmall);
  EXPECT_EQ(ChosenPageSize(), PageSize::kSmall);
  EXPECT_EQ(HugePagesOff(), 1);
  EXPECT_FALSE(FreshMappingAdvisedHuge());
  EXPECT_EQ(ChoosePageSize(), PageSize::kSmall);  // idempotent
  EXPECT_EQ(HugePagesOff(), 1);

  ::setenv("DOME_TRANSPARENT_HUGEPAGES", "1", 1);
  EXPECT_EQ(ChoosePageSize(), PageSize::kHuge);
  EXPECT_EQ(ChosenPageSize(), PageSize::kHuge);
  EXPECT_EQ(HugePagesOff(), 0);
  EXPECT_TRUE(FreshMappingAdvisedHuge());
  // The heap's reserve: what malloc places there (a buffer below the mmap threshold)
  // lies in address space advised for huge pages.
  void* buffer = std::malloc(size_t{4} << 20);
  ASSERT_NE(buffer, nullptr);
  EXPECT_TRUE(AdvisedHuge(static_cast<char*>(buffer) + (size_t{2} << 20))) << VmFlags(buffer);
  std::free(buffer);

  ::setenv("DOME_TRANSPARENT_HUGEPAGES", "0", 1);
  EXPECT_EQ(ChoosePageSize(), PageSize::kSmall);
  EXPECT_EQ(HugePagesOff(), 1);
  EXPECT_FALSE(FreshMappingAdvisedHuge());
  ::unsetenv("DOME_TRANSPARENT_HUGEPAGES");
}

TEST(Memory, WithoutTheEnvironmentTheProbeDecidesAndTheProcessFollowsIt) {
  for (const char* value : {static_cast<const char*>(nullptr), "auto"}) {
    if (value == nullptr) {
      ::unsetenv("DOME_TRANSPARENT_HUGEPAGES");
    } else {
      ::setenv("DOME_TRANSPARENT_HUGEPAGES", value, 1);
    }
    const PageSize chosen = ChoosePageSize();
    EXPECT_EQ(ChosenPageSize(), chosen);
    // Whichever the machine gets, the process is set up for it.
    EXPECT_EQ(HugePagesOff(), chosen == PageSize::kSmall ? 1 : 0);
    EXPECT_EQ(FreshMappingAdvisedHuge(), chosen == PageSize::kHuge);
  }
  ::unsetenv("DOME_TRANSPARENT_HUGEPAGES");
}

}  // namespace
}  // namespace dome::core
