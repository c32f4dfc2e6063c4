// Tests of the Newton-based implicit integrators: cpp/src/integrators/implicit.cpp and
// cpp/src/integrators/assembly.cpp (the incremental potential and its Newton system),
// cpp/src/integrators/newton.cpp (Newton's iterations and projections), the schemes
// cpp/src/integrators/schemes/backward_euler.cpp, cpp/src/integrators/schemes/bdf2.cpp,
// cpp/src/integrators/schemes/generalized_alpha.cpp and cpp/src/integrators/schemes/tr_bdf2.cpp,
// and error-controlled steps (cpp/src/integrators/adaptive_steps.cpp) — all behind
// cpp/include/yore/integrators/implicit.hpp — and cpp/src/integrators/integrator.cpp
// (cpp/include/yore/integrators/integrator.hpp: the history a state file keeps and its checks).
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include "helpers.hpp"
#include "yore/integrators/implicit.hpp"

using yore::Cloth;
using yore::HessianProjection;
using yore::ImplicitIntegrator;
using yore::ImplicitMethod;
using yore::ImplicitOptions;
using yore::Positions;
using yore::Vec3;

namespace {

constexpr double kMass = 0.2, kStiffness = 50.0, kAmplitude = 0.1;

// The linear oscillator (yore_test::oscillator: exact motion y(t) = −1 − A cos(ωt)).
Cloth oscillator() { return yore_test::oscillator(kMass, kStiffness, kAmplitude); }

ImplicitOptions tight(ImplicitMethod method) {
  ImplicitOptions options;
  options.method = method;
  options.newton_tol = 1e-12;
  options.truncation_fraction = 0.0;  // the residual test alone: solved to round-off
  return options;
}

double oscillator_error(ImplicitOptions options, int steps, double end_time) {
  Cloth cloth = oscillator();
  ImplicitIntegrator integrator(options);
  integrator.advance(cloth, Vec3::Zero(), end_time / steps, steps);
  const double omega = std::sqrt(kStiffness / kMass);
  return std::abs(cloth.positions()(1, 1) - (-1.0 - kAmplitude * std::cos(omega * end_time)));
}

double oscillator_energy(const Cloth& cloth) { return cloth.energy(Vec3::Zero()).total(); }

}  // namespace

TEST_CASE("convergence orders on the linear oscillator: BE 1, BDF2, trapezoidal α and TR-BDF2 2") {
  // ω ≈ 15.8 rad/s, 0.5 s (1.26 periods) in 250 and 500 steps: h ω ≈ 0.03 and 0.016, where
  // the leading error term dominates (ratios within ±12 % of 2^order measured here)
  const double end_time = 0.5;
  struct Case {
    ImplicitMethod method;
    double order;
  };
  for (const Case c :
       {Case{ImplicitMethod::backward_euler, 1}, Case{ImplicitMethod::bdf2, 2},
        Case{ImplicitMethod::generalized_alpha, 2}, Case{ImplicitMethod::tr_bdf2, 2}}) {
    CAPTURE(static_cast<int>(c.method));
    ImplicitOptions options = tight(c.method);
    options.rho_infinity = 1.0;
    const double coarse = oscillator_error(options, 250, end_time);
    const double fine = oscillator_error(options, 500, end_time);
    CAPTURE(coarse);
    CAPTURE(fine);
    CHECK(coarse / fine == doctest::Approx(std::pow(2.0, c.order)).epsilon(0.12));
  }
}

TEST_CASE("backward Euler dissipates energy every step; the trapezoidal rule conserves it") {
  Cloth cloth = oscillator();
  ImplicitIntegrator be(tight(ImplicitMethod::backward_euler));
  double previous = oscillator_energy(cloth);
  for (int k = 0; k < 50; ++k) {
    be.advance(cloth, Vec3::Zero(), 0.01, 1);
    const double energy = oscillator_energy(cloth);
    CHECK(energy < previous);
    previous = energy;
  }
  // generalized-α with ρ∞ = 1 is Newmark's average acceleration: the energy of a linear
  // undamped system is exact after its first (backward Euler) step, up to the solver's error
  Cloth second = oscillator();
  ImplicitOptions options = tight(ImplicitMethod::generalized_alpha);
  options.rho_infinity = 1.0;
  ImplicitIntegrator trapezoid(options);
  trapezoid.advance(second, Vec3::Zero(), 0.01, 1);
  const double after_first = oscillator_energy(second);
  trapezoid.advance(second, Vec3::Zero(), 0.01, 200);
  CHECK(oscillator_energy(second) == doctest::Approx(after_first).epsilon(1e-8));
  // with ρ∞ < 1 the highest frequencies are damped: the energy falls
  Cloth third = oscillator();
  options.rho_infinity = 0.3;
  ImplicitIntegrator damped(options);
  damped.advance(third, Vec3::Zero(), 0.01, 201);
  CHECK(oscillator_energy(third) < after_first * (1 - 1e-4));
}

TEST_CASE("the Newton system: gradient and Hessian match finite differences; clamp is SPD") {
  Cloth cloth = yore_test::grid_cloth(3, 200.0, 20.0, 0.05, 0.2);
  cloth.fix({0});
  Positions v = Positions::Zero(9, 3);
  v(4, 2) = 0.3;
  cloth.set_velocities(v);
  ImplicitIntegrator integrator;
  const Vec3 g(0, 0, -9.81);
  const double dt = 0.02;
  // every spring stretched (×1.1) so the exact Hessian is the true one and positive definite
  Positions x = cloth.positions() * 1.1;
  x(4, 2) = 0.05;
  x(8, 2) = -0.03;
  const yore::NewtonSystem system =
      integrator.newton_system(cloth, g, dt, x, HessianProjection::exact);
  REQUIRE(system.free_vertices.size() == 8);
  REQUIRE(system.gradient.size() == 24);
  const Eigen::MatrixXd hessian = yore_test::dense(system.pattern, system.hessian.data());
  // central differences, h = 1e-6 m: errors ~1e-9 of the scale; 1e-6 relative is safe
  const double h = 1e-6;
  Eigen::VectorXd numeric_gradient(24);
  Eigen::MatrixXd numeric_hessian(24, 24);
  for (int block = 0; block < 8; ++block) {
    const auto vertex = system.free_vertices[static_cast<std::size_t>(block)];
    for (int c = 0; c < 3; ++c) {
      Positions plus = x, minus = x;
      plus(vertex, c) += h;
      minus(vertex, c) -= h;
      const auto up = integrator.newton_system(cloth, g, dt, plus, HessianProjection::exact);
      const auto down = integrator.newton_system(cloth, g, dt, minus, HessianProjection::exact);
      numeric_gradient[3 * block + c] = (up.energy - down.energy) / (2 * h);
      numeric_hessian.col(3 * block + c) = (up.gradient - down.gradient) / (2 * h);
    }
  }
  CHECK((numeric_gradient - system.gradient).norm() < 1e-6 * system.gradient.norm());
  CHECK((numeric_hessian - hessian).norm() < 1e-6 * hessian.norm());
  // the Newton direction solves H d = −g
  CHECK((hessian * system.direction + system.gradient).norm() < 1e-10 * system.gradient.norm());
  // compressed (×0.8): the clamped Hessian stays SPD, at least the inertia M/h²
  const Positions squeezed = cloth.positions() * 0.8;
  const yore::NewtonSystem clamped =
      integrator.newton_system(cloth, g, dt, squeezed, HessianProjection::clamp);
  const Eigen::MatrixXd h_clamped = yore_test::dense(clamped.pattern, clamped.hessian.data());
  const double lowest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(h_clamped).eigenvalues()[0];
  CHECK(lowest >= (0.1 / 9) / (dt * dt) * (1 - 1e-9));
  CHECK_THROWS_WITH_AS(integrator.newton_system(cloth, g, dt, Positions::Zero(3, 3)),
                       doctest::Contains("positions must have shape (9, 3)"),
                       std::invalid_argument);
}

TEST_CASE("a free network keeps its momentum; fixed vertices stay; one analysis per topology") {
  Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0, 0.02, 0.0);
  Positions v = Positions::Zero(16, 3);
  v.row(5) << 0.5, 0.0, 1.0;
  v.row(10) << -0.2, 0.3, 0.0;
  cloth.set_velocities(v);
  Positions x = cloth.positions();
  x(6, 2) = 0.1;
  cloth.set_positions(x);
  const auto momentum = [](const Cloth& c) {
    Vec3 p = Vec3::Zero();
    for (Eigen::Index i = 0; i < c.vertex_count(); ++i)
      p += c.masses()[i] * c.velocities().row(i).transpose();
    return p;
  };
  const Vec3 p0 = momentum(cloth);
  ImplicitOptions options;
  options.newton_tol = 1e-10;
  ImplicitIntegrator integrator(options);
  integrator.advance(cloth, Vec3::Zero(), 0.01, 20);
  // internal forces cancel in pairs; at Newton's tolerance the momentum error is the residual's
  // impulse, h Σ|∇E| ≲ 1e-10 m × m/h ≈ 1e-10 N·s
  CHECK((momentum(cloth) - p0).norm() < 1e-8);
  CHECK(integrator.solver_statistics().analyses == 1);
  CHECK(integrator.solver_statistics().factorizations >= 20);
  CHECK(integrator.statistics().steps == 20);
  // a change of topology: exactly one new analysis
  cloth.fix({0, 3});
  const Positions pinned = cloth.positions();
  integrator.advance(cloth, Vec3(0, 0, -9.81), 0.01, 10);
  CHECK(integrator.solver_statistics().analyses == 2);
  CHECK(cloth.positions().row(0) == pinned.row(0));
  CHECK(cloth.positions().row(3) == pinned.row(3));
}

TEST_CASE("the extrapolated predictor is exact in free fall and falls back to x̂ without history") {
  // No spring stretched, no damping, no drag: every stage's solution is x̂ + h̃² g, so the start
  // x̂ + h̃² ã with ã = g (held from the last stage) passes the residual test before any Newton
  // step, while the inertial start x̂ needs exactly one (the quadratic model is exact along a
  // uniform translation). The first step restarts with backward Euler from x̂: one iteration.
  const Vec3 gravity(0.0, 0.0, -9.81);
  for (const ImplicitMethod method :
       {ImplicitMethod::bdf2, ImplicitMethod::tr_bdf2, ImplicitMethod::generalized_alpha}) {
    CAPTURE(static_cast<int>(method));
    Cloth falling = yore_test::grid_cloth(4, 300.0, 30.0);
    Cloth reference = yore_test::grid_cloth(4, 300.0, 30.0);
    ImplicitOptions options;
    options.method = method;
    options.predictor = yore::NewtonPredictor::inertial;
    ImplicitIntegrator inertial(options);
    options.predictor = yore::NewtonPredictor::extrapolated;
    ImplicitIntegrator extrapolated(options);
    inertial.advance(reference, gravity, 1.0 / 60, 6);
    extrapolated.advance(falling, gravity, 1.0 / 60, 6);
    const yore::ImplicitStatistics& s = extrapolated.statistics();
    CHECK(s.history_restarts == 1);
    CHECK(s.extrapolated_stages == s.stages - 1);  // every stage but the restart's
    CHECK(s.newton_iterations == 1);               // the restart's alone
    CHECK(inertial.statistics().newton_iterations == inertial.statistics().stages);
    CHECK(inertial.statistics().extrapolated_stages == 0);
    // the same minimiser: both at it to round-off (positions ~1 m, 6 steps)
    CHECK((falling.positions() - reference.positions()).cwiseAbs().maxCoeff() < 1e-12);
    // a topology change (a vertex fixed) leaves no history: the next step restarts from x̂
    const std::int64_t before = s.extrapolated_stages;
    falling.fix({0});
    extrapolated.advance(falling, gravity, 1.0 / 60, 1);
    CHECK(s.history_restarts == 2);
    CHECK(s.extrapolated_stages == before);
    extrapolated.advance(falling, gravity, 1.0 / 60, 1);
    CHECK(s.extrapolated_stages == before + (method == ImplicitMethod::tr_bdf2 ? 2 : 1));
  }
  // backward Euler holds no acceleration: extrapolated is the inertial start, bit for bit
  Cloth a = yore_test::grid_cloth(4, 300.0, 30.0), b = yore_test::grid_cloth(4, 300.0, 30.0);
  a.fix({0, 3});
  b.fix({0, 3});
  ImplicitOptions options;
  options.predictor = yore::NewtonPredictor::inertial;
  ImplicitIntegrator inertial(options);
  options.predictor = yore::NewtonPredictor::extrapolated;
  ImplicitIntegrator extrapolated(options);
  inertial.advance(a, gravity, 1.0 / 60, 5);
  extrapolated.advance(b, gravity, 1.0 / 60, 5);
  CHECK(a.positions() == b.positions());
  CHECK(extrapolated.statistics().extrapolated_stages == 0);
}

TEST_CASE("linearized mode takes one Newton iteration per step") {
  Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0);
  cloth.fix({0, 3});
  ImplicitOptions options;
  options.linearized = true;
  ImplicitIntegrator integrator(options);
  integrator.advance(cloth, Vec3(0, 0, -9.81), 1.0 / 60, 12);
  CHECK(integrator.statistics().newton_iterations == 12);
  CHECK(integrator.statistics().line_search_backtracks == 0);
}

TEST_CASE("BDF2's history round-trips: a restored run continues bit for bit") {
  const auto make = [] {
    Cloth cloth = yore_test::grid_cloth(4, 300.0, 30.0, 0.02, 0.1);
    cloth.fix({12, 15});
    return cloth;
  };
  ImplicitOptions options;
  options.method = ImplicitMethod::bdf2;
  ImplicitIntegrator original(options), resumed(options);
  CHECK(original.history_fields() == std::vector<std::string>{"positions", "velocities"});
  Cloth cloth = make();
  const Vec3 g(0, 0, -9.81);
  CHECK_FALSE(original.history(cloth).valid);  // no step yet
  original.advance(cloth, g, 0.01, 5);
  const yore::IntegratorHistory history = original.history(cloth);
  REQUIRE(history.valid);
  CHECK(history.dt == 0.01);
  Cloth copy = Cloth::from_state(cloth.state());
  resumed.set_history(copy, history);
  original.advance(cloth, g, 0.01, 5);
  resumed.advance(copy, g, 0.01, 5);
  CHECK(cloth.positions() == copy.positions());
  CHECK(cloth.velocities() == copy.velocities());
  CHECK(resumed.statistics().history_restarts == 0);  // it did not start afresh
  // an edit of the cloth invalidates the history
  cloth.set_positions(cloth.positions());
  CHECK_FALSE(original.history(cloth).valid);
}

TEST_CASE("the history's rows of fixed vertices are zeros, whatever the heap held (R11)") {
  // Heap blocks of the history's size, filled with NaN and freed, are what the integrator's
  // arrays are carved from next: rows no step writes must still be defined.
  for (const ImplicitMethod method :
       {ImplicitMethod::tr_bdf2, ImplicitMethod::generalized_alpha, ImplicitMethod::bdf2}) {
    CAPTURE(static_cast<int>(method));
    Cloth cloth = yore_test::grid_cloth(5, 300.0, 30.0, 0.02, 0.1);
    cloth.fix({20, 24});
    {
      std::vector<std::vector<double>> junk;
      for (int k = 0; k < 64; ++k) {
        junk.emplace_back(static_cast<std::size_t>(3 * cloth.vertex_count()), std::nan(""));
      }
    }
    ImplicitOptions options;
    options.method = method;
    ImplicitIntegrator integrator(options);
    integrator.advance(cloth, Vec3(0, 0, -9.81), 0.01, 3);
    const yore::IntegratorHistory history = integrator.history(cloth);
    REQUIRE(history.valid);
    for (const auto& [name, rows] : history.arrays) {
      CAPTURE(name);
      CHECK(rows.allFinite());
      if (name != "positions") {  // BDF2 keeps the fixed vertices' positions
        for (const int fixed : {20, 24}) CHECK(rows.row(fixed).isZero(0.0));
      }
    }
  }
}

TEST_CASE("history checks name the problem (integrator.cpp)") {
  Cloth cloth = yore_test::grid_cloth(3);
  ImplicitOptions options;
  options.method = ImplicitMethod::bdf2;
  ImplicitIntegrator bdf2(options);
  yore::IntegratorHistory history;
  history.valid = true;
  history.dt = 0.01;
  history.arrays = {{"positions", cloth.positions()}};
  CHECK_THROWS_WITH_AS(bdf2.set_history(cloth, history),
                       doctest::Contains("history has no array 'velocities'"),
                       std::invalid_argument);
  history.arrays.push_back({"velocities", Positions::Zero(4, 3)});
  CHECK_THROWS_WITH_AS(bdf2.set_history(cloth, history),
                       doctest::Contains("history velocities must have 9 rows"),
                       std::invalid_argument);
  history.arrays[1].second = Positions::Zero(9, 3);
  history.dt = 0.0;
  CHECK_THROWS_WITH_AS(bdf2.set_history(cloth, history),
                       doctest::Contains("history dt must be finite and > 0"),
                       std::invalid_argument);
  history.dt = 0.01;
  history.next_dt = -1.0;
  CHECK_THROWS_WITH_AS(bdf2.set_history(cloth, history), doctest::Contains("next_dt"),
                       std::invalid_argument);
  history.next_dt = 0.0;
  history.arrays[0].second(2, 1) = std::nan("");
  CHECK_THROWS_WITH_AS(bdf2.set_history(cloth, history),
                       doctest::Contains("history positions must be finite"),
                       std::invalid_argument);
  ImplicitIntegrator be;
  CHECK(be.history_fields().empty());
  CHECK_THROWS_WITH_AS(be.set_history(cloth, history),
                       doctest::Contains("keeps no history to restore"), std::invalid_argument);
  CHECK_NOTHROW(be.set_history(cloth, yore::IntegratorHistory{}));  // an invalid one: fine
}

TEST_CASE("the other methods' history fields") {
  ImplicitOptions options;
  options.method = ImplicitMethod::generalized_alpha;
  CHECK(ImplicitIntegrator(options).history_fields() ==
        std::vector<std::string>{"accelerations", "force_accelerations"});
  options.method = ImplicitMethod::tr_bdf2;
  CHECK(ImplicitIntegrator(options).history_fields() == std::vector<std::string>{"accelerations"});
}

TEST_CASE("error-controlled TR-BDF2 ends every output interval exactly; error follows rtol") {
  const double omega = std::sqrt(kStiffness / kMass);
  const auto run = [&](double rtol, std::int64_t& steps) {
    ImplicitOptions options = tight(ImplicitMethod::tr_bdf2);
    options.adaptive = true;
    options.rtol = rtol;
    options.atol = 1e-9;
    Cloth cloth = oscillator();
    ImplicitIntegrator integrator(options);
    integrator.advance(cloth, Vec3::Zero(), 0.05, 10);
    CHECK(integrator.statistics().intervals == 10);
    CHECK(cloth.time() == doctest::Approx(0.5).epsilon(1e-14));
    // each accepted step's estimate is within its tolerance (|x| ≤ 1.1 m here)
    CHECK(integrator.statistics().last_truncation_error <= options.atol + rtol * 1.1);
    steps = integrator.statistics().steps;
    return std::abs(cloth.positions()(1, 1) + 1.0 + kAmplitude * std::cos(omega * 0.5));
  };
  std::int64_t loose_steps = 0, tight_steps = 0;
  const double loose = run(1e-4, loose_steps), strict = run(1e-5, tight_steps);
  CAPTURE(loose);
  CAPTURE(strict);
  CHECK(loose_steps > 10);  // the error test asked for steps shorter than the interval
  CHECK(tight_steps > loose_steps);
  // the global error is at most the sum of the local ones (an oscillator does not amplify)
  CHECK(loose < static_cast<double>(loose_steps) * 1e-4 * 1.1);
  // a second-order method: the error per step ∝ h³, steps ∝ tol^(−1/3), so the global error
  // ∝ tol^(2/3): 10× tighter gives ≈ 4.6× smaller; 3× leaves room for the controller's rounding
  CHECK(loose / strict > 3.0);
}

TEST_CASE("bad options are std::invalid_argument naming them") {
  const auto refuses = [](ImplicitOptions options, const char* what) {
    CHECK_THROWS_WITH_AS(ImplicitIntegrator{options}, doctest::Contains(what),
                         std::invalid_argument);
  };
  ImplicitOptions options;
  options.newton_tol = 0.0;
  refuses(options, "newton_tol must be finite and > 0");
  options = {};
  options.rho_infinity = 1.5;
  refuses(options, "rho_infinity must be finite and in [0, 1]");
  options = {};
  options.max_newton = 0;
  refuses(options, "max_newton must be >= 1");
  options = {};
  options.linear_solver.solver = "nope";
  refuses(options, "unknown solver 'nope'");
  options = {};
  options.adaptive = true;  // backward Euler has no error estimate
  refuses(options, "need a local error estimate");
  options = {};
  options.minimizer = yore::ImplicitMinimizer::lbfgs;
  options.method = ImplicitMethod::tr_bdf2;
  refuses(options, "lbfgs) takes method backward-euler or bdf2");
  ImplicitIntegrator integrator;
  CHECK_THROWS_WITH_AS(integrator.set_projection_memory({-1, 1, 0.0, 0.0}),
                       doctest::Contains("projection memory must have exact_skip"),
                       std::invalid_argument);
  Cloth cloth = yore_test::grid_cloth(3);
  CHECK_THROWS_WITH_AS(integrator.advance(cloth, Vec3::Zero(), -0.01, 1),
                       doctest::Contains("dt must be finite and > 0"), std::invalid_argument);
}

TEST_CASE("resolve_choices decides only what is left open, and refuses a contradiction") {
  using yore::ImplicitChoices;
  using yore::NewtonPredictor;
  // nothing given: the clamp with the mixed matrices, from the inertial guess
  ImplicitOptions decided = yore::resolve_choices(ImplicitOptions{}, ImplicitChoices{});
  CHECK(decided.projection == HessianProjection::clamp);
  CHECK(decided.predictor == NewtonPredictor::inertial);
  CHECK(decided.mixed);
  CHECK_FALSE(decided.adaptive_projection);
  // the linearized step starts at xₙ and takes no mixed matrices
  ImplicitOptions linearized;
  linearized.linearized = true;
  decided = yore::resolve_choices(linearized, ImplicitChoices{});
  CHECK(decided.predictor == NewtonPredictor::start);
  CHECK_FALSE(decided.mixed);
  // adaptive_projection maps into projection; mixed goes with the clamp only
  ImplicitChoices adaptive;
  adaptive.adaptive_projection = true;
  decided = yore::resolve_choices(ImplicitOptions{}, adaptive);
  CHECK(decided.projection == HessianProjection::exact);
  CHECK_FALSE(decided.mixed);
  // given choices are kept as given
  ImplicitChoices given;
  given.projection = HessianProjection::steihaug;
  given.predictor = NewtonPredictor::start;
  given.mixed = true;
  decided = yore::resolve_choices(ImplicitOptions{}, given);
  CHECK(decided.projection == HessianProjection::steihaug);
  CHECK(decided.predictor == NewtonPredictor::start);
  CHECK(decided.mixed);
  // quasi-Newton decides its predictor alone
  ImplicitOptions lbfgs;
  lbfgs.minimizer = yore::ImplicitMinimizer::lbfgs;
  decided = yore::resolve_choices(lbfgs, ImplicitChoices{});
  CHECK(decided.predictor == NewtonPredictor::inertial);
  CHECK_FALSE(decided.mixed);  // untouched: the struct's default
  ImplicitChoices contradicting;
  contradicting.adaptive_projection = true;
  contradicting.projection = HessianProjection::clamp;
  CHECK_THROWS_WITH_AS(yore::resolve_choices(ImplicitOptions{}, contradicting),
                       "adaptive_projection=True contradicts projection='clamp'; give one of them",
                       std::invalid_argument);
}

TEST_CASE("integrator_names: every public name once, the schemes' from their rows") {
  const std::vector<std::string> names = yore::integrator_names();
  CHECK(std::set<std::string>(names.begin(), names.end()).size() == names.size());
  CHECK(names.front() == "explicit");
  for (const yore::TimeSchemeRow& row : yore::time_schemes()) {
    CHECK(std::count(names.begin(), names.end(), std::string(row.integrator)) == 1);
  }
  for (const char* other : {"quasi-newton", "local-global", "cvode", "arkode"}) {
    CHECK(std::count(names.begin(), names.end(), std::string(other)) == 1);
  }
  CHECK(names.size() == yore::time_schemes().size() + 5);
}
