// Tests of cpp/src/integrators/newton_solver.cpp (cpp/include/yore/integrators/newton_solver.hpp):
// Newton's method on one implicit stage, used on its own as a time scheme or the SUNDIALS
// integrators use it. The stage's solution is checked against the balance it solves, with the
// spring forces computed here from the springs themselves.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "helpers.hpp"
#include "yore/integrators/newton_solver.hpp"

using yore::Cloth;
using yore::ImplicitOptions;
using yore::NewtonSolver;
using yore::Positions;
using yore::Vec3;

namespace {

// Newton solved to its residual test alone, tight.
ImplicitOptions tight_newton() {
  ImplicitOptions options;
  options.newton_tol = 1e-10;
  options.truncation_fraction = 0.0;
  return options;
}

// A 4×4 sheet of stretch springs only (no bending, damping or drag), two corners fixed, moving.
Cloth moving_sheet() {
  Cloth cloth = yore_test::grid_cloth(4, 500.0, 0.0);
  cloth.fix({0, 3});
  Positions v = Positions::Zero(16, 3);
  for (Eigen::Index i = 0; i < 16; ++i) v.row(i) << 0.1 * (i % 3), -0.05 * (i % 2), 0.3;
  for (const int fixed : {0, 3}) v.row(fixed).setZero();
  cloth.set_velocities(v);
  return cloth;
}

// Σ over springs of k (ℓ − L) along the spring, at positions x: the forces f(x), n×3.
Positions spring_forces(const Cloth& cloth, const Positions& x) {
  Positions f = Positions::Zero(x.rows(), 3);
  const yore::SpringSet& springs = cloth.springs();
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t i = springs.first[k], j = springs.second[k];
    const Vec3 d = x.row(j) - x.row(i);
    const double length = d.norm();
    const Vec3 pull = springs.stiffness[k] * (length - springs.rest_length[k]) * d / length;
    f.row(i) += pull.transpose();
    f.row(j) -= pull.transpose();
  }
  return f;
}

}  // namespace

TEST_CASE("a backward-Euler stage solved by NewtonSolver balances inertia and forces") {
  Cloth cloth = moving_sheet();
  const Positions start = cloth.positions(), start_v = cloth.velocities();
  NewtonSolver solver(tight_newton());
  const Vec3 g(0.0, 0.0, -9.81);
  const double dt = 0.01;
  REQUIRE(solver.ensure_structure(cloth));
  solver.begin_step(cloth, g);
  solver.pose_backward_euler(cloth, dt);
  cloth.advance_time(dt);
  solver.solve(cloth);
  const Positions x = solver.solution();
  // M (x − x̂)/h² = f(x) + M g at every free vertex, x̂ = xₙ + h vₙ. The residual test stops at
  // h²/m |r| ≤ 1e-10 × the mean rest length (1/3 m): |r| ≤ 2e-8 N here, against forces of
  // m g = 0.06 N; 1e-6 N leaves the round-off of 500 N/m springs room.
  const Positions f = spring_forces(cloth, x);
  double largest = 0.0;
  for (const std::int32_t i : solver.free_vertices()) {
    const double m = cloth.masses()[i];
    const Vec3 target = start.row(i) + dt * start_v.row(i);
    const Vec3 inertia = m * (x.row(i).transpose() - target) / (dt * dt);
    const Vec3 force = f.row(i).transpose() + m * g;
    largest = std::max(largest, (inertia - force).lpNorm<Eigen::Infinity>());
  }
  CHECK(largest < 1e-6);
  // the stage moved the sheet: not a trivial balance
  CHECK((x - start).cwiseAbs().maxCoeff() > 1e-3);
  CHECK(solver.free_vertices().size() == 14);
  CHECK(solver.statistics().stages == 1);
  CHECK(solver.statistics().newton_iterations == solver.step_iterations());
  CHECK(solver.step_iterations() >= 1);
  // no scheme: the truncation test cannot stop Newton, and no estimate is reported
  CHECK(solver.statistics().truncation_stops == 0);
  CHECK(std::isnan(solver.statistics().last_truncation_error));

  // write: x into the free rows, v = (x − xₙ)/h; the fixed rows stay
  solver.write(cloth);
  for (const std::int32_t i : solver.free_vertices()) {
    CHECK((cloth.positions().row(i) - x.row(i)).norm() == 0.0);
    const Vec3 v = (x.row(i) - start.row(i)) / dt;
    CHECK((cloth.velocities().row(i) - v.transpose()).norm() < 1e-12);
  }
  CHECK((cloth.positions().row(0) - start.row(0)).norm() == 0.0);
}

TEST_CASE("NewtonSolver builds its structure once per topology") {
  const Cloth first = moving_sheet();
  const Cloth second = moving_sheet();  // another cloth: another topology version
  NewtonSolver solver(ImplicitOptions{});
  CHECK(solver.ensure_structure(first));
  CHECK_FALSE(solver.ensure_structure(first));
  CHECK(solver.pattern().size == 42);  // 14 free vertices × 3
  CHECK(solver.ensure_structure(second));
  CHECK_FALSE(solver.ensure_structure(second));
  CHECK(solver.solver_statistics().analyses == 2);
}

TEST_CASE("NewtonSolver's decisions round-trip and its options are checked") {
  NewtonSolver solver(ImplicitOptions{});
  solver.set_projection_memory({3, 4, 2.0, 0.5});
  const NewtonSolver::Decisions kept = solver.decisions();
  solver.set_projection_memory({0, 1, 0.0, 0.0});
  solver.restore_decisions(kept);
  const yore::ProjectionMemory memory = solver.projection_memory();
  CHECK(memory.exact_skip == 3);
  CHECK(memory.exact_backoff == 4);
  CHECK(memory.shift == 2.0);
  CHECK(memory.radius == 0.5);
  CHECK_THROWS_AS(solver.set_projection_memory({33, 1, 0.0, 0.0}), std::invalid_argument);

  ImplicitOptions bad;
  bad.newton_tol = -1.0;
  CHECK_THROWS_WITH_AS(NewtonSolver{bad}, doctest::Contains("newton_tol must be finite and > 0"),
                       std::invalid_argument);
  ImplicitOptions exact;
  exact.adaptive_projection = true;  // mapped into the projection
  CHECK(NewtonSolver(exact).options().projection == yore::HessianProjection::exact);
}
