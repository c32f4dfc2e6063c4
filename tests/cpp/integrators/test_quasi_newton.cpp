// Tests of cpp/src/integrators/quasi_newton.cpp (ImplicitMinimizer::lbfgs of
// cpp/include/yore/integrators/implicit.hpp): L-BFGS with the constant spring matrix as its initial
// Hessian minimises the same objective as Newton's method, for backward Euler and BDF2.
#include <doctest/doctest.h>

#include "helpers.hpp"
#include "yore/integrators/implicit.hpp"

using yore::Cloth;
using yore::ImplicitIntegrator;
using yore::ImplicitMethod;
using yore::ImplicitOptions;
using yore::Vec3;

namespace {

Cloth hanging() {
  Cloth cloth = yore_test::grid_cloth(4, 200.0, 20.0, 0.03, 0.2);
  cloth.fix({12, 15});
  return cloth;
}

ImplicitOptions tight(ImplicitMethod method, yore::ImplicitMinimizer minimizer) {
  ImplicitOptions options;
  options.method = method;
  options.minimizer = minimizer;
  options.newton_tol = 1e-11;
  options.truncation_fraction = 0.0;
  return options;
}

}  // namespace

TEST_CASE("quasi-Newton steps equal Newton's steps (same objective, same residual test)") {
  for (const ImplicitMethod method : {ImplicitMethod::backward_euler, ImplicitMethod::bdf2}) {
    CAPTURE(static_cast<int>(method));
    Cloth newton_cloth = hanging(), lbfgs_cloth = hanging();
    ImplicitIntegrator newton(tight(method, yore::ImplicitMinimizer::newton));
    ImplicitIntegrator lbfgs(tight(method, yore::ImplicitMinimizer::lbfgs));
    const Vec3 g(0, 0, -9.81);
    newton.advance(newton_cloth, g, 0.02, 4);
    lbfgs.advance(lbfgs_cloth, g, 0.02, 4);
    // both residuals at 1e-11 × the mean rest length (0.33 m): 1e-8 m is a wide margin
    CHECK((lbfgs_cloth.positions() - newton_cloth.positions()).cwiseAbs().maxCoeff() < 1e-8);
    CHECK(lbfgs.statistics().unconverged_steps == 0);
    // L-BFGS needs more, cheaper iterations than Newton
    CHECK(lbfgs.statistics().newton_iterations > newton.statistics().newton_iterations);
    // the scaled residual at the end of the last step meets the test
    CHECK(lbfgs.statistics().last_scaled_residual <= 1e-11);
  }
}

TEST_CASE("quasi-Newton refuses what it cannot do") {
  ImplicitOptions options;
  options.minimizer = yore::ImplicitMinimizer::lbfgs;
  options.linearized = true;
  CHECK_THROWS_WITH_AS(ImplicitIntegrator{options},
                       doctest::Contains("takes neither linearized nor lagged_factorization"),
                       std::invalid_argument);
  options.linearized = false;
  options.lbfgs_history = 0;
  CHECK_THROWS_WITH_AS(ImplicitIntegrator{options},
                       doctest::Contains("lbfgs_history must be in [1, 1000], got 0"),
                       std::invalid_argument);
  // the incremental potential's Newton system is Newton's alone
  options.lbfgs_history = 8;
  ImplicitIntegrator lbfgs(options);
  Cloth cloth = hanging();
  CHECK_THROWS_WITH_AS(lbfgs.newton_system(cloth, Vec3::Zero(), 0.01, cloth.positions()),
                       doctest::Contains("needs a Newton integrator"), std::invalid_argument);
}
