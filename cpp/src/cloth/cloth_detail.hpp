#pragma once
// Helpers shared by the parts of Cloth (cloth.cpp: construction, topology and rest state;
// cloth_state.cpp: the stepping state; cloth_rewiring.cpp: subdivision; stable_step.cpp: the
// stable-step estimates). Private to cpp/src.

#include <cstdint>
#include <string>

#include "yore/cloth/membrane.hpp"
#include "yore/cloth/mesh.hpp"
#include "yore/platform/limits.hpp"

namespace yore::detail {

/// Bad input: a std::invalid_argument with this message.
[[noreturn]] void fail(const std::string& message);

/// Bad input naming its argument: `name` without a "state: " prefix.
[[noreturn]] void fail_argument(const std::string& message, const std::string& name);

/// Topology versions are unique across all cloths of the process, so a cache keyed by a version
/// can never mistake one cloth (or an earlier topology) for another. One counter, in cloth.cpp.
std::uint64_t next_topology_version();

/// 0 or a normal number up to kMaxMaterialValue; throws (naming `name`) otherwise.
void check_non_negative(double value, const char* name);

/// A normal number > 0 up to kMaxMaterialValue; throws (naming `name`) otherwise.
void check_positive(double value, const char* name);

/// A membrane material: Young's modulus as check_non_negative, Poisson's ratio in (−1, 1), and
/// 0 without a membrane. `prefix` starts the messages ("" or "state: ").
void check_membrane(const MembraneMaterial& membrane, const char* prefix);

/// Every row of an n×3 array finite; throws naming `name` and the first bad vertex.
void check_finite_rows(const Positions& values, const char* name);

}  // namespace yore::detail
