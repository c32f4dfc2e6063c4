#pragma once
/// @file timer.hpp
/// Wall-time accounting of the integrators' phases.

#include <chrono>

namespace yore {

/// Adds the wall time of its own lifetime, in seconds, to a counter.
class ScopedTimer {
 public:
  explicit ScopedTimer(double& total) : m_total(total), m_start(Clock::now()) {}
  ~ScopedTimer() { m_total += std::chrono::duration<double>(Clock::now() - m_start).count(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  using Clock = std::chrono::steady_clock;
  double& m_total;
  Clock::time_point m_start;
};

}  // namespace yore
