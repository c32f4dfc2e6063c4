#pragma once
/// @file timer.hpp
/// Wall-time accounting of the integrators' phases.

#include <chrono>

namespace yore {

/// Wall time since construction or the last restart(), in seconds (steady clock).
class Stopwatch {
 public:
  Stopwatch() : m_start(Clock::now()) {}
  void restart() { m_start = Clock::now(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - m_start).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point m_start;
};

/// Adds the wall time of its own lifetime, in seconds, to a counter.
class ScopedTimer {
 public:
  explicit ScopedTimer(double& total) : m_total(total) {}
  ~ScopedTimer() { m_total += m_watch.seconds(); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& m_total;
  Stopwatch m_watch;
};

}  // namespace yore
