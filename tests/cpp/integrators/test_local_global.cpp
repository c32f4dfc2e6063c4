// Tests of cpp/src/integrators/local_global.cpp (cpp/include/yore/integrators/local_global.hpp):
// Liu et al.'s prefactored backward Euler — it minimises the Newton integrator's objective,
// decreases it every iteration, factors once per (topology, dt), and refuses what it cannot model.
#include <doctest/doctest.h>

#include <stdexcept>

#include "helpers.hpp"
#include "yore/integrators/implicit.hpp"
#include "yore/integrators/local_global.hpp"

using yore::Cloth;
using yore::LocalGlobalIntegrator;
using yore::LocalGlobalOptions;
using yore::Positions;
using yore::Vec3;

namespace {

Cloth hanging(double damping) {
  Cloth cloth = yore_test::grid_cloth(4, 200.0, 20.0, damping, 0.2);
  cloth.fix({12, 15});
  return cloth;
}

}  // namespace

TEST_CASE("converged local-global steps equal Newton's backward-Euler steps") {
  const Vec3 g(0, 0, -9.81);
  const double dt = 0.02;
  Cloth reference = hanging(0.05), cloth = hanging(0.05);
  yore::ImplicitOptions newton_options;
  newton_options.newton_tol = 1e-12;
  newton_options.truncation_fraction = 0.0;
  yore::ImplicitIntegrator newton(newton_options);
  LocalGlobalOptions options;
  options.tolerance = 1e-10;
  options.iterations = 20000;
  LocalGlobalIntegrator local_global(options);
  newton.advance(reference, g, dt, 3);
  local_global.advance(cloth, g, dt, 3);
  // both solved far below the 1e-6 m compared here (tolerances × 0.33 m mean rest length)
  CHECK((cloth.positions() - reference.positions()).cwiseAbs().maxCoeff() < 1e-6);
  CHECK((cloth.velocities() - reference.velocities()).cwiseAbs().maxCoeff() < 1e-6 / dt);
  CHECK(local_global.statistics().unconverged_steps == 0);
  CHECK(local_global.statistics().last_residual < 1e-6);
}

TEST_CASE("without acceleration every iteration lowers the objective") {
  Cloth cloth = hanging(0.0);
  LocalGlobalOptions options;
  options.chebyshev_rho = 0.0;
  options.record_objective = true;
  options.tolerance = 0.0;  // always run the cap
  options.iterations = 40;
  LocalGlobalIntegrator integrator(options);
  integrator.advance(cloth, Vec3(0, 0, -9.81), 0.02, 1);
  const std::vector<double>& objective = integrator.objective_history();
  REQUIRE(objective.size() == 40);
  for (std::size_t k = 1; k < objective.size(); ++k) {
    // alternating minimisation: monotone up to the round-off of the objective's sum
    CHECK(objective[k] <= objective[k - 1] + 1e-12 * std::abs(objective[k - 1]));
  }
  CHECK(objective.back() < objective.front());
  CHECK(integrator.statistics().last_iterations == 40);
}

TEST_CASE("one analysis per topology, one factorization per (topology, dt)") {
  Cloth cloth = hanging(0.02);
  LocalGlobalIntegrator integrator;
  const Vec3 g(0, 0, -9.81);
  integrator.advance(cloth, g, 0.02, 3);
  integrator.advance(cloth, g, 0.02, 3);
  CHECK(integrator.statistics().analyses == 1);
  CHECK(integrator.statistics().factorizations == 1);
  integrator.advance(cloth, g, 0.01, 1);
  CHECK(integrator.statistics().analyses == 1);
  CHECK(integrator.statistics().factorizations == 2);
  cloth.fix({0});
  integrator.advance(cloth, g, 0.01, 1);
  CHECK(integrator.statistics().analyses == 2);
  CHECK(integrator.statistics().rebuilds >= 1);
  CHECK(integrator.statistics().steps == 8);
  CHECK(integrator.solver_statistics().analyses >= 1);
}

TEST_CASE("bad options, and a membrane, are refused by name") {
  LocalGlobalOptions options;
  options.iterations = 0;
  CHECK_THROWS_WITH_AS(LocalGlobalIntegrator{options}, doctest::Contains("iterations must be >= 1"),
                       std::invalid_argument);
  options = {};
  options.chebyshev_rho = 1.0;
  CHECK_THROWS_WITH_AS(LocalGlobalIntegrator{options},
                       doctest::Contains("chebyshev_rho must be in [0, 1)"), std::invalid_argument);
  options = {};
  options.tolerance = -1.0;
  CHECK_THROWS_WITH_AS(LocalGlobalIntegrator{options},
                       doctest::Contains("tolerance must be finite"), std::invalid_argument);
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  Cloth membrane(
      mesh.positions, mesh.faces, Eigen::VectorXd::Constant(9, 0.01),
      yore_test::material(0.0, 0.0, 0.0, 0.0, yore::BendingModel::springs, 0.0, {100.0, 0.3}));
  const Positions start = membrane.positions();
  LocalGlobalIntegrator integrator;
  CHECK_THROWS_WITH_AS(integrator.advance(membrane, Vec3::Zero(), 0.01, 1),
                       doctest::Contains("not a membrane"), std::invalid_argument);
  CHECK(membrane.positions() == start);
}
