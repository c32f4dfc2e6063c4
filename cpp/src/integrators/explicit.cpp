#include "yore/integrators/explicit.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "yore/platform/build_info.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {
namespace {

// Below these sizes a loop runs on one thread even when more are configured: forking and
// joining would cost more than the loop. Break-even measured per loop on the 2-core machine of
// docs/results.md (phase times of stats, every loop forced parallel, 1 against 2 threads, idle):
// spring forces pay from about 1000 springs (16²: 3.2 µs against 5.1 µs), the fused
// gather + update from about 500 vertices (16²: 2.9 against 2.5 µs, 24²: 3.6 against 5.3 µs),
// the energy check from about 1000 (24²: 1.06 against 1.22 µs, 16²: 0.84 against 0.72 µs).
constexpr std::int64_t kParallelSprings = 1000;
constexpr std::int64_t kParallelVertices = 500;
constexpr std::int64_t kParallelCheckVertices = 1000;

// Dynamic schedule in chunks of about an eighth of a thread's share: a thread that starts late
// (woken, or descheduled by another process) leaves its chunks to the others instead of
// holding up the loop's end by a whole static share.
std::int64_t chunk_size(std::int64_t count, int threads) {
  return std::max<std::int64_t>(256, count / (8 * static_cast<std::int64_t>(threads)));
}

/// Force on each spring's first end (elastic, plus damping when Damped) into `out` (s×3);
/// returns the total spring energy at the current positions.
template <bool Damped>
double spring_forces(const Cloth& cloth, Positions& out, int threads) {
  const SpringSet& springs = cloth.springs();
  const double* x = cloth.positions().data();
  const double* v = cloth.velocities().data();
  const std::int32_t* first = springs.first.data();
  const std::int32_t* second = springs.second.data();
  const double* rest = springs.rest_length.data();
  const double* stiffness = springs.stiffness.data();
  const double* damping = springs.damping.data();
  double* f = out.data();
  const auto count = static_cast<std::int64_t>(springs.size());
  double energy = 0.0;
  const std::int64_t chunk = chunk_size(count, threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, chunk) reduction(+ : energy) \
    if (threads > 1 && count >= kParallelSprings)
  for (std::int64_t s = 0; s < count; ++s) {
    const double* xi = x + 3 * first[s];
    const double* xj = x + 3 * second[s];
    const double dx = xi[0] - xj[0], dy = xi[1] - xj[1], dz = xi[2] - xj[2];
    const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double stretch = length - rest[s];
    energy += 0.5 * stiffness[s] * stretch * stretch;
    double* fs = f + 3 * s;
    if (length == 0.0) {  // direction undefined: no force (see spring_gradient)
      fs[0] = fs[1] = fs[2] = 0.0;
      continue;
    }
    const double inverse_length = 1.0 / length;
    double scale = -stiffness[s] * stretch * inverse_length;
    if constexpr (Damped) {
      const double* vi = v + 3 * first[s];
      const double* vj = v + 3 * second[s];
      const double closing =
          ((vi[0] - vj[0]) * dx + (vi[1] - vj[1]) * dy + (vi[2] - vj[2]) * dz) * inverse_length;
      scale -= damping[s] * closing * inverse_length;
    }
    fs[0] = scale * dx;
    fs[1] = scale * dy;
    fs[2] = scale * dz;
  }
  return energy;
}

}  // namespace

ExplicitIntegrator::ExplicitIntegrator(const ExplicitOptions& options)
    : m_options(options),
      m_monitor(options.divergence_energy_factor, options.energy_growth_tolerance) {
  if (!std::isfinite(options.strain_limit) || options.strain_limit < 0.0 ||
      (options.strain_limit > 0.0 && options.strain_limit < 1.0)) {
    std::ostringstream msg;
    msg << "strain_limit must be 0 (off) or a ratio >= 1 (e.g. 1.1), got " << options.strain_limit;
    throw std::invalid_argument(msg.str());
  }
  if (options.strain_limit_passes < 1) {
    std::ostringstream msg;
    msg << "strain_limit_passes must be >= 1, got " << options.strain_limit_passes;
    throw std::invalid_argument(msg.str());
  }
}

void ExplicitIntegrator::prepare(const Cloth& cloth) {
  const Eigen::Index n = cloth.vertex_count();
  const auto s = static_cast<Eigen::Index>(cloth.springs().size());
  if (m_spring_forces.rows() != s) m_spring_forces.resize(s, 3);
  if (m_options.strain_limit > 0.0 && m_previous_positions.rows() != n) {
    m_previous_positions.setZero(n, 3);
  }
  m_with_spring_damping = cloth.has_spring_damping();
  m_with_potentials = cloth.has_quadratic_bending() || cloth.has_membrane();
  if (m_with_potentials && m_potential_gradient.rows() != n) m_potential_gradient.resize(n, 3);
}

double ExplicitIntegrator::compute_spring_forces(const Cloth& cloth, int threads) {
  return m_with_spring_damping ? spring_forces<true>(cloth, m_spring_forces, threads)
                               : spring_forces<false>(cloth, m_spring_forces, threads);
}

void ExplicitIntegrator::update_velocities_and_positions(Cloth& cloth, const Vec3& gravity,
                                                         double dt, int threads) {
  const Eigen::Index n = cloth.vertex_count();
  double* x = cloth.integrator_positions().data();
  double* v = cloth.integrator_velocities().data();
  double* previous = m_options.strain_limit > 0.0 ? m_previous_positions.data() : nullptr;
  const double* m = cloth.masses().data();
  const double* inverse_mass = cloth.inverse_masses().data();
  const std::int32_t* offsets = cloth.incidence_offsets().data();
  const std::int32_t* incident = cloth.incident_springs().data();
  const double* signs = cloth.incident_signs().data();
  const double* fs = m_spring_forces.data();
  const double* bending = m_with_potentials ? m_potential_gradient.data() : nullptr;
  const double drag = cloth.drag();
  const double gx = gravity.x(), gy = gravity.y(), gz = gravity.z();
  const std::int64_t chunk = chunk_size(n, threads);
  // Gather per vertex instead of scattering per spring: no write conflicts between threads.
  // Vertex i's force needs only the spring forces and its own velocity, so the update fuses
  // with the gather: one parallel loop instead of two, and no n×3 force buffer.
#pragma omp parallel for num_threads(threads) \
    schedule(dynamic, chunk) if (threads > 1 && n >= kParallelVertices)
  for (Eigen::Index i = 0; i < n; ++i) {
    double* xi = x + 3 * i;
    double* vi = v + 3 * i;
    if (previous != nullptr) {
      for (int c = 0; c < 3; ++c) previous[3 * i + c] = xi[c];
    }
    if (inverse_mass[i] == 0.0) continue;
    double fx = m[i] * gx, fy = m[i] * gy, fz = m[i] * gz;
    if (drag > 0.0) {
      fx -= drag * m[i] * vi[0];
      fy -= drag * m[i] * vi[1];
      fz -= drag * m[i] * vi[2];
    }
    for (std::int32_t slot = offsets[i]; slot < offsets[i + 1]; ++slot) {
      const double* fk = fs + 3 * incident[slot];
      fx += signs[slot] * fk[0];
      fy += signs[slot] * fk[1];
      fz += signs[slot] * fk[2];
    }
    if (bending != nullptr) {  // quadratic bending: −κ (Q x)ᵢ
      fx -= bending[3 * i];
      fy -= bending[3 * i + 1];
      fz -= bending[3 * i + 2];
    }
    const double f[3] = {fx, fy, fz};
    for (int c = 0; c < 3; ++c) {
      vi[c] += dt * inverse_mass[i] * f[c];
      xi[c] += dt * vi[c];
    }
  }
}

void ExplicitIntegrator::limit_strain(Cloth& cloth) {
  // Provot 1995: pull over-stretched structural springs back to the limit, splitting the
  // correction by inverse mass (momentum-preserving between two free vertices; a fixed or driven
  // end does not move). Gauss–Seidel, so sequential.
  const SpringSet& springs = cloth.springs();
  double* x = cloth.integrator_positions().data();
  const double* inverse_mass = cloth.inverse_masses().data();
  const double limit = m_options.strain_limit;
  std::int64_t corrections = 0;
  for (int pass = 0; pass < m_options.strain_limit_passes; ++pass) {
    std::int64_t pass_corrections = 0;
    for (std::size_t s = 0; s < springs.size(); ++s) {
      if (springs.kind[s] != SpringKind::structural) continue;
      const std::int32_t i = springs.first[s], j = springs.second[s];
      const double wi = inverse_mass[i], wj = inverse_mass[j];
      if (wi + wj == 0.0) continue;
      double* xi = x + 3 * i;
      double* xj = x + 3 * j;
      const double dx = xi[0] - xj[0], dy = xi[1] - xj[1], dz = xi[2] - xj[2];
      const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
      const double longest = limit * springs.rest_length[s];
      if (length <= longest) continue;
      const double scale = (length - longest) / (length * (wi + wj));
      xi[0] -= wi * scale * dx;
      xi[1] -= wi * scale * dy;
      xi[2] -= wi * scale * dz;
      xj[0] += wj * scale * dx;
      xj[1] += wj * scale * dy;
      xj[2] += wj * scale * dz;
      ++pass_corrections;
    }
    corrections += pass_corrections;
    if (pass_corrections == 0) break;
  }
  m_statistics.strain_corrections += corrections;
}

void ExplicitIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt, std::int64_t steps) {
  check_advance_arguments(dt, gravity, steps);
  if (steps == 0) return;

  Stopwatch start;
  prepare(cloth);
  m_monitor.prepare(cloth, gravity, dt);
  const Eigen::Index n = cloth.vertex_count();
  m_checkpoint_positions = cloth.positions();  // same size every call: no reallocation
  m_checkpoint_velocities = cloth.velocities();
  const SimulationClock checkpoint_clock = cloth.clock();
  m_lowest_at_start = m_monitor.lowest();
  m_statistics.checks_seconds += start.seconds();

  const auto spring_count = static_cast<std::int64_t>(cloth.springs().size());
  // Small cloths never fork: nothing to choose, nothing to re-time.
  const bool parallel_pays =
      spring_count >= kParallelSprings || n >= kParallelVertices || n >= kParallelCheckVertices;
  const int configured = parallel_pays ? max_threads() : 1;
  for (std::int64_t step = 0; step < steps; ++step) {
    poll_interrupt_or_undo(cloth, checkpoint_clock);
    const Stopwatch step_start;
    const int threads = m_thread_chooser.threads_for_next_step(configured);
    start = step_start;
    const double energy_before = forces_and_energy(cloth, threads);
    m_statistics.forces_seconds += start.seconds();

    start.restart();
    update_velocities_and_positions(cloth, gravity, dt, threads);
    const double new_time = cloth.advance_time(dt);
    cloth.apply_drivers(new_time);
    m_statistics.update_seconds += start.seconds();

    if (m_options.strain_limit > 0.0) {
      start.restart();
      limit_strain(cloth);
      strain_limited_velocities(cloth, dt);
      m_statistics.constraints_seconds += start.seconds();
    }

    start.restart();
    double position_sum = 0.0;
    const double monitored =
        energy_before + kinetic_and_gravity(cloth, gravity, threads, position_sum);
    const bool finite = std::isfinite(monitored) && std::isfinite(position_sum);
    // The elastic energy above is the step's start's (the forces' by-product): a blow-up shows
    // one step late, so the call's last step is judged again on its own state below.
    judge_or_restore(cloth, finite, monitored, m_statistics.steps, new_time, dt, checkpoint_clock);
    if (step + 1 == steps) {
      const double exact = DivergenceMonitor::monitored_energy(cloth, gravity);
      judge_or_restore(cloth, std::isfinite(exact), exact, m_statistics.steps, new_time, dt,
                       checkpoint_clock);
    }
    ++m_statistics.steps;
    m_statistics.checks_seconds += start.seconds();
    if (m_thread_chooser.record(step_start.seconds())) ++m_statistics.thread_probes;
    m_statistics.last_step_threads = threads;
    if (threads > 1) ++m_statistics.parallel_steps;
  }
}

void ExplicitIntegrator::poll_interrupt_or_undo(Cloth& cloth, const SimulationClock& clock) {
  // A long multi-step call answers Ctrl-C between steps, and undoes the call, as on divergence.
  try {
    poll_interrupt();
  } catch (...) {
    cloth.integrator_positions() = m_checkpoint_positions;
    cloth.integrator_velocities() = m_checkpoint_velocities;
    cloth.set_clock(clock);
    throw;
  }
}

double ExplicitIntegrator::forces_and_energy(Cloth& cloth, int threads) {
  // The springs' forces, and the potentials' gradient when the cloth has any; returns their
  // energy at the step's start (the forces' by-product), which the divergence check monitors.
  double energy = compute_spring_forces(cloth, threads);
  if (!m_with_potentials) return energy;
  if (cloth.has_quadratic_bending()) {  // a sparse product with the constant Q
    energy += quadratic_bending_gradient(cloth.quadratic_bending(), cloth.bending_modulus(),
                                         cloth.positions(), m_potential_gradient);
  } else {
    m_potential_gradient.setZero();
  }
  if (cloth.has_membrane()) {
    energy += membrane_add_gradient(cloth.membrane_elements(), cloth.membrane(), cloth.positions(),
                                    m_potential_gradient, m_membrane_work);
  }
  return energy;
}

void ExplicitIntegrator::strain_limited_velocities(Cloth& cloth, double dt) {
  // After the strain limit moved positions: each free vertex's velocity is its displacement
  // over the step (the limit's corrections included).
  const double* x = cloth.integrator_positions().data();
  double* v = cloth.integrator_velocities().data();
  const double* inverse_mass = cloth.inverse_masses().data();
  const double* previous = m_previous_positions.data();
  for (Eigen::Index i = 0; i < cloth.vertex_count(); ++i) {
    if (inverse_mass[i] == 0.0) continue;
    for (int c = 0; c < 3; ++c) v[3 * i + c] = (x[3 * i + c] - previous[3 * i + c]) / dt;
  }
}

double ExplicitIntegrator::kinetic_and_gravity(const Cloth& cloth, const Vec3& gravity, int threads,
                                               double& position_sum) const {
  // Kinetic minus gravity's work over the free vertices, and the sum of every coordinate (a
  // non-finite position shows in it), reduced over the threads.
  const Eigen::Index n = cloth.vertex_count();
  const double* x = cloth.positions().data();
  const double* v = cloth.velocities().data();
  const double* m = cloth.masses().data();
  const double* inverse_mass = cloth.inverse_masses().data();
  const double gx = gravity.x(), gy = gravity.y(), gz = gravity.z();
  double monitored = 0.0, sum = 0.0;
  const std::int64_t chunk = chunk_size(n, threads);
#pragma omp parallel for num_threads(threads) schedule(dynamic, chunk) \
    reduction(+ : monitored, sum) if (threads > 1 && n >= kParallelCheckVertices)
  for (Eigen::Index i = 0; i < n; ++i) {
    sum += x[3 * i] + x[3 * i + 1] + x[3 * i + 2];
    if (inverse_mass[i] == 0.0) continue;
    const double speed_squared =
        v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2];
    monitored +=
        0.5 * m[i] * speed_squared - m[i] * (x[3 * i] * gx + x[3 * i + 1] * gy + x[3 * i + 2] * gz);
  }
  position_sum = sum;
  return monitored;
}

void ExplicitIntegrator::judge_or_restore(Cloth& cloth, bool finite, double energy,
                                          std::int64_t step, double time, double dt,
                                          const SimulationClock& checkpoint_clock) {
  const DivergenceMonitor::Verdict verdict =
      finite ? m_monitor.judge(energy) : DivergenceMonitor::Verdict::past_bound;
  if (verdict == DivergenceMonitor::Verdict::ok) return;
  m_monitor.restore_lowest(m_lowest_at_start);
  cloth.integrator_positions() = m_checkpoint_positions;
  cloth.integrator_velocities() = m_checkpoint_velocities;
  cloth.set_clock(checkpoint_clock);
  if (verdict == DivergenceMonitor::Verdict::gained) {
    throw energy_gain_error(cloth, m_monitor, energy,
                            {integrator_name::kExplicit, Remedy::stable_step}, step, time, dt);
  }
  throw diverged_error(cloth, {integrator_name::kExplicit, Remedy::stable_step}, step, time, dt,
                       finite);
}

int StepThreadChooser::threads_for_next_step(int configured) {
  if (configured != m_configured) {  // first step, or set_max_threads since: start over
    m_configured = configured;
    // One thread first: on a busy machine a first parallel step can stall for a whole time
    // slice, and on an idle one the parallel re-timing comes after one block anyway.
    m_preferred = m_running = 1;
    m_block_steps = 0;
    m_block_seconds = 0.0;
    m_preferred_seconds_per_step = 0.0;
    m_wait_seconds = 0.0;
    m_seconds_until_probe = 0.0;
  }
  return m_running;
}

bool StepThreadChooser::record(double seconds) {
  if (m_configured <= 1) return false;
  m_block_seconds += seconds;
  ++m_block_steps;
  const bool probing = m_running != m_preferred;
  // A re-timing that is already losing by 2× ends at once: on a busy machine one parallel step
  // can cost as much as hundreds of serial ones.
  const bool lost_already =
      probing && m_block_seconds > 2.0 * m_preferred_seconds_per_step * m_block_steps;
  if (!lost_already && (m_block_steps < kMinBlockSteps || m_block_seconds < kBlockSeconds)) {
    return false;
  }
  const double seconds_per_step = m_block_seconds / m_block_steps;
  const double block_seconds = m_block_seconds;
  const int block_steps = m_block_steps;
  m_block_steps = 0;
  m_block_seconds = 0.0;
  if (probing) {
    if (seconds_per_step < m_preferred_seconds_per_step) {
      m_preferred = m_running;  // it won: keep it, and re-time the loser soon
      m_preferred_seconds_per_step = seconds_per_step;
      m_wait_seconds = kBlockSeconds;
    } else {
      // The first re-timing of all threads also starts the thread pool: it is tried again
      // soon rather than judged by that one-time cost.
      const bool first = m_wait_seconds == 0.0;
      const double lost = block_seconds - m_preferred_seconds_per_step * block_steps;
      m_wait_seconds =
          first ? kBlockSeconds
                : std::min(std::max({2.0 * m_wait_seconds, kOverheadFactor * lost, kBlockSeconds}),
                           kMaxWaitSeconds);
    }
    m_running = m_preferred;
    m_seconds_until_probe = m_wait_seconds;
    return true;
  }
  m_preferred_seconds_per_step = seconds_per_step;
  m_seconds_until_probe -= block_seconds;
  if (m_seconds_until_probe <= 0.0) m_running = m_preferred == 1 ? m_configured : 1;
  return false;
}

}  // namespace yore
