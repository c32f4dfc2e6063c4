#pragma once
/// @file integrator.hpp
/// The interface every time integrator of yore implements (explicit, Newton's implicit methods,
/// local-global), and the history a state file keeps of one.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "yore/cloth/cloth.hpp"

namespace yore {

/// The public names of the integrators that are not Newton time schemes (yore.INTEGRATORS in
/// Python, and the failure messages here), written once; the time schemes' names are their rows
/// of time_schemes() (schemes/registry.cpp).
namespace integrator_name {
inline constexpr const char* kExplicit = "explicit";
inline constexpr const char* kQuasiNewton = "quasi-newton";
inline constexpr const char* kLocalGlobal = "local-global";
inline constexpr const char* kCvode = "cvode";
inline constexpr const char* kArkode = "arkode";
}  // namespace integrator_name

/// Every public integrator name the core implements: the explicit integrator, each time
/// scheme's row, then quasi-Newton, local-global and the SUNDIALS methods (Python's registry
/// checks it lists exactly these).
std::vector<std::string> integrator_names();

/// What an integrator carries from one step to the next besides the cloth's state: named
/// arrays (n×3 each, in the units their names say) and the step size of the last step, s.
struct IntegratorHistory {
  bool valid = false;  ///< false: the next step starts afresh (none kept, or the cloth changed)
  double dt = 0.0;
  /// Error-controlled BDF2 (dt = "auto"): the step proposed for the next output interval, s
  /// (its dt is the last step taken, which the variable-step formula needs); 0: none.
  double next_dt = 0.0;
  std::vector<std::pair<std::string, Positions>> arrays;
  /// The array called `name`. Throws std::invalid_argument naming it when it is absent.
  const Positions& array(const std::string& name) const;
};

/// A time integrator of a Cloth. It owns only caches derived from the cloth, keyed by
/// Cloth::topology_version (a stroke needs no call: the next step sees the new version and
/// rebuilds what depends on it), its statistics, and the history its method needs between
/// steps, which history()/set_history() expose for state files.
class Integrator {
 public:
  virtual ~Integrator() = default;
  /// Runs `steps` steps of dt (s) under gravity (m/s²). Throws SimulationDiverged (cloth
  /// restored to its state at the start of the call) when a step blows up, std::invalid_argument
  /// on bad dt, gravity or steps.
  virtual void advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) = 0;
  /// The names of the history's arrays, in order; empty when the method keeps none.
  virtual std::vector<std::string> history_fields() const { return {}; }
  /// The history the next step of `cloth` would use; invalid when the method keeps none or
  /// the next step would start afresh.
  virtual IntegratorHistory history(const Cloth& cloth) const;
  /// Restores a history taken by history(), for `cloth` as it is now (a resumed run); an invalid
  /// one makes the next step start afresh. Throws std::invalid_argument on missing arrays,
  /// shapes that do not match the cloth, non-finite values or a non-positive dt, and on a valid
  /// history for a method that keeps none.
  virtual void set_history(const Cloth& cloth, const IntegratorHistory& history);

 protected:
  /// Checks a history against history_fields() and the cloth (see set_history).
  void check_history(const Cloth& cloth, const IntegratorHistory& history) const;
};

}  // namespace yore
