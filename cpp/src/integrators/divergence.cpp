#include "yore/integrators/divergence.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "yore/platform/interrupt.hpp"

namespace yore {

DivergenceMonitor::DivergenceMonitor(double factor, double growth)
    : m_factor(factor), m_growth(growth) {
  if (!std::isfinite(factor) || factor <= 0.0) {
    std::ostringstream msg;
    msg << "divergence_energy_factor must be finite and > 0, got " << factor;
    throw std::invalid_argument(msg.str());
  }
  if (!std::isfinite(growth) || growth < 0.0) {
    std::ostringstream msg;
    msg << "energy_growth_tolerance must be finite and >= 0 (0 = off), got " << growth;
    throw std::invalid_argument(msg.str());
  }
}

DivergenceMonitor::Verdict DivergenceMonitor::judge(double energy) {
  if (energy > m_limit) return Verdict::past_bound;
  m_lowest = std::min(m_lowest, energy);
  const double gain = energy - m_lowest;
  m_largest_gain = std::max(m_largest_gain, gain);
  return gain > m_allowance ? Verdict::gained : Verdict::ok;
}

double DivergenceMonitor::monitored_energy(const Cloth& cloth, const Vec3& gravity) {
  const EnergyTerms all = cloth.energy(gravity);
  double constrained = 0.0;  // kinetic and gravitational energy of fixed and driven vertices
  for (Eigen::Index i = 0; i < cloth.vertex_count(); ++i) {
    if (cloth.inverse_masses()[i] != 0.0) continue;
    const double m = cloth.masses()[i];
    constrained += 0.5 * m * cloth.velocities().row(i).squaredNorm() -
                   m * cloth.positions().row(i).dot(gravity);
  }
  return all.total() - constrained;
}

void DivergenceMonitor::prepare(const Cloth& cloth, const Vec3& gravity, double dt) {
  if (cloth.topology_version() == m_topology && cloth.edit_count() == m_edits &&
      gravity == m_gravity && dt == m_dt) {
    return;
  }
  const EnergyTerms energy = cloth.energy(gravity);
  const double diagonal =
      (cloth.positions().colwise().maxCoeff() - cloth.positions().colwise().minCoeff()).norm();
  const double total_mass = cloth.masses().sum();
  double omega_max = 0.0;
  for (const RotationDriver& driver : cloth.drivers()) {
    omega_max = std::max(omega_max, std::abs(driver.omega));
  }
  double rest_energy = 0.0;
  const SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    rest_energy += 0.5 * springs.stiffness[k] * springs.rest_length[k] * springs.rest_length[k];
  }
  // Quadratic bending's analogue of a spring compressed to nothing: every hinge folded flat.
  if (cloth.has_quadratic_bending()) {
    rest_energy += cloth.bending_modulus() * cloth.quadratic_bending().fold_energy;
  }
  // The membrane's: Y × its rest area, the order of its energy stretched to twice its size
  // (uniaxially, A Y (s² − 1)²/8 = 1.1 A Y at s = 2).
  if (cloth.has_membrane()) {
    rest_energy += cloth.membrane().young_modulus * cloth.membrane_status().rest_area;
  }
  const double elastic = energy.spring + energy.bending + energy.membrane;
  const double lifting = total_mass * gravity.norm() * diagonal;
  const double driving = total_mass * (omega_max * diagonal) * (omega_max * diagonal);
  const double scale = energy.kinetic + elastic + lifting + 0.5 * driving + rest_energy;
  const double baseline = monitored_energy(cloth, gravity);
  m_limit = baseline + m_factor * scale;
  m_lowest = baseline;
  // A round-off floor: a cloth at rest without gravity has no energy to scale by, and its
  // energy still moves in the last digits of the terms it sums.
  const double round_off = 1e-12 * (std::abs(baseline) + scale);
  // A turning driver does work the monitor cannot bound without its reaction forces (a
  // twisted tube stores elastic energy without limit): the growth check is off while one turns.
  m_allowance =
      m_growth > 0.0 && omega_max == 0.0
          ? m_growth * (std::max(energy.kinetic, 0.0) + std::max(elastic, 0.0) + lifting) +
                round_off
          : std::numeric_limits<double>::infinity();
  m_topology = cloth.topology_version();
  m_edits = cloth.edit_count();
  m_gravity = gravity;
  m_dt = dt;
}

void check_advance_arguments(double dt, const Vec3& gravity, std::int64_t steps) {
  if (!std::isfinite(dt) || dt <= 0.0) {
    std::ostringstream msg;
    msg << "dt must be finite and > 0, got " << dt;
    throw std::invalid_argument(msg.str());
  }
  if (!gravity.allFinite()) throw std::invalid_argument("gravity must be finite");
  if (steps < 0) {
    std::ostringstream msg;
    msg << "the number of steps must be >= 0, got " << steps;
    throw std::invalid_argument(msg.str());
  }
}

void advance_checked(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps,
                     DivergenceMonitor& monitor, IntegratorIdentity integrator,
                     Positions& checkpoint_positions, Positions& checkpoint_velocities,
                     const std::function<void()>& step,
                     const std::function<std::int64_t()>& step_index,
                     const std::function<void()>& on_restore) {
  check_advance_arguments(dt, gravity, steps);
  if (steps == 0) return;
  monitor.prepare(cloth, gravity, dt);
  checkpoint_positions = cloth.positions();  // same size call to call: no reallocation
  checkpoint_velocities = cloth.velocities();
  const SimulationClock checkpoint_clock = cloth.clock();
  const double lowest_at_start = monitor.lowest();
  auto restore = [&] {
    cloth.integrator_positions() = checkpoint_positions;
    cloth.integrator_velocities() = checkpoint_velocities;
    cloth.set_clock(checkpoint_clock);
    monitor.restore_lowest(lowest_at_start);
    if (on_restore) on_restore();
  };
  for (std::int64_t k = 0; k < steps; ++k) {
    try {
      poll_interrupt();  // a long multi-step call answers Ctrl-C between steps
      step();
    } catch (...) {
      restore();
      throw;
    }
    const double energy = DivergenceMonitor::monitored_energy(cloth, gravity);
    const bool finite = std::isfinite(energy) && cloth.positions().allFinite();
    const DivergenceMonitor::Verdict verdict =
        finite ? monitor.judge(energy) : DivergenceMonitor::Verdict::past_bound;
    if (verdict != DivergenceMonitor::Verdict::ok) {
      const double failed_time = cloth.time();
      restore();
      if (verdict == DivergenceMonitor::Verdict::gained) {
        throw energy_gain_error(cloth, monitor, energy, integrator, step_index(), failed_time, dt);
      }
      throw diverged_error(cloth, integrator, step_index(), failed_time, dt, finite);
    }
  }
}

SimulationDiverged diverged_error(const Cloth& cloth, IntegratorIdentity integrator,
                                  std::int64_t step, double time, double dt, bool finite) {
  const double stable = cloth.stable_time_step();
  std::ostringstream msg;
  msg << "simulation diverged at step " << step << " (t = " << time << " s, dt = " << dt << " s, "
      << integrator.name << " integrator): "
      << (finite ? "the energy grew past its bound" : "positions or velocities became non-finite")
      << ". The estimated stable time step of the explicit integrator is " << stable << " s; ";
  if (!(stable > 0.0) || !std::isfinite(stable)) {
    msg << (stable > 0.0 ? "nothing elastic limits the step: check the forces and drivers."
                         : "no step is stable: check for tiny masses or huge stiffnesses.");
  } else if (integrator.remedy == Remedy::stable_step) {
    // The state-independent bound, as the default explicit dt: the tight estimate above holds at
    // the state the run restored to, and stretching can lower the limit below it.
    msg << "use dt <= " << 0.98 * cloth.stable_time_step_bound() << " s or an implicit integrator.";
  } else {
    msg << "an implicit step this far off points to a failed Newton solve: try dt <= " << dt / 4
        << " s, or more Newton iterations (max_newton).";
  }
  return SimulationDiverged(msg.str(), step, time, dt, stable);
}

SimulationDiverged energy_gain_error(const Cloth& cloth, const DivergenceMonitor& monitor,
                                     double energy, IntegratorIdentity integrator,
                                     std::int64_t step, double time, double dt) {
  std::ostringstream msg;
  msg << "simulation gained energy at step " << step << " (t = " << time << " s, dt = " << dt
      << " s, " << integrator.name << " integrator): its energy rose " << energy - monitor.lowest()
      << " J above the lowest it had reached (" << monitor.lowest()
      << " J), more than energy_growth_tolerance = " << monitor.growth()
      << " of its energy scale allows (" << monitor.allowance()
      << " J); damping, drag and gravity cannot feed energy in. ";
  switch (integrator.remedy) {
    case Remedy::stable_step:
      msg << "Use dt <= " << 0.98 * cloth.stable_time_step_bound()
          << " s or an implicit integrator.";
      break;
    case Remedy::tolerance:
      msg << "Tighten rtol and atol, or set max_dt.";
      break;
    case Remedy::quasi_newton:
      msg << "Lower newton_tol, or try dt <= " << dt / 4 << " s.";
      break;
    case Remedy::local_global:
      msg << "Lower its tolerance or dt (try dt <= " << dt / 4 << " s).";
      break;
    case Remedy::newton:
      msg << "The step gained energy even when redone to Newton's residual test (its early "
             "stops off), so the step is too long or that test too loose: try dt <= "
          << dt / 4 << " s, or lower newton_tol.";
      break;
  }
  return SimulationDiverged(msg.str(), step, time, dt, cloth.stable_time_step());
}

}  // namespace yore
