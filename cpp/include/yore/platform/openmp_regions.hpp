#pragma once
/// @file openmp_regions.hpp
/// OpenMP regions of one thread without a libgomp team (openmp_regions.cpp).
///
/// libgomp runs a parallel region that gets one thread as a team of one, and ends it with a
/// futex_wake system call (its team barrier wakes waiters unconditionally). This module therefore
/// defines GOMP_parallel, the entry point compiled OpenMP code calls for a region; the dynamic
/// linker binds yore's own code and CHOLMOD (loaded as this module's dependency, so this module
/// comes first in its scope) to it ahead of libgomp's. A region opened outside any parallel
/// region runs inline, on the calling thread, when it would get one thread anyway (an `if`
/// clause that is false, `num_threads(1)`, or one thread configured) or inside a SerialRegions
/// scope; every other region goes to libgomp. Inline is exactly a team of one: thread 0 of 1,
/// and worksharing constructs bind to the calling thread alone.

#include <cstdint>

namespace yore {

/// For its lifetime, on this thread: no active OpenMP level (omp_set_max_active_levels(0),
/// process-wide in libgomp), so code that asks for a team of several threads gets one, and
/// those regions run inline. For calls into CHOLMOD, whose supernodal factorization asks for
/// teams of 4 whatever the thread setting. `inlined`, when given, gains the regions run
/// inline during the scope.
class SerialRegions {
 public:
  explicit SerialRegions(std::int64_t* inlined = nullptr);
  ~SerialRegions();
  SerialRegions(const SerialRegions&) = delete;
  SerialRegions& operator=(const SerialRegions&) = delete;

 private:
  std::int64_t* m_inlined;
  std::int64_t m_start;
  int m_saved_levels = 1;
};

/// Regions this thread has run inline so far (0 where libgomp's GOMP_parallel was bound first,
/// e.g. libgomp loaded into the global scope before yore).
std::int64_t openmp_regions_inlined_on_this_thread();

}  // namespace yore
