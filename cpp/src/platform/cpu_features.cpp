#include "yore/platform/cpu_features.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#define YORE_X86 1
#endif

namespace yore {
namespace {

#ifdef YORE_X86
struct Registers {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
};

Registers cpuid(unsigned leaf, unsigned subleaf = 0) {
  Registers r;
  __cpuid_count(leaf, subleaf, r.eax, r.ebx, r.ecx, r.edx);
  return r;
}

// XGETBV by its opcode: the mnemonic needs -mxsave, which would let the compiler use XSAVE
// anywhere in this unit. Only called when CPUID says OSXSAVE (the OS enabled XGETBV).
std::uint64_t xcr0() {
  unsigned low = 0, high = 0;
  __asm__ volatile(".byte 0x0f, 0x01, 0xd0" : "=a"(low), "=d"(high) : "c"(0));
  return (static_cast<std::uint64_t>(high) << 32) | low;
}

bool bit(unsigned value, int index) { return ((value >> index) & 1u) != 0; }
#endif

}  // namespace

CpuFeatures cpu_features() {
  CpuFeatures features;
#ifdef YORE_X86
  const Registers vendor = cpuid(0);
  const unsigned highest = vendor.eax;
  char name[13] = {};
  std::memcpy(name, &vendor.ebx, 4);
  std::memcpy(name + 4, &vendor.edx, 4);
  std::memcpy(name + 8, &vendor.ecx, 4);
  features.vendor = name;
  if (highest < 1) return features;

  const Registers basic = cpuid(1);
  const int base_family = static_cast<int>((basic.eax >> 8) & 0xf);
  const int base_model = static_cast<int>((basic.eax >> 4) & 0xf);
  features.family =
      base_family == 0xf ? base_family + static_cast<int>((basic.eax >> 20) & 0xff) : base_family;
  features.model = (base_family == 0x6 || base_family == 0xf)
                       ? base_model + (static_cast<int>((basic.eax >> 16) & 0xf) << 4)
                       : base_model;

  const bool osxsave = bit(basic.ecx, 27);
  const std::uint64_t xcr = osxsave ? xcr0() : 0;
  features.os_saves_ymm = (xcr & 0x6) == 0x6;
  features.os_saves_zmm = features.os_saves_ymm && (xcr & 0xe0) == 0xe0;

  auto& out = features.extensions;
  if (bit(basic.ecx, 0)) out.push_back("sse3");
  if (bit(basic.ecx, 9)) out.push_back("ssse3");
  if (bit(basic.ecx, 19)) out.push_back("sse4_1");
  if (bit(basic.ecx, 20)) out.push_back("sse4_2");
  const bool avx = features.os_saves_ymm && bit(basic.ecx, 28);
  if (avx) out.push_back("avx");
  if (avx && bit(basic.ecx, 12)) out.push_back("fma");

  if (cpuid(0x80000000).eax >= 0x80000001) {
    const Registers extended = cpuid(0x80000001);
    if (avx && bit(extended.ecx, 16)) out.push_back("fma4");
  }
  if (highest >= 7) {
    const Registers structured = cpuid(7, 0);
    if (avx && bit(structured.ebx, 5)) out.push_back("avx2");
    if (avx && features.os_saves_zmm) {
      const std::pair<int, const char*> avx512[] = {
          {16, "avx512f"}, {17, "avx512dq"}, {28, "avx512cd"}, {30, "avx512bw"}, {31, "avx512vl"}};
      for (const auto& [index, extension] : avx512) {
        if (bit(structured.ebx, index)) out.push_back(extension);
      }
      if (bit(structured.ebx, 16) && structured.eax >= 1 && bit(cpuid(7, 1).eax, 5)) {
        out.push_back("avx512_bf16");
      }
    }
  }
  std::sort(out.begin(), out.end());
#endif
  return features;
}

}  // namespace yore
