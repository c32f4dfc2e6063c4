// Tests of cpp/src/platform/cpu_features.cpp (cpp/include/yore/platform/cpu_features.hpp): what
// CPUID and XGETBV say, checked against the rules that hold on every x86-64 processor and OS, and
// against Linux's own reading (/proc/cpuinfo) where there is one.
#include <doctest/doctest.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "yore/platform/cpu_features.hpp"

namespace {

bool has(const yore::CpuFeatures& features, const std::string& extension) {
  return std::find(features.extensions.begin(), features.extensions.end(), extension) !=
         features.extensions.end();
}

// The "flags" line of /proc/cpuinfo's first processor, empty where there is none.
std::set<std::string> linux_flags() {
  std::ifstream file("/proc/cpuinfo");
  std::string line;
  while (std::getline(file, line)) {
    if (line.rfind("flags", 0) == 0) {
      std::istringstream words(line.substr(line.find(':') + 1));
      std::set<std::string> flags;
      for (std::string word; words >> word;) flags.insert(word);
      return flags;
    }
  }
  return {};
}

}  // namespace

TEST_CASE("cpu_features: every extension implies the ones it is built on") {
  const auto features = yore::cpu_features();
#if defined(__x86_64__)
  CHECK_FALSE(features.vendor.empty());
  CHECK(features.family >= 6);  // every x86-64 processor
  CHECK(std::is_sorted(features.extensions.begin(), features.extensions.end()));
  // the OS enables AVX-512 state only on top of AVX state
  CHECK((!features.os_saves_zmm || features.os_saves_ymm));
  const std::pair<const char*, const char*> implies[] = {
      {"ssse3", "sse3"},       {"sse4_1", "ssse3"},     {"sse4_2", "sse4_1"},
      {"fma", "avx"},          {"avx2", "avx"},         {"avx512f", "avx2"},
      {"avx512bw", "avx512f"}, {"avx512vl", "avx512f"}, {"avx512_bf16", "avx512f"}};
  for (const auto& [extension, base] : implies) {
    CAPTURE(extension);
    CHECK((!has(features, extension) || has(features, base)));
  }
  if (has(features, "avx")) CHECK(features.os_saves_ymm);
  if (has(features, "avx512f")) CHECK(features.os_saves_zmm);
#else
  CHECK(features.extensions.empty());
#endif
}

TEST_CASE("cpu_features agrees with the Linux kernel's reading of the same CPU") {
  const auto flags = linux_flags();
  if (flags.empty()) return;  // not Linux, or no /proc
  const auto features = yore::cpu_features();
  // Linux names SSE3 "pni"; the rest by the same names. The kernel clears the AVX family when
  // it does not save their state, as XCR0 tells us, so both readings agree on usable sets.
  for (const std::string extension :
       {"ssse3", "sse4_1", "sse4_2", "avx", "fma", "avx2", "avx512f", "avx512cd", "avx512bw",
        "avx512dq", "avx512vl", "avx512_bf16"}) {
    CAPTURE(extension);
    CHECK(has(features, extension) == (flags.count(extension) == 1));
  }
  CHECK(has(features, "sse3") == (flags.count("pni") == 1));
}
