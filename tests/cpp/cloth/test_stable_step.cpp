// Tests of cpp/src/cloth/stable_step.cpp (cpp/include/yore/cloth/cloth.hpp): symplectic Euler's
// step limit and the stable-step estimates (Gershgorin, Lanczos at the state and for every state).
#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"

using yore::Cloth;
using yore::Edges;
using yore::Positions;

TEST_CASE("symplectic Euler's step limit: the damped oscillator's bound") {
  // h² ω² + 2 h γ = 4 at the limit
  for (const auto& [w2, gamma] : {std::pair{100.0, 0.0}, {100.0, 3.0}, {1e4, 0.5}}) {
    const double h = yore::symplectic_euler_step_limit(w2, gamma);
    CHECK(h * h * w2 + 2 * h * gamma == doctest::Approx(4.0).epsilon(1e-14));
  }
  CHECK(yore::symplectic_euler_step_limit(100.0, 0.0) == doctest::Approx(0.2).epsilon(1e-15));
  CHECK(yore::symplectic_euler_step_limit(0.0, 4.0) == 0.5);
  CHECK(std::isinf(yore::symplectic_euler_step_limit(0.0, 0.0)));
  CHECK(yore::symplectic_euler_step_limit(std::numeric_limits<double>::infinity(), 0.0) == 0.0);
  CHECK(yore::symplectic_euler_step_limit(1.0, std::nan("")) == 0.0);
}

TEST_CASE("stable steps: exact for one spring, ordered as documented on a cloth") {
  // one spring at rest, one end fixed: a single mode of ω² = k/m, h = 2/ω for every estimate
  Positions p(2, 3);
  p << 0, 0, 0, 0, -1, 0;
  Edges e(1, 2);
  e << 0, 1;
  Cloth spring = Cloth::from_springs(p, e, {}, Eigen::Vector2d(0.2, 0.2), 50.0, 0.0, 0.0);
  spring.fix({0});
  const double exact = 2.0 / std::sqrt(50.0 / 0.2);
  // Lanczos on a 3×3 problem converges to round-off
  CHECK(spring.stable_time_step() == doctest::Approx(exact).epsilon(1e-9));
  CHECK(spring.stable_time_step_bound() == doctest::Approx(exact).epsilon(1e-9));
  CHECK(spring.gershgorin_time_step() == doctest::Approx(exact).epsilon(1e-12));
  // a cloth: Gershgorin ≤ the state-independent bound ≤ the estimate at this state
  Cloth cloth = yore_test::grid_cloth(6, 500.0, 50.0, 0.01, 0.1);
  cloth.fix({0, 5});
  const double lanczos = cloth.stable_time_step(), bound = cloth.stable_time_step_bound(),
               gershgorin = cloth.gershgorin_time_step();
  CHECK(gershgorin > 0.0);
  CHECK(gershgorin <= bound * (1 + 1e-9));
  CHECK(bound <= lanczos * (1 + 1e-9));
  // stiffer springs lower every estimate (ω ∝ √k at zero damping)
  Cloth stiffer = yore_test::grid_cloth(6, 2000.0, 200.0, 0.01, 0.1);
  stiffer.fix({0, 5});
  CHECK(stiffer.stable_time_step() < lanczos);
  CHECK(stiffer.gershgorin_time_step() < gershgorin);
}
