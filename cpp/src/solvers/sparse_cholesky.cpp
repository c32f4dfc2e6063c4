#include "yore/solvers/sparse_cholesky.hpp"

#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "yore/platform/errors.hpp"
#include "yore/platform/openmp_regions.hpp"

namespace yore {
namespace {

int cholmod_ordering(Ordering ordering) {
  switch (ordering) {
    case Ordering::amd:
      return CHOLMOD_AMD;
    case Ordering::metis:
      return CHOLMOD_METIS;
    case Ordering::nesdis:
      return CHOLMOD_NESDIS;
    case Ordering::natural:
      return CHOLMOD_NATURAL;
    case Ordering::automatic:
      break;  // resolved by size before it gets here
  }
  return CHOLMOD_AMD;
}

const char* ordering_name(int code) {
  switch (code) {
    case CHOLMOD_NATURAL:
      return "natural";
    case CHOLMOD_GIVEN:
      return "given";
    case CHOLMOD_AMD:
      return "amd";
    case CHOLMOD_METIS:
      return "metis";
    case CHOLMOD_NESDIS:
      return "nesdis";
    case CHOLMOD_COLAMD:
      return "colamd";
    case CHOLMOD_POSTORDERED:
      return "natural-postordered";
    default:
      return "unknown";
  }
}

// Debian's CHOLMOD 3.0 runs some loops of its supernodal factorization in OpenMP teams of a
// fixed 4 threads (CHOLMOD_OMP_NUM_THREADS, compiled in), whatever the thread setting: on this
// project's 2-core machines, 3 extra threads that spin and hand off through futexes. A 64²
// linearized step took 3.1 CPU s per 20 steps with them and 0.96 without (one thread, same
// run; OMP_MAX_ACTIVE_LEVELS=0). The dense kernels' parallelism is BLAS's (its own threads), so
// CHOLMOD's calls run in a SerialRegions scope (openmp_regions.hpp): no active OpenMP level, and
// its regions inline on the calling thread rather than in libgomp teams of one (a system call
// each, ~9 200 per factorization of the 64² sheet). The level is process-wide in libgomp: for
// the length of a CHOLMOD call, OpenMP loops on other threads run serial too (only slower).

// Flop-weighted medians of the supernodes' widths (columns) and of the rows below them: a
// supernode of k columns with m rows below costs about k³/3 + k²m + km² flops (its dense
// Cholesky, the triangular solve below it and the update it sends to its ancestors).
void supernode_sizes(const cholmod_factor* factor, SolverStatistics& statistics) {
  statistics.supernode_median_columns = 0.0;
  statistics.supernode_median_rows = 0.0;
  if (!factor || !factor->is_super || factor->nsuper == 0) return;
  const auto* super = static_cast<const std::int32_t*>(factor->super);
  const auto* row_starts = static_cast<const std::int32_t*>(factor->pi);
  struct Node {
    double columns, rows, flops;
  };
  std::vector<Node> nodes(factor->nsuper);
  double total = 0.0;
  for (std::size_t s = 0; s < factor->nsuper; ++s) {
    const double k = super[s + 1] - super[s];
    const double m = (row_starts[s + 1] - row_starts[s]) - k;
    nodes[s] = {k, m, k * k * k / 3.0 + k * k * m + k * m * m};
    total += nodes[s].flops;
  }
  const auto median = [&](double Node::*size) {
    std::sort(nodes.begin(), nodes.end(),
              [&](const Node& a, const Node& b) { return a.*size < b.*size; });
    double sum = 0.0;
    for (const Node& node : nodes) {
      sum += node.flops;
      if (sum >= 0.5 * total) return node.*size;
    }
    return nodes.back().*size;
  };
  statistics.supernode_median_columns = median(&Node::columns);
  statistics.supernode_median_rows = median(&Node::rows);
}

}  // namespace

bool cholmod_has_metis() {
#ifdef NPARTITION
  return false;
#else
  return true;  // Debian's libcholmod links libmetis (checked by the tests through ordering
                // "metis")
#endif
}

struct SparseCholesky::Impl {
  cholmod_common common{};
  cholmod_sparse* matrix = nullptr;
  cholmod_factor* factor = nullptr;
  cholmod_factor* solve_factor = nullptr;  // simplicial copy for the solves, or null
  bool simplicial_solves = false;
  cholmod_dense* rhs = nullptr;
  cholmod_dense* solution = nullptr;
  cholmod_dense* work_y = nullptr;
  cholmod_dense* work_e = nullptr;
  // the same for several right-hand sides at once
  cholmod_dense* block_rhs = nullptr;
  cholmod_dense* block_solution = nullptr;
  cholmod_dense* block_y = nullptr;
  cholmod_dense* block_e = nullptr;
  SolverStatistics statistics;
  bool factored = false;
  Ordering ordering = Ordering::automatic;
  // A supernodal factor of a permuted matrix is refactored from the matrix stored already
  // permuted (see prepermute): `permutation` is the analysis's P (empty when the matrix is not
  // permuted), `gather[k]` the caller's value that goes to the permuted matrix's k-th entry.
  std::vector<std::int32_t> permutation;
  std::vector<std::int32_t> gather;

  Impl(FactorKind kind, Ordering requested, double relaxation) : ordering(requested) {
    cholmod_start(&common);
    common.print = 0;  // errors are reported through common.status and exceptions
    common.supernodal = kind == FactorKind::supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
    common.final_ll = 1;  // LLᵀ also for the simplicial factor
    common.nmethods = 1;
    common.method[0].ordering = cholmod_ordering(resolve_ordering(requested, 0));
    if (requested == Ordering::natural) common.postorder = 0;
    for (int k = 0; k < 3; ++k) {
      common.nrelax[k] =
          static_cast<std::size_t>(std::lround(relaxation * static_cast<double>(common.nrelax[k])));
    }
  }

  ~Impl() {
    release();
    cholmod_finish(&common);
  }

  void release() {
    if (factor) cholmod_free_factor(&factor, &common);
    if (solve_factor) cholmod_free_factor(&solve_factor, &common);
    if (matrix) cholmod_free_sparse(&matrix, &common);
    if (rhs) cholmod_free_dense(&rhs, &common);
    if (solution) cholmod_free_dense(&solution, &common);
    if (work_y) cholmod_free_dense(&work_y, &common);
    if (work_e) cholmod_free_dense(&work_e, &common);
    for (cholmod_dense** dense : {&block_rhs, &block_solution, &block_y, &block_e}) {
      if (*dense) cholmod_free_dense(dense, &common);
    }
    permutation.clear();
    gather.clear();
    factored = false;
  }

  void prepermute();

  void check(const char* what) const {
    // Out of memory is std::bad_alloc (Python's MemoryError): a run can tell it from a solver
    // failure and stop cleanly with its state kept.
    if (common.status == CHOLMOD_OUT_OF_MEMORY) throw std::bad_alloc();
    if (common.status < CHOLMOD_OK) {
      std::ostringstream msg;
      msg << "CHOLMOD " << what << " failed with status " << common.status
          << (common.status == CHOLMOD_OUT_OF_MEMORY ? " (out of memory)" : "");
      throw std::runtime_error(msg.str());
    }
  }
};

SparseCholesky::SparseCholesky(FactorKind factor, Ordering ordering, double supernode_relaxation) {
  const bool partitions = ordering == Ordering::metis || ordering == Ordering::nesdis ||
                          ordering == Ordering::automatic;
  if (partitions && !cholmod_has_metis()) {
    throw std::invalid_argument(
        "orderings 'metis', 'nesdis' and 'auto' are not available: "
        "CHOLMOD was built without METIS; valid: amd, natural");
  }
  if (!(supernode_relaxation >= 0.0 && supernode_relaxation <= 16.0)) {
    std::ostringstream msg;
    msg << "supernode_relaxation must be in [0, 16], got " << supernode_relaxation;
    throw std::invalid_argument(msg.str());
  }
  m_impl = std::make_unique<Impl>(factor, ordering, supernode_relaxation);
}

SparseCholesky::~SparseCholesky() = default;

namespace {

// The vertex graph of a pattern of b×b blocks: the lower triangle, one entry per coupled pair
// of blocks (read off each block's first column).
cholmod_sparse* block_graph(const SymmetricPattern& pattern, cholmod_common& common) {
  const std::int32_t b = pattern.block_size;
  const std::int32_t blocks = pattern.size / b;
  std::vector<std::int32_t> starts(static_cast<std::size_t>(blocks) + 1, 0), rows;
  rows.reserve(static_cast<std::size_t>(pattern.nonzeros() / (b * b) + blocks));
  for (std::int32_t block = 0; block < blocks; ++block) {
    const auto column = static_cast<std::size_t>(b * block);
    for (std::int32_t k = pattern.column_starts[column]; k < pattern.column_starts[column + 1];
         ++k) {
      const std::int32_t row = pattern.row_indices[static_cast<std::size_t>(k)] / b;
      if (rows.empty() || static_cast<std::int32_t>(rows.size()) == starts[block] ||
          rows.back() != row) {
        rows.push_back(row);
      }
    }
    starts[static_cast<std::size_t>(block) + 1] = static_cast<std::int32_t>(rows.size());
  }
  cholmod_sparse* graph =
      cholmod_allocate_sparse(static_cast<std::size_t>(blocks), static_cast<std::size_t>(blocks),
                              rows.size(), 1, 1, -1, CHOLMOD_PATTERN, &common);
  if (graph == nullptr) return nullptr;
  std::memcpy(graph->p, starts.data(), starts.size() * sizeof(std::int32_t));
  std::memcpy(graph->i, rows.data(), rows.size() * sizeof(std::int32_t));
  return graph;
}

// For each of `columns` columns of n: out[i] = in[p[i]], or with `inverse` out[p[i]] = in[i]
// (a copy when p is empty).
void permute_columns(const std::vector<std::int32_t>& p, const double* in, double* out,
                     std::size_t n, int columns, bool inverse = false) {
  for (std::size_t c = 0; c < static_cast<std::size_t>(columns); ++c) {
    const double* from = in + c * n;
    double* to = out + c * n;
    if (p.empty()) {
      std::memcpy(to, from, n * sizeof(double));
    } else if (inverse) {
      for (std::size_t i = 0; i < n; ++i) to[p[i]] = from[i];
    } else {
      for (std::size_t i = 0; i < n; ++i) to[i] = from[p[i]];
    }
  }
}

// P A Pᵀ's lower triangle from A's (compressed columns, n of them): its column starts, its rows
// (sorted within each column), and for each of its entries the index of A's entry it holds.
struct PermutedLower {
  std::vector<std::int32_t> starts, rows, source;
};

PermutedLower permuted_lower(const std::int32_t* starts, const std::int32_t* rows,
                             const std::int32_t* perm, std::int32_t n) {
  std::vector<std::int32_t> inverse(static_cast<std::size_t>(n));
  for (std::int32_t i = 0; i < n; ++i) inverse[static_cast<std::size_t>(perm[i])] = i;
  const auto nnz = static_cast<std::size_t>(starts[n]);
  // entry k of A (row r ≥ column c) goes to (max, min) of (P⁻¹r, P⁻¹c)
  const auto place = [&](std::int32_t c, std::int32_t k) {
    const std::int32_t i = inverse[static_cast<std::size_t>(rows[k])];
    const std::int32_t j = inverse[static_cast<std::size_t>(c)];
    return std::pair<std::int32_t, std::int32_t>{std::max(i, j), std::min(i, j)};
  };
  PermutedLower out;
  out.starts.assign(static_cast<std::size_t>(n) + 1, 0);
  for (std::int32_t c = 0; c < n; ++c)
    for (std::int32_t k = starts[c]; k < starts[c + 1]; ++k) ++out.starts[place(c, k).second + 1];
  for (std::int32_t c = 0; c < n; ++c) out.starts[c + 1] += out.starts[c];
  std::vector<std::int32_t> next(out.starts.begin(), out.starts.end() - 1);
  std::vector<std::pair<std::int32_t, std::int32_t>> entries(nnz);  // (row, source)
  for (std::int32_t c = 0; c < n; ++c) {
    for (std::int32_t k = starts[c]; k < starts[c + 1]; ++k) {
      const auto [row, column] = place(c, k);
      entries[static_cast<std::size_t>(next[column]++)] = {row, k};
    }
  }
  for (std::int32_t c = 0; c < n; ++c)
    std::sort(entries.begin() + out.starts[c], entries.begin() + out.starts[c + 1]);
  out.rows.resize(nnz);
  out.source.resize(nnz);
  for (std::size_t k = 0; k < nnz; ++k) {
    out.rows[k] = entries[k].first;
    out.source[k] = entries[k].second;
  }
  return out;
}

// cholmod_analyze in the matrix's own order, without postorder; the common's ordering settings
// are restored afterwards.
cholmod_factor* analyze_natural(cholmod_sparse* matrix, cholmod_common& common) {
  const int saved_ordering = common.method[0].ordering;
  const int saved_postorder = common.postorder;
  const int saved_methods = common.nmethods;
  common.nmethods = 1;
  common.method[0].ordering = CHOLMOD_NATURAL;
  common.postorder = 0;
  cholmod_factor* factor = nullptr;
  {
    const SerialRegions serial;
    factor = cholmod_analyze(matrix, &common);
  }
  common.method[0].ordering = saved_ordering;
  common.postorder = saved_postorder;
  common.nmethods = saved_methods;
  return factor;
}

}  // namespace

// CHOLMOD's supernodal factorization of PAPᵀ (cholmod_factorize with a permuted factor) first
// forms tril(PAPᵀ) by two transposes of A, allocated afresh on every call: 11.5 % of a TR-BDF2
// step on the 64² sheet (perf, one thread), with page faults on the fresh memory besides. Stored
// already permuted, in the lower triangle, and analysed again in its natural order (no
// postorder: P is CHOLMOD's postordered permutation already), the same matrix reaches the
// supernodal factorization with no transpose, in the same supernodes; the values are gathered
// into it at each factorization and right-hand sides permuted at each solve. Checked: the same
// factor (nonzeros, supernodes) or the permuted factor is kept.
void SparseCholesky::Impl::prepermute() {
  if (!factor || !factor->is_super || factor->ordering == CHOLMOD_NATURAL || !factor->Perm) return;
  const auto n = static_cast<std::int32_t>(matrix->nrow);
  const auto* perm = static_cast<const std::int32_t*>(factor->Perm);
  PermutedLower lower = permuted_lower(static_cast<const std::int32_t*>(matrix->p),
                                       static_cast<const std::int32_t*>(matrix->i), perm, n);
  const std::size_t nnz = lower.rows.size();
  cholmod_sparse* permuted =
      cholmod_allocate_sparse(matrix->nrow, matrix->ncol, nnz, 1, 1, -1, CHOLMOD_REAL, &common);
  if (permuted == nullptr) {  // keep the permuted factor; it works, only slower
    common.status = CHOLMOD_OK;
    return;
  }
  std::memcpy(permuted->p, lower.starts.data(), lower.starts.size() * sizeof(std::int32_t));
  std::memcpy(permuted->i, lower.rows.data(), nnz * sizeof(std::int32_t));
  std::memset(permuted->x, 0, nnz * sizeof(double));
  const double lnz = common.lnz, fl = common.fl;
  cholmod_factor* natural = analyze_natural(permuted, common);
  const bool same = natural != nullptr && natural->is_super && natural->nsuper == factor->nsuper &&
                    common.lnz == lnz && common.fl == fl;
  common.lnz = lnz;
  common.fl = fl;
  if (!same) {
    if (natural) cholmod_free_factor(&natural, &common);
    cholmod_free_sparse(&permuted, &common);
    common.status = CHOLMOD_OK;
    return;
  }
  permutation.assign(perm, perm + n);
  gather = std::move(lower.source);
  cholmod_free_factor(&factor, &common);
  cholmod_free_sparse(&matrix, &common);
  factor = natural;
  matrix = permuted;
}

void SparseCholesky::analyze(const SymmetricPattern& pattern) {
  Impl& d = *m_impl;
  const std::int32_t b = std::max(pattern.block_size, 1);
  const Ordering ordering = resolve_ordering(d.ordering, pattern.size / b);
  if (b == 1 || pattern.size % b != 0 || ordering == Ordering::natural) {
    d.common.method[0].ordering = cholmod_ordering(ordering);
    analyze_with_permutation(pattern, {});
    return;
  }
  cholmod_sparse* graph = block_graph(pattern, d.common);
  d.check("allocate_sparse");
  const auto blocks = static_cast<std::size_t>(pattern.size / b);
  std::vector<std::int32_t> order(blocks), parents(blocks), members(blocks);
  {
    const SerialRegions serial;
    switch (ordering) {
      case Ordering::metis:
        cholmod_metis(graph, nullptr, 0, 1, order.data(), &d.common);
        break;
      case Ordering::nesdis:
        cholmod_nested_dissection(graph, nullptr, 0, order.data(), parents.data(), members.data(),
                                  &d.common);
        break;
      default:
        cholmod_amd(graph, nullptr, 0, order.data(), &d.common);
        break;
    }
  }
  cholmod_free_sparse(&graph, &d.common);
  d.check("ordering");
  std::vector<std::int32_t> expanded(static_cast<std::size_t>(pattern.size));
  for (std::size_t k = 0; k < blocks; ++k) {
    for (std::int32_t c = 0; c < b; ++c)
      expanded[b * k + static_cast<std::size_t>(c)] = b * order[k] + c;
  }
  analyze_with_permutation(pattern, expanded);
  d.statistics.ordering = ordering_name(cholmod_ordering(ordering));
}

void SparseCholesky::analyze_with_permutation(const SymmetricPattern& pattern,
                                              const std::vector<std::int32_t>& permutation) {
  Impl& d = *m_impl;
  if (!permutation.empty()) {
    std::vector<char> seen(static_cast<std::size_t>(pattern.size), 0);
    bool valid = permutation.size() == static_cast<std::size_t>(pattern.size);
    for (const std::int32_t k : permutation) {
      valid = valid && k >= 0 && k < pattern.size && !seen[static_cast<std::size_t>(k)]++;
    }
    if (!valid) throw std::invalid_argument("analyze_with_permutation: not a permutation");
  }
  d.release();
  const auto n = static_cast<std::size_t>(pattern.size);
  const auto nnz = static_cast<std::size_t>(pattern.nonzeros());
  // stype −1: symmetric, lower triangle stored; sorted, packed.
  d.matrix = cholmod_allocate_sparse(n, n, nnz, 1, 1, -1, CHOLMOD_REAL, &d.common);
  d.check("allocate_sparse");
  std::memcpy(d.matrix->p, pattern.column_starts.data(), (n + 1) * sizeof(std::int32_t));
  std::memcpy(d.matrix->i, pattern.row_indices.data(), nnz * sizeof(std::int32_t));
  std::memset(d.matrix->x, 0, nnz * sizeof(double));
  if (permutation.empty()) {
    const SerialRegions serial;
    d.factor = cholmod_analyze(d.matrix, &d.common);
  } else {
    // One method, the given permutation (postordered by CHOLMOD as usual); restore afterwards.
    const SerialRegions serial;
    const int saved = d.common.method[0].ordering;
    d.common.method[0].ordering = CHOLMOD_GIVEN;
    d.factor = cholmod_analyze_p(d.matrix, const_cast<std::int32_t*>(permutation.data()), nullptr,
                                 0, &d.common);
    d.common.method[0].ordering = saved;
  }
  d.check("analyze");
  d.rhs = cholmod_zeros(n, 1, CHOLMOD_REAL, &d.common);
  d.check("zeros");
  ++d.statistics.analyses;
  d.statistics.factor_nonzeros = d.common.lnz;
  d.statistics.factor_flops = d.common.fl;
  d.statistics.ordering = ordering_name(d.factor->ordering);
  d.prepermute();
  supernode_sizes(d.factor, d.statistics);
}

void SparseCholesky::factorize(const double* values) {
  Impl& d = *m_impl;
  if (!d.factor) throw std::logic_error("SparseCholesky::factorize before analyze");
  auto* x = static_cast<double*>(d.matrix->x);
  if (d.gather.empty()) {
    std::memcpy(x, values, d.matrix->nzmax * sizeof(double));
  } else {
    const std::size_t count = d.gather.size();
    for (std::size_t k = 0; k < count; ++k) x[k] = values[d.gather[k]];
  }
  {
    const SerialRegions serial(&d.statistics.openmp_regions_inlined);
    cholmod_factorize(d.matrix, d.factor, &d.common);
  }
  d.check("factorize");
  ++d.statistics.factorizations;
  if (d.common.status == CHOLMOD_NOT_POSDEF || d.factor->minor < d.factor->n) {
    d.factored = false;
    std::ostringstream msg;
    msg << "the system matrix is not positive definite: CHOLMOD met a non-positive pivot at "
           "column "
        << d.factor->minor << " of " << d.factor->n;
    throw NotPositiveDefinite(msg.str());
  }
  if (d.solve_factor) cholmod_free_factor(&d.solve_factor, &d.common);
  if (d.simplicial_solves && d.factor->is_super) {
    // to simplicial LLᵀ (packed, monotonic): the supernodal factor stays for the next
    // factorization with this analysis
    d.solve_factor = cholmod_copy_factor(d.factor, &d.common);
    d.check("copy_factor");
    cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, d.solve_factor, &d.common);
    d.check("change_factor");
  }
  d.factored = true;
}

void SparseCholesky::set_simplicial_solves(bool on) { m_impl->simplicial_solves = on; }

void SparseCholesky::solve(const double* rhs, double* solution) {
  Impl& d = *m_impl;
  if (!d.factored) throw std::logic_error("SparseCholesky::solve without a valid factor");
  const std::size_t n = d.rhs->nrow;
  permute_columns(d.permutation, rhs, static_cast<double*>(d.rhs->x), n, 1);
  // cholmod_solve2 reuses solution and workspace: no allocation after the first call.
  cholmod_factor* factor = d.solve_factor ? d.solve_factor : d.factor;
  {
    const SerialRegions serial;
    cholmod_solve2(CHOLMOD_A, factor, d.rhs, nullptr, &d.solution, nullptr, &d.work_y, &d.work_e,
                   &d.common);
  }
  d.check("solve");
  permute_columns(d.permutation, static_cast<const double*>(d.solution->x), solution, n, 1, true);
  ++d.statistics.solves;
}

void SparseCholesky::solve_columns(const double* rhs, double* solution, int columns) {
  Impl& d = *m_impl;
  if (!d.factored) throw std::logic_error("SparseCholesky::solve_columns without a valid factor");
  const std::size_t n = d.factor->n;
  if (!d.block_rhs || d.block_rhs->ncol != static_cast<std::size_t>(columns)) {
    if (d.block_rhs) cholmod_free_dense(&d.block_rhs, &d.common);
    d.block_rhs = cholmod_zeros(n, static_cast<std::size_t>(columns), CHOLMOD_REAL, &d.common);
    d.check("zeros");
  }
  permute_columns(d.permutation, rhs, static_cast<double*>(d.block_rhs->x), n, columns);
  cholmod_factor* factor = d.solve_factor ? d.solve_factor : d.factor;
  {
    const SerialRegions serial;
    cholmod_solve2(CHOLMOD_A, factor, d.block_rhs, nullptr, &d.block_solution, nullptr, &d.block_y,
                   &d.block_e, &d.common);
  }
  d.check("solve");
  permute_columns(d.permutation, static_cast<const double*>(d.block_solution->x), solution, n,
                  columns, true);
  d.statistics.solves += columns;
}

const SolverStatistics& SparseCholesky::statistics() const { return m_impl->statistics; }

std::vector<std::int32_t> SparseCholesky::permutation() const {
  if (!m_impl->permutation.empty()) return m_impl->permutation;
  const cholmod_factor* factor = m_impl->factor;
  if (!factor || !factor->Perm) return {};
  const auto* perm = static_cast<const std::int32_t*>(factor->Perm);
  return std::vector<std::int32_t>(perm, perm + factor->n);
}

}  // namespace yore
