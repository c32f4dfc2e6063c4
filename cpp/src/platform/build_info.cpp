#include "yore/platform/build_info.hpp"

#include <cholmod.h>
#include <dlfcn.h>

#include <Eigen/Core>
#include <atomic>
#include <sstream>
#include <stdexcept>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace yore {
namespace {

// 0 until set_max_threads is called: then OpenMP's own default applies. One process-wide value,
// not OpenMP's per-thread ICV, so a count set from one Python thread holds in every thread.
std::atomic<int> g_max_threads{0};

// CHOLMOD links libblas.so.3, which Debian resolves at run time (OpenBLAS, reference BLAS,
// ...). Look OpenBLAS's thread control up in the copy already loaded instead of linking it:
// yore then builds and runs against any BLAS. Python loads extensions RTLD_LOCAL, so
// RTLD_DEFAULT would not see it; RTLD_NOLOAD returns the loaded library without loading one.
void* openblas_symbol(const char* name) {
  for (const char* library : {"libblas.so.3", "libopenblas.so.0"}) {
    if (void* handle = dlopen(library, RTLD_LAZY | RTLD_NOLOAD)) {
      void* symbol = dlsym(handle, name);
      dlclose(handle);  // drops only the reference RTLD_NOLOAD added
      if (symbol != nullptr) return symbol;
    }
  }
  return nullptr;
}

}  // namespace

std::map<std::string, std::string> build_info() {
  std::map<std::string, std::string> info;
  info["eigen"] = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) +
                  "." + std::to_string(EIGEN_MINOR_VERSION);
  // Ask the linked library, not the header: proves CHOLMOD is really linked and which one loaded.
  int version[3] = {0, 0, 0};
  cholmod_version(version);
  info["cholmod"] = std::to_string(version[0]) + "." + std::to_string(version[1]) + "." +
                    std::to_string(version[2]);
#if defined(__clang__)
  info["compiler"] = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  info["compiler"] = std::string("gcc ") + __VERSION__;
#else
  info["compiler"] = "unknown";
#endif
#ifdef _OPENMP
  info["openmp"] = std::to_string(_OPENMP);
#else
  info["openmp"] = "off";
#endif
#ifdef NDEBUG
  info["build_type"] = "release";
#else
  info["build_type"] = "debug";
#endif
  using GetConfig = char* (*)();
  auto config = reinterpret_cast<GetConfig>(openblas_symbol("openblas_get_config"));
  info["blas"] = config != nullptr ? std::string(config()) : "not OpenBLAS";
  // The kernel set OpenBLAS chose when it loaded (its DYNAMIC_ARCH builds pick one per CPU).
  auto corename = reinterpret_cast<GetConfig>(openblas_symbol("openblas_get_corename"));
  info["blas_kernel"] = corename != nullptr ? std::string(corename()) : "";
  return info;
}

int max_threads() {
  const int configured = g_max_threads.load(std::memory_order_relaxed);
  if (configured > 0) return configured;
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

void set_max_threads(int threads) {
  if (threads < 1) {
    std::ostringstream msg;
    msg << "the number of threads must be >= 1, got " << threads;
    throw std::invalid_argument(msg.str());
  }
  g_max_threads.store(threads, std::memory_order_relaxed);
#ifdef _OPENMP
  omp_set_num_threads(threads);  // for OpenMP loops that do not pass num_threads themselves
#endif
  set_blas_threads(threads);
}

bool set_blas_threads(int threads) {
  if (threads < 1) {
    std::ostringstream msg;
    msg << "the number of BLAS threads must be >= 1, got " << threads;
    throw std::invalid_argument(msg.str());
  }
  using SetThreads = void (*)(int);
  auto set = reinterpret_cast<SetThreads>(openblas_symbol("openblas_set_num_threads"));
  if (set == nullptr) return false;
  set(threads);
  return true;
}

int blas_threads() {
  using GetThreads = int (*)();
  auto get = reinterpret_cast<GetThreads>(openblas_symbol("openblas_get_num_threads"));
  return get != nullptr ? get() : 0;
}

}  // namespace yore
