// Tests of cpp/src/solvers/bandwidth.cpp (cpp/include/yore/solvers/bandwidth.hpp): the STREAM-triad
// probe.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "yore/solvers/bandwidth.hpp"

TEST_CASE("the triad reports a finite, positive bandwidth and refuses empty work") {
  // 2e5 doubles × 3 arrays = 4.8 MB: a few milliseconds; the value itself is the machine's,
  // so only its order of magnitude is a contract (bytes per second)
  const double bandwidth = yore::stream_triad_bandwidth(200000, 2);
  CHECK(std::isfinite(bandwidth));
  CHECK(bandwidth > 1e7);   // 10 MB/s: far below any memory system, even a loaded one
  CHECK(bandwidth < 1e13);  // 10 TB/s: far above; a unit slip (bits, one array) would show
  CHECK_THROWS_WITH_AS(yore::stream_triad_bandwidth(0, 3),
                       doctest::Contains("elements and repeats must be >= 1"),
                       std::invalid_argument);
  CHECK_THROWS_AS(yore::stream_triad_bandwidth(10, 0), std::invalid_argument);
}
