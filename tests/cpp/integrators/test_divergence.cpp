// Tests of cpp/src/integrators/divergence.cpp (cpp/include/yore/integrators/divergence.hpp): the
// monitored energy, its bound, the argument checks shared by every integrator, and
// advance_checked's restore.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/integrators/divergence.hpp"

using yore::Cloth;
using yore::DivergenceMonitor;
using yore::Positions;
using yore::Vec3;

TEST_CASE(
    "the monitored energy leaves out the kinetic and potential energy of constrained vertices") {
  Cloth cloth = yore_test::grid_cloth(3, 100.0, 0.0);
  Positions v = Positions::Zero(9, 3);
  v.row(0) << 1, 0, 0;
  v.row(4) << 0, 2, 0;
  cloth.set_velocities(v);
  const Vec3 g(0, 0, -9.81);
  CHECK(DivergenceMonitor::monitored_energy(cloth, g) ==
        doctest::Approx(cloth.energy(g).total()).epsilon(1e-15));
  Positions x = cloth.positions();
  x(0, 2) = 0.3;
  cloth.set_positions(x);
  cloth.fix({0});  // zeroes its velocity; its height no longer counts
  const double m = 0.1 / 9;
  const double expected = cloth.energy(g).total() - m * 9.81 * 0.3;
  CHECK(DivergenceMonitor::monitored_energy(cloth, g) == doctest::Approx(expected).epsilon(1e-14));
}

namespace {

// Two 1 kg masses on one spring along x at its rest length, 1 m (k = 8 N/m, no damping or drag).
Cloth one_spring() {
  Positions x(2, 3);
  x << 0, 0, 0, 1, 0, 0;
  yore::Edges e(1, 2);
  e << 0, 1;
  return Cloth::from_springs(x, e, {}, Eigen::Vector2d(1.0, 1.0), 8.0, 0.0, 0.0);
}

}  // namespace

TEST_CASE("the bound: baseline plus factor × the documented energy scale") {
  // one free mass on one spring at rest, no gravity, no drivers: E_scale = ½ k L²
  Cloth spring = one_spring();
  DivergenceMonitor monitor(3.0);
  monitor.prepare(spring, Vec3::Zero(), 1e-3);
  CHECK(monitor.limit() == doctest::Approx(3.0 * 0.5 * 8.0).epsilon(1e-15));
  // gravity adds M|g|D (D the bounding-box diagonal, 1 m here); zero height at the origin
  monitor.prepare(spring, Vec3(0, -2.0, 0), 1e-3);
  CHECK(monitor.limit() == doctest::Approx(3.0 * (4.0 + 2.0 * 2.0 * 1.0)).epsilon(1e-15));
  CHECK_THROWS_WITH_AS(DivergenceMonitor(0.0), doctest::Contains("divergence_energy_factor"),
                       std::invalid_argument);
  CHECK_THROWS_AS(DivergenceMonitor(std::nan("")), std::invalid_argument);
}

TEST_CASE("the growth check: a rise above the lowest energy by more than the allowance") {
  // one free mass on a spring stretched by 0.5 m (k = 8: 1 J), no gravity, no drivers:
  // allowance = growth × (kinetic + elastic) = 0.25 × 1 J
  Cloth spring = one_spring();
  Positions x = spring.positions();
  spring.fix({0});
  x(1, 0) = 1.5;
  spring.set_positions(x);
  DivergenceMonitor monitor(10.0, 0.25);
  monitor.prepare(spring, Vec3::Zero(), 1e-3);
  // plus the round-off floor, 1e-12 × (|1 J| + E_scale = 1 J + ½ k L² = 4 J)
  CHECK(monitor.allowance() == doctest::Approx(0.25 + 6e-12).epsilon(1e-12));
  CHECK(monitor.lowest() == doctest::Approx(1.0).epsilon(1e-15));
  CHECK(monitor.judge(0.5) == DivergenceMonitor::Verdict::ok);   // lost energy
  CHECK(monitor.judge(0.74) == DivergenceMonitor::Verdict::ok);  // 0.24 above the lowest
  CHECK(monitor.largest_gain() == doctest::Approx(0.24));
  CHECK(monitor.judge(0.76) == DivergenceMonitor::Verdict::gained);
  CHECK(monitor.judge(1e9) == DivergenceMonitor::Verdict::past_bound);
  // a new baseline (an edit) starts the lowest afresh; the largest gain is kept
  spring.set_positions(x);
  monitor.prepare(spring, Vec3::Zero(), 1e-3);
  CHECK(monitor.lowest() == doctest::Approx(1.0).epsilon(1e-15));
  CHECK(monitor.largest_gain() == doctest::Approx(0.26));
  // a turning driver does work the monitor cannot bound: no allowance is ever passed
  spring.drive_rotation({1}, Vec3::Zero(), Vec3(0, 0, 1), 1.0);
  monitor.prepare(spring, Vec3::Zero(), 1e-3);
  CHECK(std::isinf(monitor.allowance()));
  CHECK(monitor.judge(9.0) == DivergenceMonitor::Verdict::ok);
  // 0 turns the check off
  DivergenceMonitor off(10.0, 0.0);
  off.prepare(spring, Vec3::Zero(), 1e-3);
  CHECK(std::isinf(off.allowance()));
  CHECK(off.judge(9.0) == DivergenceMonitor::Verdict::ok);
  CHECK_THROWS_WITH_AS(DivergenceMonitor(10.0, -1.0), doctest::Contains("energy_growth_tolerance"),
                       std::invalid_argument);
  CHECK_THROWS_AS(DivergenceMonitor(10.0, INFINITY), std::invalid_argument);
}

TEST_CASE("check_advance_arguments names the bad argument") {
  CHECK_NOTHROW(yore::check_advance_arguments(1e-3, Vec3::Zero(), 0));
  CHECK_THROWS_WITH_AS(yore::check_advance_arguments(-1.0, Vec3::Zero(), 1),
                       doctest::Contains("dt must be finite and > 0, got -1"),
                       std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::check_advance_arguments(INFINITY, Vec3::Zero(), 1),
                       doctest::Contains("dt must be finite"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::check_advance_arguments(1e-3, Vec3(INFINITY, 0, 0), 1),
                       doctest::Contains("gravity must be finite"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::check_advance_arguments(1e-3, Vec3::Zero(), -3),
                       doctest::Contains("must be >= 0, got -3"), std::invalid_argument);
}

TEST_CASE("advance_checked restores the cloth on a blow-up and on a failing step") {
  Cloth cloth = yore_test::grid_cloth(3);
  const Positions start = cloth.positions();
  DivergenceMonitor monitor;
  Positions checkpoint_x, checkpoint_v;
  int restores = 0, steps_taken = 0;
  const auto on_restore = [&] { ++restores; };
  const auto index = [&] { return static_cast<std::int64_t>(steps_taken - 1); };
  SUBCASE("steps that stay bounded: nothing restored") {
    const auto step = [&] {
      ++steps_taken;
      cloth.advance_time(1e-3);
    };
    yore::advance_checked(cloth, Vec3::Zero(), 1e-3, 5, monitor, {"test", yore::Remedy::newton},
                          checkpoint_x, checkpoint_v, step, index, on_restore);
    CHECK(steps_taken == 5);
    CHECK(restores == 0);
    CHECK(cloth.time() == 5e-3);
  }
  SUBCASE("a step that flings a vertex away: SimulationDiverged naming the step") {
    const auto step = [&] {
      ++steps_taken;
      cloth.advance_time(1e-3);
      if (steps_taken == 3) cloth.integrator_positions()(4, 2) = 1e6;  // springs far stretched
    };
    CHECK_THROWS_WITH_AS(yore::advance_checked(cloth, Vec3::Zero(), 1e-3, 10, monitor,
                                               {"test", yore::Remedy::newton}, checkpoint_x,
                                               checkpoint_v, step, index, on_restore),
                         doctest::Contains("diverged at step 2"), yore::SimulationDiverged);
    CHECK(restores == 1);
    CHECK(cloth.positions() == start);
    CHECK(cloth.time() == 0.0);
  }
  SUBCASE("a step that feeds energy in: SimulationDiverged saying so, the cloth restored") {
    const auto step = [&] {
      ++steps_taken;
      cloth.advance_time(1e-3);
      cloth.integrator_velocities().row(4) += Vec3(0, 0, 0.5).transpose();  // a push from nowhere
    };
    CHECK_THROWS_WITH_AS(yore::advance_checked(cloth, Vec3(0, 0, -9.81), 1e-3, 1000, monitor,
                                               {"tr-bdf2", yore::Remedy::newton}, checkpoint_x,
                                               checkpoint_v, step, index, on_restore),
                         doctest::Contains("gained energy"), yore::SimulationDiverged);
    CHECK(restores == 1);
    CHECK(cloth.positions() == start);
    CHECK(cloth.time() == 0.0);
    CHECK(steps_taken < 1000);
    // the undone steps' energies are gone from the monitor's memory too
    CHECK(monitor.lowest() ==
          doctest::Approx(DivergenceMonitor::monitored_energy(cloth, Vec3(0, 0, -9.81)))
              .epsilon(1e-12));
  }
  SUBCASE("a non-finite state") {
    const auto step = [&] {
      ++steps_taken;
      cloth.integrator_positions()(1, 0) = std::nan("");
    };
    CHECK_THROWS_WITH_AS(yore::advance_checked(cloth, Vec3::Zero(), 1e-3, 10, monitor,
                                               {"test", yore::Remedy::newton}, checkpoint_x,
                                               checkpoint_v, step, index, on_restore),
                         doctest::Contains("non-finite"), yore::SimulationDiverged);
    CHECK(cloth.positions() == start);
  }
  SUBCASE("an exception from a step goes through, after the restore") {
    const auto step = [&] {
      ++steps_taken;
      cloth.integrator_positions()(1, 0) = 0.5;
      if (steps_taken == 2) throw std::runtime_error("solver broke");
    };
    CHECK_THROWS_WITH_AS(yore::advance_checked(cloth, Vec3::Zero(), 1e-3, 10, monitor,
                                               {"test", yore::Remedy::newton}, checkpoint_x,
                                               checkpoint_v, step, index, on_restore),
                         "solver broke", std::runtime_error);
    CHECK(restores == 1);
    CHECK(cloth.positions() == start);
  }
}

TEST_CASE("diverged_error advises by integrator and carries the stability estimate") {
  Cloth cloth = yore_test::grid_cloth(3);
  cloth.fix({0});
  const yore::SimulationDiverged explicit_error =
      yore::diverged_error(cloth, {"explicit", yore::Remedy::stable_step}, 7, 0.5, 0.01, true);
  CHECK(explicit_error.step() == 7);
  CHECK(explicit_error.time() == 0.5);
  CHECK(explicit_error.dt() == 0.01);
  CHECK(explicit_error.stable_dt() == doctest::Approx(cloth.stable_time_step()).epsilon(1e-12));
  CHECK(std::string(explicit_error.what()).find("energy grew past its bound") != std::string::npos);
  CHECK(std::string(explicit_error.what()).find("use dt <=") != std::string::npos);
  const yore::SimulationDiverged implicit_error =
      yore::diverged_error(cloth, {"implicit", yore::Remedy::newton}, 7, 0.5, 0.01, false);
  CHECK(std::string(implicit_error.what()).find("became non-finite") != std::string::npos);
  CHECK(std::string(implicit_error.what()).find("failed Newton solve") != std::string::npos);
}
