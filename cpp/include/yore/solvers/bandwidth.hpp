#pragma once
/// @file bandwidth.hpp
/// A memory-bandwidth probe (STREAM triad) for the benchmarks' roofline of the explicit step.

#include <cstddef>

namespace yore {

/// Memory bandwidth of the triad a[i] = b[i] + s·c[i] over arrays of `elements` doubles (far
/// larger than the caches), with the core's OpenMP threads: bytes moved (3 × 8 per element,
/// write-allocate not counted, as STREAM does) over the best of `repeats` timings, bytes/s.
/// Throws std::invalid_argument for elements or repeats < 1.
double stream_triad_bandwidth(std::size_t elements, int repeats);

}  // namespace yore
