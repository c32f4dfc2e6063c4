#include "yore/platform/openmp_regions.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

#if defined(_OPENMP) && defined(__GLIBC__)
#include <dlfcn.h>
#endif

namespace yore {
namespace {

thread_local int t_serial_depth = 0;
thread_local std::int64_t t_inlined = 0;

}  // namespace

SerialRegions::SerialRegions(std::int64_t* inlined) : m_inlined(inlined), m_start(t_inlined) {
#ifdef _OPENMP
  m_saved_levels = omp_get_max_active_levels();
  omp_set_max_active_levels(0);
#endif
  ++t_serial_depth;
}

SerialRegions::~SerialRegions() {
  --t_serial_depth;
#ifdef _OPENMP
  omp_set_max_active_levels(m_saved_levels);
#endif
  if (m_inlined) *m_inlined += t_inlined - m_start;
}

std::int64_t openmp_regions_inlined_on_this_thread() { return t_inlined; }

#if defined(_OPENMP) && defined(__GLIBC__)
namespace {

bool runs_inline(unsigned num_threads) {
  if (omp_get_level() != 0) return false;  // nested: libgomp decides
  if (t_serial_depth > 0) return true;
  // GCC passes 1 for a false `if` clause and for num_threads(1), 0 for "as configured"
  return num_threads == 1 || (num_threads == 0 && omp_get_max_threads() == 1);
}

}  // namespace
#endif

}  // namespace yore

#if defined(_OPENMP) && defined(__GLIBC__)
// Measured: CHOLMOD's regions cost ~9 200 futex calls per factorization of the 64² sheet (a
// Newton iteration 0.75 as expensive without them, with the permuted storage; see
// docs/integrators.md, The factorization); yore's own loops 3 per explicit step at 32² (2.5 %
// of it with one thread).
extern "C" __attribute__((visibility("default"))) void GOMP_parallel(void (*body)(void*),
                                                                     void* data,
                                                                     unsigned num_threads,
                                                                     unsigned flags) {
  using Parallel = void (*)(void (*)(void*), void*, unsigned, unsigned);
  static const auto libgomp = reinterpret_cast<Parallel>(dlsym(RTLD_NEXT, "GOMP_parallel"));
  // no libgomp after this definition (not seen: it is a dependency of this module): serial
  if (libgomp == nullptr || yore::runs_inline(num_threads)) {
    ++yore::t_inlined;
    body(data);
    return;
  }
  libgomp(body, data, num_threads, flags);
}
#endif
