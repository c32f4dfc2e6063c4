#pragma once
/// @file build_info.hpp
/// Versions of the libraries yore was built and linked against, and threading facts.

#include <map>
#include <string>

namespace yore {

/// Versions and build facts of the physics core as name → text ("eigen", "cholmod", "compiler",
/// "openmp", "build_type").
std::map<std::string, std::string> build_info();

/// Threads OpenMP will use in the core's parallel loops (1 without OpenMP).
int max_threads();

/// Sets the number of OpenMP threads (n >= 1). Throws std::invalid_argument for n < 1.
void set_max_threads(int threads);

}  // namespace yore
