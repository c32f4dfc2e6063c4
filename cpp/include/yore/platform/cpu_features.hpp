#pragma once
/// @file cpu_features.hpp
/// The instruction sets this CPU runs *and* the operating system has enabled (CPUID and XGETBV),
/// read without touching any BLAS: the package asks before CHOLMOD's BLAS loads, to choose that
/// BLAS's kernels (python/yore/blas.py). No dependency but the compiler's <cpuid.h>.

#include <string>
#include <vector>

namespace yore {

/// What CPUID says of the processor, with the vector extensions filtered by what the OS saves
/// on a context switch (XCR0): an AVX instruction the OS does not enable faults like a missing one.
struct CpuFeatures {
  std::string vendor;  ///< CPUID's vendor string, e.g. "GenuineIntel"; empty off x86-64
  int family = 0;      ///< display family (base + extended)
  int model = 0;       ///< display model (base + extended for families 6 and 15)
  /// Usable extensions, lowercase as Linux's /proc/cpuinfo names them (sse3, ssse3, sse4_1,
  /// sse4_2, avx, fma, fma4, avx2, avx512f, avx512cd, avx512bw, avx512dq, avx512vl,
  /// avx512_bf16), sorted.
  std::vector<std::string> extensions;
  bool os_saves_ymm = false;  ///< XCR0 enables SSE and AVX state (bits 1, 2)
  bool os_saves_zmm = false;  ///< XCR0 also enables the AVX-512 state (bits 5, 6, 7)
};

/// Reads this CPU's features. Off x86-64 every field is empty or false. Never throws.
CpuFeatures cpu_features();

}  // namespace yore
