// Tests of cpp/src/platform/build_info.cpp (cpp/include/yore/platform/build_info.hpp): the versions
// the core was built with and its thread settings.
#include <doctest/doctest.h>

#include <stdexcept>

#include "yore/platform/build_info.hpp"

TEST_CASE("build_info names every documented library with a non-empty value") {
  const auto info = yore::build_info();
  for (const char* key : {"eigen", "cholmod", "compiler", "openmp", "build_type", "blas"}) {
    CAPTURE(key);
    REQUIRE(info.count(key) == 1);
    CHECK_FALSE(info.at(key).empty());
  }
  CHECK(info.at("eigen").find('3') == 0);  // Eigen 3.x
  // OpenBLAS names the kernel it runs inside its configuration string; another BLAS has none
  REQUIRE(info.count("blas_kernel") == 1);
  if (info.at("blas").rfind("OpenBLAS", 0) == 0) {
    CHECK_FALSE(info.at("blas_kernel").empty());
    CHECK(info.at("blas").find(info.at("blas_kernel")) != std::string::npos);
  } else {
    CHECK(info.at("blas_kernel").empty());
  }
}

TEST_CASE("set_max_threads sets what max_threads reports; below one is refused") {
  const int before = yore::max_threads();
  CHECK(before >= 1);
  yore::set_max_threads(1);
  CHECK(yore::max_threads() == 1);
  // OpenBLAS, when it is the loaded BLAS, follows (blas_threads is 0 for another BLAS)
  CHECK(yore::blas_threads() <= 1);
  yore::set_max_threads(before);
  CHECK(yore::max_threads() == before);
  CHECK_THROWS_WITH_AS(yore::set_max_threads(0), doctest::Contains("threads"),
                       std::invalid_argument);
  CHECK_THROWS_AS(yore::set_blas_threads(0), std::invalid_argument);
  if (yore::set_blas_threads(2)) CHECK(yore::blas_threads() == 2);
  yore::set_blas_threads(1);
}
