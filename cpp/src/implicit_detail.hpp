#pragma once
// Constants shared by the parts of ImplicitIntegrator (implicit.cpp: structure, objective, line
// search, state; newton.cpp: Newton's directions and projections; quasi_newton.cpp: L-BFGS).
// Private to cpp/src.

namespace yore::implicit_detail {

// Most steps the exact projection waits, projected, after repeated rejections.
constexpr int kMaxExactBackoff = 32;

// Backtracking line search: Armijo constant, halvings before giving up.
constexpr double kArmijo = 1e-4;
constexpr int kMaxBacktracks = 40;
// Relative size, against the sum of the objective's terms' magnitudes (gravity's is large and
// of the other sign), of the energy changes that round-off can hide.
constexpr double kRoundoff = 1e-12;

// Projection shifted (Levenberg–Marquardt on the exact Hessian, μ in units of M/h̃²): the
// smallest μ > 0, the factor μ grows by on an indefinite matrix or a poor model fit, the factor
// it shrinks by on a good fit, and the largest μ tried before giving up.
constexpr double kMinShift = 1e-3;
constexpr double kShiftGrowth = 4.0;
constexpr double kShiftShrink = 4.0;
constexpr double kMaxShift = 1e12;

}  // namespace yore::implicit_detail
