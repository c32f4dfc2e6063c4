#pragma once
/// @file errors.hpp
/// Numerical failures that are not bad input, and bad input that names its argument.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

namespace yore {

/// Thrown when a run blows up (non-finite state, or energy growing past its bound). Carries where
/// it happened and a time step that the stability estimate expects to be stable.
class SimulationDiverged : public std::runtime_error {
 public:
  SimulationDiverged(const std::string& message, std::int64_t step, double time, double dt,
                     double stable_dt)
      : std::runtime_error(message), m_step(step), m_time(time), m_dt(dt), m_stable_dt(stable_dt) {}
  /// Index of the failing step since the integrator was created (0-based).
  std::int64_t step() const { return m_step; }
  /// Simulated time at the end of the failing step, s.
  double time() const { return m_time; }
  /// Time step in use, s.
  double dt() const { return m_dt; }
  /// Estimated stable time step, s.
  double stable_dt() const { return m_stable_dt; }

 private:
  std::int64_t m_step;
  double m_time, m_dt, m_stable_dt;
};

}  // namespace yore

namespace yore {

/// Thrown when a matrix that must be positive definite is not (e.g. CHOLMOD reports a
/// non-positive pivot). Names the failing column.
class NotPositiveDefinite : public std::runtime_error {
 public:
  explicit NotPositiveDefinite(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace yore

namespace yore {

/// Bad input (a std::invalid_argument) that carries the name of the argument at fault, so a
/// caller can point at where the value came from (a scene file's key) without reading the
/// message. argument() is the bare name: "stretch_stiffness", "masses", "poisson_ratio".
class InvalidArgument : public std::invalid_argument {
 public:
  InvalidArgument(const std::string& message, std::string argument)
      : std::invalid_argument(message), m_argument(std::move(argument)) {}
  const std::string& argument() const { return m_argument; }

 private:
  std::string m_argument;
};

}  // namespace yore
