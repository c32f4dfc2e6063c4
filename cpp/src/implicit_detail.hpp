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
// it shrinks by on a good fit, and the largest μ tried before giving up. Measured on the 32²
// gathered hanging cloth (120 steps at 1/60 s): from (1e-3, ×4, /4) to (1, ×10, /2) the
// thrown-away factorizations fell from 7.2 to 2.4 per step, the iterations rose from 11.8 to
// 12.7 per step (median 10 both): 15.1 factorizations per step instead of 18.9. A μ below the
// inertia itself hardly changes an indefinite matrix, so climbing from 1e-3 wasted tries.
constexpr double kMinShift = 1.0;
constexpr double kShiftGrowth = 10.0;
constexpr double kShiftShrink = 2.0;
constexpr double kMaxShift = 1e12;

}  // namespace yore::implicit_detail
