#include "yore/build_info.hpp"

#include <Eigen/Core>
#include <cholmod.h>

#include <sstream>
#include <stdexcept>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace yore {

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
  return info;
}

int max_threads() {
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
#ifdef _OPENMP
  omp_set_num_threads(threads);
#endif
}

}  // namespace yore
