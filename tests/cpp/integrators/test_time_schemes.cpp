// Tests of the time schemes apart from Newton: cpp/src/integrators/schemes/registry.cpp (the
// registry behind cpp/include/yore/integrators/time_scheme.hpp),
// cpp/src/integrators/schemes/implicit_midpoint.cpp, and what every scheme shares through it
// (history arrays, error control only with an estimate). The older schemes' numerics
// (cpp/src/integrators/schemes/backward_euler.cpp, bdf2.cpp, generalized_alpha.cpp, tr_bdf2.cpp)
// and cpp/src/integrators/adaptive_steps.cpp are tested in test_implicit.cpp.
#include <doctest/doctest.h>

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "helpers.hpp"
#include "yore/integrators/implicit.hpp"
#include "yore/integrators/time_scheme.hpp"

using yore::Cloth;
using yore::ImplicitIntegrator;
using yore::ImplicitMethod;
using yore::ImplicitOptions;
using yore::Positions;
using yore::Vec3;

namespace {

constexpr double kMass = 0.2, kStiffness = 50.0, kAmplitude = 0.1;

ImplicitOptions tight(ImplicitMethod method) {
  ImplicitOptions options;
  options.method = method;
  options.newton_tol = 1e-12;
  options.truncation_fraction = 0.0;  // the residual test alone: solved to round-off
  return options;
}

double energy(const Cloth& cloth) { return cloth.energy(Vec3::Zero()).total(); }

// A free, undamped network in motion (no fixed vertex, no gravity): its momentum and angular
// momentum are invariants of the motion.
Cloth spinning_network() {
  Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0, 0.0, 0.0);
  Positions v = Positions::Zero(16, 3);
  for (Eigen::Index i = 0; i < 16; ++i) {
    const Vec3 x = cloth.positions().row(i).transpose() - Vec3(0.5, 0.5, 0.0);
    v.row(i) = (Vec3(0.0, 0.0, 4.0).cross(x) + Vec3(0.1, -0.2, 0.3)).transpose();
  }
  v.row(5) += Vec3(0.3, 0.0, 1.0).transpose();  // and a kick that stretches the springs
  cloth.set_velocities(v);
  return cloth;
}

Vec3 angular_momentum(const Cloth& cloth) {
  Vec3 total = Vec3::Zero();
  for (Eigen::Index i = 0; i < cloth.vertex_count(); ++i) {
    total += cloth.masses()[i] *
             cloth.positions().row(i).transpose().cross(cloth.velocities().row(i).transpose());
  }
  return total;
}

}  // namespace

TEST_CASE("the registry has one row per scheme, named once, and makes each") {
  std::set<std::string> names, integrators;
  std::set<int> methods;
  for (const yore::TimeSchemeRow& row : yore::time_schemes()) {
    CAPTURE(row.name);
    names.insert(row.name);
    integrators.insert(row.integrator);
    methods.insert(static_cast<int>(row.method));
    CHECK(&yore::time_scheme(row.method) == &row);
    ImplicitOptions options;
    options.method = row.method;
    CHECK(row.make(options) != nullptr);
  }
  const std::size_t rows = yore::time_schemes().size();
  CHECK(rows == 5);
  CHECK(names.size() == rows);
  CHECK(integrators.size() == rows);
  CHECK(methods.size() == rows);
  CHECK(names.count("implicit-midpoint") == 1);
}

TEST_CASE("error control only wraps a scheme with an estimate") {
  for (const yore::TimeSchemeRow& row : yore::time_schemes()) {
    CAPTURE(row.name);
    ImplicitOptions options;
    options.method = row.method;
    options.adaptive = true;
    const bool estimate = row.make(options)->error_estimate();
    if (estimate) {
      CHECK_NOTHROW(ImplicitIntegrator{options});
    } else {
      CHECK_THROWS_AS(ImplicitIntegrator{options}, std::invalid_argument);
    }
  }
}

TEST_CASE("implicit midpoint: second order on the linear oscillator") {
  // h ω ≈ 0.03 and 0.016 over 0.5 s, as the other schemes' order test
  const auto error = [](int steps) {
    Cloth cloth = yore_test::oscillator(kMass, kStiffness, kAmplitude);
    ImplicitIntegrator integrator(tight(ImplicitMethod::implicit_midpoint));
    integrator.advance(cloth, Vec3::Zero(), 0.5 / steps, steps);
    const double omega = std::sqrt(kStiffness / kMass);
    return std::abs(cloth.positions()(1, 1) - (-1.0 - kAmplitude * std::cos(omega * 0.5)));
  };
  const double coarse = error(250), fine = error(500);
  CAPTURE(coarse);
  CAPTURE(fine);
  CHECK(coarse / fine == doctest::Approx(4.0).epsilon(0.12));
}

TEST_CASE("implicit midpoint conserves a linear system's energy from the first step, at any dt") {
  // h ω = 1.6 per step: backward Euler loses nearly all of it, the midpoint rule none (its
  // amplification factor has modulus 1 on the imaginary axis), from the first step: a step
  // without history is a midpoint step too (only its error estimate restarts)
  for (const double dt : {0.01, 0.1}) {
    CAPTURE(dt);
    Cloth cloth = yore_test::oscillator(kMass, kStiffness, kAmplitude);
    const double start = energy(cloth);
    ImplicitIntegrator midpoint(tight(ImplicitMethod::implicit_midpoint));
    midpoint.advance(cloth, Vec3::Zero(), dt, 200);
    CHECK(energy(cloth) == doctest::Approx(start).epsilon(1e-9));
    CHECK(midpoint.statistics().history_restarts == 1);
  }
  Cloth damped = yore_test::oscillator(kMass, kStiffness, kAmplitude);
  const double start = energy(damped);
  ImplicitIntegrator be(tight(ImplicitMethod::backward_euler));
  be.advance(damped, Vec3::Zero(), 0.1, 200);
  CHECK(energy(damped) < 0.01 * start);
}

TEST_CASE("implicit midpoint keeps momentum and angular momentum of a free nonlinear network") {
  // Both are quadratic invariants, which the midpoint rule conserves exactly on any system of
  // central forces (up to Newton's residual); backward Euler loses angular momentum.
  Cloth cloth = spinning_network();
  const Vec3 start = angular_momentum(cloth);
  const double start_energy = energy(cloth);
  ImplicitIntegrator midpoint(tight(ImplicitMethod::implicit_midpoint));
  midpoint.advance(cloth, Vec3::Zero(), 0.02, 100);
  CHECK((angular_momentum(cloth) - start).norm() < 1e-9 * start.norm());
  // the energy of nonlinear springs is not exactly conserved, but it neither decays nor grows
  CHECK(energy(cloth) == doctest::Approx(start_energy).epsilon(0.02));
  Cloth other = spinning_network();
  ImplicitIntegrator be(tight(ImplicitMethod::backward_euler));
  be.advance(other, Vec3::Zero(), 0.02, 100);
  CHECK((angular_momentum(other) - start).norm() > 0.05 * start.norm());
}

TEST_CASE("implicit midpoint's history round-trips and stops Newton by its estimate") {
  const auto make = [] {
    Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0, 0.02, 0.1);
    cloth.fix({12, 15});
    return cloth;
  };
  ImplicitOptions options;
  options.method = ImplicitMethod::implicit_midpoint;
  ImplicitIntegrator original(options), resumed(options);
  CHECK(original.history_fields() == std::vector<std::string>{"accelerations"});
  Cloth cloth = make();
  const Vec3 g(0, 0, -9.81);
  CHECK_FALSE(original.history(cloth).valid);
  original.advance(cloth, g, 0.01, 5);
  // the first step has no earlier midpoint (estimate 0), the later ones do
  CHECK(original.statistics().last_truncation_error > 0.0);
  const yore::IntegratorHistory history = original.history(cloth);
  REQUIRE(history.valid);
  Cloth copy = Cloth::from_state(cloth.state());
  resumed.set_history(copy, history);
  original.advance(cloth, g, 0.01, 5);
  resumed.advance(copy, g, 0.01, 5);
  CHECK(cloth.positions() == copy.positions());
  CHECK(cloth.velocities() == copy.velocities());
  // fixed vertices stay where the drivers hold them
  CHECK(cloth.positions().row(12) == make().positions().row(12));
}
