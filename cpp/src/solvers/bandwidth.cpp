#include "yore/solvers/bandwidth.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>

#include "yore/platform/build_info.hpp"
#include "yore/platform/timer.hpp"

namespace yore {

double stream_triad_bandwidth(std::size_t elements, int repeats) {
  if (elements < 1 || repeats < 1) {
    throw std::invalid_argument("stream_triad_bandwidth: elements and repeats must be >= 1");
  }
  const auto n = static_cast<std::int64_t>(elements);
  const int threads = max_threads();
  std::unique_ptr<double[]> a(new double[elements]), b(new double[elements]),
      c(new double[elements]);
  // First touch by the threads that will use the pages.
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::int64_t i = 0; i < n; ++i) {
    a[i] = 0.0;
    b[i] = 1.0;
    c[i] = 2.0;
  }
  double best = std::numeric_limits<double>::infinity();
  const double scale = 3.0;
  for (int r = 0; r < repeats; ++r) {
    const Stopwatch watch;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::int64_t i = 0; i < n; ++i) a[i] = b[i] + scale * c[i];
    const double seconds = watch.seconds();
    best = std::min(best, seconds);
  }
  // Keep the result observable so the loop is not optimised away.
  volatile double sink = a[static_cast<std::size_t>(n / 2)];
  (void)sink;
  return 3.0 * 8.0 * static_cast<double>(elements) / best;
}

}  // namespace yore
