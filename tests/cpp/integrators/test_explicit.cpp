// Tests of cpp/src/integrators/explicit.cpp (cpp/include/yore/integrators/explicit.hpp): symplectic
// Euler against a step computed by hand and an analytic oscillator, conservation laws, constraints,
// Provot strain limiting, divergence handling, option checks and the step's thread chooser.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/integrators/divergence.hpp"
#include "yore/integrators/explicit.hpp"
#include "yore/platform/errors.hpp"

using yore::Cloth;
using yore::ExplicitIntegrator;
using yore::ExplicitOptions;
using yore::Positions;
using yore::Vec3;

namespace {

// A small free network: a triangle of unequal springs, out of its rest state, moving.
Cloth triangle_network(double damping, double drag) {
  Positions x(3, 3);
  x << 0, 0, 0, 1.1, 0.1, 0, 0.2, 0.9, 0.3;
  yore::Edges edges(3, 2);
  edges << 0, 1, 1, 2, 2, 0;
  Cloth cloth = Cloth::from_springs(x, edges, Eigen::Vector3d(1.0, 0.8, 0.9),
                                    Eigen::Vector3d(0.1, 0.2, 0.15), 30.0, damping, drag);
  Positions v(3, 3);
  v << 0.1, 0, 0, 0, -0.2, 0.1, 0.3, 0.1, 0;
  cloth.set_velocities(v);
  return cloth;
}

Vec3 momentum(const Cloth& cloth) {
  Vec3 p = Vec3::Zero();
  for (Eigen::Index i = 0; i < cloth.vertex_count(); ++i)
    p += cloth.masses()[i] * cloth.velocities().row(i).transpose();
  return p;
}

}  // namespace

TEST_CASE("one step is v⁺ = v + h M⁻¹ f(x, v), x⁺ = x + h v⁺ with springs, damping, drag, g") {
  Cloth cloth = triangle_network(0.05, 0.3);
  const Positions x = cloth.positions(), v = cloth.velocities();
  const Vec3 g(0, -9.81, 0);
  const double h = 1e-3;
  Positions force = Positions::Zero(3, 3);
  const auto& s = cloth.springs();
  for (std::size_t k = 0; k < s.size(); ++k) {
    const Vec3 xi = x.row(s.first[k]), xj = x.row(s.second[k]);
    const Vec3 f =
        -yore::spring_gradient(xi, xj, s.rest_length[k], s.stiffness[k]) +
        yore::spring_damping_force(xi, xj, v.row(s.first[k]), v.row(s.second[k]), s.damping[k]);
    force.row(s.first[k]) += f.transpose();
    force.row(s.second[k]) -= f.transpose();
  }
  Positions expected_v(3, 3), expected_x(3, 3);
  for (int i = 0; i < 3; ++i) {
    const double m = cloth.masses()[i];
    const Eigen::RowVector3d f = force.row(i) + m * g.transpose() - 0.3 * m * v.row(i);
    expected_v.row(i) = v.row(i) + h * f / m;
    expected_x.row(i) = x.row(i) + h * expected_v.row(i);
  }
  ExplicitIntegrator integrator;
  integrator.advance(cloth, g, h, 1);
  // the same arithmetic in another order: round-off of O(1) numbers, 1e-14
  CHECK((cloth.velocities() - expected_v).cwiseAbs().maxCoeff() < 1e-14);
  CHECK((cloth.positions() - expected_x).cwiseAbs().maxCoeff() < 1e-14);
  CHECK(cloth.time() == h);
  CHECK(integrator.statistics().steps == 1);
}

TEST_CASE("a mass on a spring returns after one period (analytic oscillator)") {
  const double m = 0.2, k = 50.0, amplitude = 0.1;
  Cloth cloth = yore_test::oscillator(m, k, amplitude);
  const double omega = std::sqrt(k / m), period = 2 * M_PI / omega, dt = period / 2000;
  ExplicitIntegrator integrator;
  integrator.advance(cloth, Vec3::Zero(), dt, 2000);
  const double displacement = -cloth.positions()(1, 1) - 1.0;
  // one period later the mass is back near its start: symplectic Euler's error ≈ a·ω·dt/2
  CHECK(std::abs(displacement - amplitude) < amplitude * omega * dt);
  // and the fixed end never moved
  CHECK(cloth.positions().row(0).isZero(0.0));
}

TEST_CASE("without gravity, drag or constraints the momentum is conserved and energy bounded") {
  Cloth cloth = triangle_network(0.0, 0.0);
  const Vec3 p0 = momentum(cloth);
  const double e0 = cloth.energy(Vec3::Zero()).total();
  ExplicitIntegrator integrator;
  const double dt = 0.02 * cloth.stable_time_step();
  double largest_drift = 0.0;
  for (int block = 0; block < 20; ++block) {
    integrator.advance(cloth, Vec3::Zero(), dt, 50);
    largest_drift = std::max(largest_drift, std::abs(cloth.energy(Vec3::Zero()).total() - e0));
  }
  // spring forces come in ± pairs: momentum changes by round-off only
  CHECK((momentum(cloth) - p0).norm() < 1e-13);
  // symplectic: the energy oscillates by O(h ω) of itself (h ω ≈ 0.04 here) and does not
  // drift away over the 1000 steps
  CHECK(largest_drift < 0.05 * e0);
  CAPTURE(largest_drift / e0);
  // with damping the energy only falls
  Cloth damped = triangle_network(0.5, 0.0);
  ExplicitIntegrator second;
  second.advance(damped, Vec3::Zero(), dt, 1000);
  CHECK(damped.energy(Vec3::Zero()).total() < 0.5 * e0);
}

TEST_CASE("fixed vertices never move, driven ones follow their driver exactly") {
  Cloth cloth = yore_test::grid_cloth(4, 200.0, 20.0, 0.01, 0.1);
  cloth.fix({0, 3});
  cloth.drive_rotation({12, 15}, Vec3(0.5, 1.0, 0.0), Vec3(0, 1, 0), 2.0);
  const Positions start = cloth.positions();
  ExplicitIntegrator integrator;
  integrator.advance(cloth, Vec3(0, 0, -9.81), 1e-3, 100);
  CHECK(cloth.positions().row(0) == start.row(0));
  CHECK(cloth.positions().row(3) == start.row(3));
  Positions x = cloth.positions(), v = cloth.velocities();
  cloth.driver_state(cloth.time(), x, v);
  CHECK(cloth.positions().row(12) == x.row(12));
  CHECK(cloth.velocities().row(15) == v.row(15));
  CHECK(cloth.positions().row(5) != start.row(5));  // the free ones fall
}

TEST_CASE("strain limiting keeps structural springs at most strain_limit × rest") {
  // a chain hung from a fixed vertex under a large load: without the limit it stretches far
  const int n = 6;
  Positions x(n, 3);
  yore::Edges edges(n - 1, 2);
  for (int i = 0; i < n; ++i) x.row(i) << 0, -0.1 * i, 0;
  for (int i = 0; i + 1 < n; ++i) edges.row(i) << i, i + 1;
  const auto make = [&] {
    Cloth chain =
        Cloth::from_springs(x, edges, {}, Eigen::VectorXd::Constant(n, 0.01), 20.0, 0.05, 0.5);
    chain.fix({0});
    return chain;
  };
  const auto largest_strain = [](const Cloth& cloth) {
    double largest = 0.0;
    const auto& s = cloth.springs();
    for (std::size_t k = 0; k < s.size(); ++k)
      largest = std::max(
          largest, (cloth.positions().row(s.first[k]) - cloth.positions().row(s.second[k])).norm() /
                       s.rest_length[k]);
    return largest;
  };
  Cloth free = make(), limited = make();
  ExplicitIntegrator plain;
  ExplicitOptions options;
  options.strain_limit = 1.1;
  options.strain_limit_passes = 400;
  ExplicitIntegrator limiting(options);
  const Vec3 g(0, -30.0, 0);
  plain.advance(free, g, 1e-3, 500);
  limiting.advance(limited, g, 1e-3, 500);
  CHECK(largest_strain(free) > 1.15);
  // Gauss–Seidel on a chain converges geometrically (measured: 5e-7 left after 50 passes);
  // 400 passes leave round-off
  CHECK(largest_strain(limited) <= 1.1 * (1 + 1e-12));
  CAPTURE(largest_strain(limited) - 1.1);
  CHECK(limiting.statistics().strain_corrections > 0);
  CHECK(plain.statistics().strain_corrections == 0);
}

TEST_CASE("a step too large for stability throws SimulationDiverged and restores the cloth") {
  Cloth cloth = yore_test::grid_cloth(4, 1000.0, 100.0);
  cloth.fix({0});
  Positions x = cloth.positions();
  x(5, 2) = 0.05;  // something to oscillate
  cloth.set_positions(x);
  const Positions start = cloth.positions();
  const double stable = cloth.stable_time_step();
  ExplicitIntegrator integrator;
  bool thrown = false;
  try {
    integrator.advance(cloth, Vec3::Zero(), 10 * stable, 1000);
  } catch (const yore::SimulationDiverged& error) {
    thrown = true;
    CHECK(std::string(error.what()).find("simulation diverged at step") != std::string::npos);
    CHECK(std::string(error.what()).find("explicit integrator") != std::string::npos);
    CHECK(error.dt() == 10 * stable);
    CHECK(error.stable_dt() == doctest::Approx(stable).epsilon(1e-9));
    CHECK(error.step() >= 0);
    CHECK(error.time() == doctest::Approx((error.step() + 1) * 10 * stable).epsilon(1e-12));
  }
  CHECK(thrown);
  CHECK(cloth.positions() == start);  // as at the start of the call
  CHECK(cloth.time() == 0.0);
}

TEST_CASE("no call returns a blown-up cloth: the call's last step is judged on its own state") {
  // R08: the step's elastic energy comes with its forces, at the step's start, so a blow-up on
  // a call's last step used to be returned and caught only by the next call.
  Cloth cloth = yore_test::grid_cloth(4, 1000.0, 100.0);
  cloth.fix({0});
  Positions x = cloth.positions();
  x(5, 2) = 0.05;
  cloth.set_positions(x);
  yore::DivergenceMonitor bound;  // the integrator's default factor, same baseline
  bound.prepare(cloth, Vec3::Zero(), 10 * cloth.stable_time_step());
  const double dt = 10 * cloth.stable_time_step();
  ExplicitIntegrator integrator;
  int returned = 0;
  bool thrown = false;
  for (int call = 0; call < 1000 && !thrown; ++call) {
    const Positions before = cloth.positions();
    try {
      integrator.advance(cloth, Vec3::Zero(), dt, 1);
      ++returned;
      const double energy = yore::DivergenceMonitor::monitored_energy(cloth, Vec3::Zero());
      REQUIRE(std::isfinite(energy));
      REQUIRE(energy <= bound.limit());
    } catch (const yore::SimulationDiverged&) {
      thrown = true;
      CHECK(cloth.positions() == before);  // the failing call undone
    }
  }
  CHECK(thrown);
  CHECK(returned > 0);
}

TEST_CASE("the explicit growth check is off by default and on when asked") {
  // a gathered cloth's first steps at the default dt: the true energy swings about the
  // modified energy symplectic Euler keeps (docs/integrators.md)
  const auto make = [] {
    Cloth cloth = yore_test::grid_cloth(8, 2e3, 200.0, 0.02, 0.3);
    Positions x = cloth.positions();
    x.col(0) *= 0.8;  // compressed along x
    cloth.set_positions(x);
    cloth.fix({0, 7});
    return cloth;
  };
  Cloth cloth = make();
  const double dt = 0.98 * cloth.stable_time_step_bound();
  ExplicitIntegrator quiet;
  CHECK(quiet.options().energy_growth_tolerance == 0.0);
  quiet.advance(cloth, Vec3(0, 0, -9.81), dt, 20);
  CHECK(quiet.monitor().largest_gain() > 0.0);  // measured, not judged
  CHECK(std::isinf(quiet.monitor().allowance()));
  ExplicitOptions strict;
  strict.energy_growth_tolerance = 1e-9;
  ExplicitIntegrator watching(strict);
  Cloth other = make();
  CHECK_THROWS_WITH_AS(watching.advance(other, Vec3(0, 0, -9.81), dt, 20),
                       doctest::Contains("gained energy"), yore::SimulationDiverged);
}

TEST_CASE("bad options and arguments are std::invalid_argument naming them") {
  ExplicitOptions options;
  options.strain_limit = 0.5;
  CHECK_THROWS_WITH_AS(ExplicitIntegrator{options}, doctest::Contains("strain_limit must be 0"),
                       std::invalid_argument);
  options = {};
  options.strain_limit_passes = 0;
  CHECK_THROWS_WITH_AS(ExplicitIntegrator{options},
                       doctest::Contains("strain_limit_passes must be >= 1"),
                       std::invalid_argument);
  options = {};
  options.divergence_energy_factor = -1.0;
  CHECK_THROWS_WITH_AS(ExplicitIntegrator{options}, doctest::Contains("divergence_energy_factor"),
                       std::invalid_argument);
  Cloth cloth = yore_test::grid_cloth(3);
  ExplicitIntegrator integrator;
  CHECK_THROWS_WITH_AS(integrator.advance(cloth, Vec3::Zero(), 0.0, 1),
                       doctest::Contains("dt must be finite and > 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(integrator.advance(cloth, Vec3(0, std::nan(""), 0), 1e-3, 1),
                       doctest::Contains("gravity must be finite"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(integrator.advance(cloth, Vec3::Zero(), 1e-3, -1),
                       doctest::Contains("steps must be >= 0"), std::invalid_argument);
  integrator.advance(cloth, Vec3::Zero(), 1e-3, 0);  // zero steps: nothing happens
  CHECK(cloth.time() == 0.0);
}

TEST_CASE("the thread chooser starts on one thread and keeps whichever is faster per step") {
  // The chooser is fed step times, not a clock: deterministic.
  yore::StepThreadChooser single;
  CHECK(single.threads_for_next_step(1) == 1);
  CHECK_FALSE(single.record(1.0));
  yore::StepThreadChooser chooser;
  CHECK(chooser.threads_for_next_step(4) == 1);
  // a block of serial steps (at least kBlockSeconds and kMinBlockSteps), then a re-timing
  const double serial = 1e-3, parallel = 4e-4;
  int guard = 0;
  while (chooser.threads_for_next_step(4) == 1 && ++guard < 100) chooser.record(serial);
  REQUIRE(chooser.threads_for_next_step(4) == 4);
  bool ended = false;
  for (guard = 0; !ended && guard < 100; ++guard) ended = chooser.record(parallel);
  REQUIRE(ended);
  CHECK(chooser.preferred() == 4);  // the parallel steps won
  CHECK(chooser.threads_for_next_step(4) == 4);
  // later the loser is re-timed; a re-timing already 2× slower ends after one step
  for (guard = 0; chooser.threads_for_next_step(4) == 4 && guard < 1000; ++guard)
    chooser.record(parallel);
  REQUIRE(chooser.threads_for_next_step(4) == 1);
  CHECK(chooser.record(100 * parallel));
  CHECK(chooser.preferred() == 4);
  CHECK(chooser.threads_for_next_step(4) == 4);
  // a new configuration starts over on one thread
  CHECK(chooser.threads_for_next_step(2) == 1);
}
