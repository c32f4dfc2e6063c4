// Tests of cpp/src/integrators/error_controlled.cpp
// (cpp/include/yore/integrators/error_controlled.hpp): CVODE's BDF and ARKODE's ESDIRK on the cloth
// — accuracy that follows the tolerance on an analytic oscillator, exact output times, restarts, no
// history, and option checks.
#include <doctest/doctest.h>

#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/integrators/error_controlled.hpp"

using yore::Cloth;
using yore::ErrorControlledIntegrator;
using yore::ErrorControlledMethod;
using yore::ErrorControlledOptions;
using yore::Positions;
using yore::Vec3;

namespace {

constexpr double kMass = 0.2, kStiffness = 50.0, kAmplitude = 0.1;

// The linear oscillator (yore_test::oscillator: exact motion y(t) = −1 − A cos(ωt)).
Cloth oscillator() { return yore_test::oscillator(kMass, kStiffness, kAmplitude); }

double error_at(ErrorControlledMethod method, double rtol) {
  ErrorControlledOptions options;
  options.method = method;
  options.rtol = rtol;
  options.atol = 1e-3 * rtol;
  Cloth cloth = oscillator();
  ErrorControlledIntegrator integrator(options);
  integrator.advance(cloth, Vec3::Zero(), 0.05, 10);
  CHECK(cloth.time() == doctest::Approx(0.5).epsilon(1e-14));
  CHECK(integrator.statistics().steps == 10);
  CHECK(integrator.statistics().internal_steps > 10);
  const double omega = std::sqrt(kStiffness / kMass);
  return std::abs(cloth.positions()(1, 1) + 1.0 + kAmplitude * std::cos(omega * 0.5));
}

}  // namespace

TEST_CASE("CVODE and ARKODE follow the analytic oscillator more closely at a tighter tolerance") {
  for (const ErrorControlledMethod method :
       {ErrorControlledMethod::cvode, ErrorControlledMethod::arkode}) {
    CAPTURE(static_cast<int>(method));
    const double loose = error_at(method, 1e-3), strict = error_at(method, 1e-6);
    CAPTURE(loose);
    CAPTURE(strict);
    // the global error of a tolerance-controlled run scales roughly with the tolerance; three
    // decades of tolerance must buy at least one of accuracy
    CHECK(strict < 0.1 * loose);
    CHECK(strict < 1e-4 * kAmplitude * 10);
  }
}

TEST_CASE("no history to save; an edit restarts the integrator; counters add up") {
  Cloth cloth = yore_test::grid_cloth(4, 200.0, 20.0, 0.02, 0.1);
  cloth.fix({12, 15});
  ErrorControlledIntegrator integrator;
  CHECK(std::string(integrator.name()) == "cvode");
  const Vec3 g(0, 0, -9.81);
  integrator.advance(cloth, g, 0.02, 3);
  CHECK_FALSE(integrator.history(cloth).valid);
  CHECK(integrator.statistics().restarts == 1);
  cloth.set_velocities(cloth.velocities());  // an outside edit
  integrator.advance(cloth, g, 0.02, 2);
  CHECK(integrator.statistics().restarts == 2);
  CHECK(integrator.statistics().steps == 5);
  CHECK(cloth.time() == doctest::Approx(0.1).epsilon(1e-14));
  // every factorization is a linear-solver setup SUNDIALS asked for
  CHECK(integrator.solver_statistics().factorizations == integrator.statistics().linear_setups);
  CHECK(integrator.solver_statistics().analyses == 1);
  // fixed vertices stayed
  const Cloth fresh = [] {
    Cloth c = yore_test::grid_cloth(4);
    return c;
  }();
  CHECK(cloth.positions().row(12) == fresh.positions().row(12));
}

TEST_CASE("bad options are std::invalid_argument naming them") {
  const auto refuses = [](ErrorControlledOptions options, const char* what) {
    CHECK_THROWS_WITH_AS(ErrorControlledIntegrator{options}, doctest::Contains(what),
                         std::invalid_argument);
  };
  ErrorControlledOptions options;
  options.rtol = 0.0;
  refuses(options, "rtol must be finite and > 0");
  options = {};
  options.max_order = 6;
  refuses(options, "max_order must be an integer from 1 to 5");
  options = {};
  options.method = ErrorControlledMethod::arkode;
  options.order = 5;
  refuses(options, "order must be 2, 3 or 4");
  options = {};
  options.max_steps = 0;
  refuses(options, "max_steps must be at least 1");
  options = {};
  options.projection = yore::HessianProjection::exact;
  refuses(options, "projection must be clamp or abs");
  options = {};
  options.linear_solver.solver = "pcg";
  refuses(options, "need a Cholesky solver");
}
