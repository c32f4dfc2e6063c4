#pragma once
/// @file build_info.hpp
/// Versions of the libraries yore was built and linked against, and the core's thread count.

#include <map>
#include <string>

namespace yore {

/// Versions and build facts of the physics core as name → text ("eigen", "cholmod", "compiler",
/// "openmp", "build_type", "blas": the loaded OpenBLAS's configuration, "blas_kernel": the
/// kernel set it chose when it loaded, "" for another BLAS).
std::map<std::string, std::string> build_info();

/// Threads the core's parallel loops may use: the last set_max_threads, else OpenMP's default
/// (OMP_NUM_THREADS, else the logical cores); 1 without OpenMP.
int max_threads();

/// Sets the threads of the core's parallel loops and of the BLAS that CHOLMOD calls (OpenBLAS,
/// when it is the loaded libblas.so.3) to `threads` (>= 1), for every thread of the process.
/// Throws std::invalid_argument for threads < 1.
void set_max_threads(int threads);

/// Sets the threads of the loaded OpenBLAS alone (threads >= 1); returns false when the loaded
/// BLAS is not OpenBLAS. Throws std::invalid_argument for threads < 1.
bool set_blas_threads(int threads);

/// Threads of the loaded OpenBLAS (what CHOLMOD's supernodal factorization uses), 0 when the
/// loaded BLAS is not OpenBLAS.
int blas_threads();

}  // namespace yore
