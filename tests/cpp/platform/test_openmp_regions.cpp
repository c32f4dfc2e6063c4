// Tests of cpp/src/platform/openmp_regions.cpp (cpp/include/yore/platform/openmp_regions.hpp):
// regions that get one thread run inline on the calling thread, as a team of one would; regions
// of several threads, and nested ones, are libgomp's; a SerialRegions scope runs every region of
// its thread inline and counts them.
#include <doctest/doctest.h>

#include <cstdint>
#include <vector>

#include "yore/platform/openmp_regions.hpp"

#ifdef _OPENMP
#include <omp.h>

using yore::openmp_regions_inlined_on_this_thread;

TEST_CASE("a region of one thread runs inline, exactly as a team of one") {
  const std::int64_t before = openmp_regions_inlined_on_this_thread();
  int threads = 0, thread = -1;
#pragma omp parallel num_threads(1)
  {
    threads = omp_get_num_threads();
    thread = omp_get_thread_num();
  }
  CHECK(threads == 1);
  CHECK(thread == 0);
  CHECK(openmp_regions_inlined_on_this_thread() == before + 1);
  // a false `if` clause, with a worksharing loop and a reduction inside: every iteration once
  volatile bool parallel = false;
  std::vector<int> hits(1000, 0);
  long sum = 0;
#pragma omp parallel for schedule(dynamic, 7) reduction(+ : sum) if (parallel)
  for (int i = 0; i < 1000; ++i) {
    ++hits[static_cast<std::size_t>(i)];
    sum += i;
  }
  CHECK(openmp_regions_inlined_on_this_thread() == before + 2);
  CHECK(sum == 999L * 1000L / 2L);
  bool once = true;
  for (const int h : hits) once = once && h == 1;
  CHECK(once);
}

TEST_CASE("regions of two threads and nested regions are libgomp's") {
  const std::int64_t before = openmp_regions_inlined_on_this_thread();
  int members = 0, nested_levels = 0;
#pragma omp parallel num_threads(2) reduction(+ : members, nested_levels)
  {
    members += 1;
#pragma omp parallel num_threads(1)
    { nested_levels += omp_get_level() == 2 ? 1 : 0; }
  }
  CHECK(members == 2);        // a real team
  CHECK(nested_levels == 2);  // the inner regions ran inside libgomp's teams, at level 2
  CHECK(openmp_regions_inlined_on_this_thread() == before);
}

TEST_CASE("a SerialRegions scope runs a region asking for 4 threads inline, and counts it") {
  std::int64_t inlined = 0;
  int threads = 0;
  {
    const yore::SerialRegions serial(&inlined);
    CHECK(omp_get_max_active_levels() == 0);
#pragma omp parallel num_threads(4)
    { threads = omp_get_num_threads(); }
  }
  CHECK(threads == 1);
  CHECK(inlined == 1);
  CHECK(omp_get_max_active_levels() > 0);  // restored
}
#endif
