#include "solve/sparse_cholesky.hpp"

#include "core/fnv1a.hpp"
#include "core/target_clones.hpp"
#include "solve/diagonal_shifts.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <utility>

namespace fascia {

namespace {

// A supernodal factorisation runs on several threads only where its supernodes are large: on
// average at least kParallelSupernodeFlops of CHOLMOD's flop count each. CHOLMOD's supernodal
// factorisation is parallel only within its BLAS calls, a few per supernode, each an OpenMP
// parallel region: under the passive wait policy a region took 23-51 µs on a 16-core virtual
// machine (2 to 16 threads) and 70-100 µs on a 2-core one, while 1e7 flops take about 0.5 ms on
// one core. The shipped scenes' tangents average 2e5 flops per supernode (the pelvis), the pelvis
// with shells of 5,120 triangles 1.1e6 (its factorisation on two threads of the 2-core VM made
// the step 30 % slower), the pelvis's tangent at 16 k and 56 k samples 1.9e7 and 9.9e7, the
// consistent integration's systems 1e8 to 2.3e8. Supernodal factors of any size are solved on
// one thread (supernodal_solve): CHOLMOD's solve makes a multithreaded BLAS-2 call per supernode
// and column block, far less work than a region's cost.
constexpr double kParallelSupernodeFlops = 1e7;

// The most threads a factorisation runs with. Its BLAS calls, one supernode at a time, gain
// little beyond four threads: the consistent integration's system of the pelvis with its finest
// fasciae (n 9,068, 12.3 M nonzeros in L) factorised on an H200 host (16 cores, OpenBLAS's
// SkylakeX kernels) in 0.68 s with 4 threads, 0.76 with 8, 1.05 with 16 and 0.89 with 2.
constexpr int kMaxFactorThreads = 4;

// A supernodal factor of at least this many stored entries is swept, when it preconditions PCG,
// with its values rounded to float (SparseCholesky::solve): such sweeps stream the factor from
// memory twice per solve, and half its bytes is what bounds them; the pelvis's tangent at 56 k
// samples has 1.2e7 entries (96 MB in double), at 16 k 2.7e6, the shipped scenes' about 2.7e5,
// which stay in cache and in double.
constexpr double kSinglePrecisionSweepEntries = 1e6;

// Sets the calling thread's OpenMP team size for the scope and restores it after.
class TeamSize {
 public:
  explicit TeamSize(int threads) : m_previous(omp_get_max_threads()) { omp_set_num_threads(threads); }
  ~TeamSize() { omp_set_num_threads(m_previous); }
  TeamSize(const TeamSize&) = delete;
  TeamSize& operator=(const TeamSize&) = delete;

 private:
  int m_previous;
};

// Makes every OpenMP region that starts in the scope inactive (one thread), which a team size
// does not do for regions with a num_threads clause: CHOLMOD's supernodal numeric factorisation
// asks for 4 threads in its loops over large supernodes (about 200 regions per factorisation of
// the shipped scenes' tangents). The level limit is the process's: regions that other threads
// start meanwhile (the rows' output thread) run on one thread too, for the factorisation's
// milliseconds.
class SerialRegions {
 public:
  SerialRegions() : m_previous(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
  ~SerialRegions() { omp_set_max_active_levels(m_previous); }
  SerialRegions(const SerialRegions&) = delete;
  SerialRegions& operator=(const SerialRegions&) = delete;

 private:
  int m_previous;
};

// A supernode's block: nsrow x nscol, column-major, its first nscol rows a lower triangle T and
// the m = nsrow - nscol rows below them a rectangle B (cholmod.h's layout, below); values of
// type Value (double, or float for a preconditioner's sweeps), the arithmetic in double.
template <class Value>
struct SupernodeBlock {
  const Value* x;
  int nsrow, nscol;
  const Value* column(int j) const { return x + static_cast<std::ptrdiff_t>(j) * nsrow; }
};

// Forward over columns j0 .. j0 + 3 of a supernode, t [nsrow] holding the right-hand side at its
// rows: the 4 x 4 triangle on the diagonal, then t_i -= sum_q L_{i,j0+q} t_{j0+q} for every row
// below it, T's and B's alike, in one pass over the four columns.
template <class Value>
FASCIA_CLONE_INLINE void forward_panel(const SupernodeBlock<Value>& L, int j0, double* t) {
  const Value *c0 = L.column(j0), *c1 = L.column(j0 + 1), *c2 = L.column(j0 + 2), *c3 = L.column(j0 + 3);
  const double v0 = t[j0] / c0[j0];
  const double v1 = (t[j0 + 1] - c0[j0 + 1] * v0) / c1[j0 + 1];
  const double v2 = (t[j0 + 2] - c0[j0 + 2] * v0 - c1[j0 + 2] * v1) / c2[j0 + 2];
  const double v3 = (t[j0 + 3] - c0[j0 + 3] * v0 - c1[j0 + 3] * v1 - c2[j0 + 3] * v2) / c3[j0 + 3];
  t[j0] = v0, t[j0 + 1] = v1, t[j0 + 2] = v2, t[j0 + 3] = v3;
#pragma omp simd
  for (int i = j0 + 4; i < L.nsrow; ++i) t[i] -= c0[i] * v0 + c1[i] * v1 + c2[i] * v2 + c3[i] * v3;
}

// Forward over one column j.
template <class Value>
FASCIA_CLONE_INLINE void forward_column(const SupernodeBlock<Value>& L, int j, double* t) {
  const Value* c = L.column(j);
  const double v = t[j] / c[j];
  t[j] = v;
#pragma omp simd
  for (int i = j + 1; i < L.nsrow; ++i) t[i] -= c[i] * v;
}

// Backward over columns j0 .. j0 + 3, every row below them final: four dot products with those
// rows (independent sums, so the pass is bound by the loads, not by an addition's latency), then
// the 4 x 4 triangle transposed.
template <class Value>
FASCIA_CLONE_INLINE void backward_panel(const SupernodeBlock<Value>& L, int j0, double* t) {
  const Value *c0 = L.column(j0), *c1 = L.column(j0 + 1), *c2 = L.column(j0 + 2), *c3 = L.column(j0 + 3);
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
#pragma omp simd reduction(+ : s0, s1, s2, s3)
  for (int i = j0 + 4; i < L.nsrow; ++i) {
    s0 += c0[i] * t[i];
    s1 += c1[i] * t[i];
    s2 += c2[i] * t[i];
    s3 += c3[i] * t[i];
  }
  const double v3 = (t[j0 + 3] - s3) / c3[j0 + 3];
  const double v2 = (t[j0 + 2] - s2 - c2[j0 + 3] * v3) / c2[j0 + 2];
  const double v1 = (t[j0 + 1] - s1 - c1[j0 + 2] * v2 - c1[j0 + 3] * v3) / c1[j0 + 1];
  const double v0 = (t[j0] - s0 - c0[j0 + 1] * v1 - c0[j0 + 2] * v2 - c0[j0 + 3] * v3) / c0[j0];
  t[j0] = v0, t[j0 + 1] = v1, t[j0 + 2] = v2, t[j0 + 3] = v3;
}

// Backward over one column j.
template <class Value>
FASCIA_CLONE_INLINE void backward_column(const SupernodeBlock<Value>& L, int j, double* t) {
  const Value* c = L.column(j);
  double s = 0.0;
#pragma omp simd reduction(+ : s)
  for (int i = j + 1; i < L.nsrow; ++i) s += c[i] * t[i];
  t[j] = (t[j] - s) / c[j];
}

// y = L^{-T} L^{-1} y for a supernodal LL^T factor (cholmod.h's layout: supernode k holds
// columns super[k] .. super[k+1] - 1, its rows are s[pi[k]] .. s[pi[k+1] - 1], the first nscol
// of them its columns, and its values are the column-major nsrow x nscol block at x + px[k]).
// Per supernode, y's entries at its rows are gathered into t [nsrow] (forward: its columns', and
// zeros below them, which collect -B t), swept in panels of four columns, and put back (forward:
// the rows below added in). CHOLMOD's solve makes the same sweeps with BLAS calls per supernode
// and column block, whose overhead exceeds the arithmetic on the shipped scenes' factors (tens of
// columns per supernode); a column at a time, the sweeps would wait on each column's division
// and on each dot product's additions. These loops run in AVX2 where the CPU has it
// (core/target_clones.hpp).
// The sweeps of supernodal_solve over the factor's structure with values x (the factor's own,
// or their float copy).
template <class Value>
FASCIA_CLONE_INLINE void sweep(const cholmod_factor& factor, const Value* x, double* y, double* t) {
  const int* super = static_cast<const int*>(factor.super);
  const int* pi = static_cast<const int*>(factor.pi);
  const int* px = static_cast<const int*>(factor.px);
  const int* rows = static_cast<const int*>(factor.s);
  const int nsuper = static_cast<int>(factor.nsuper);
  for (int k = 0; k < nsuper; ++k) {  // y = L^{-1} y
    const SupernodeBlock<Value> L{x + px[k], pi[k + 1] - pi[k], super[k + 1] - super[k]};
    const int* r = rows + pi[k];
    for (int i = 0; i < L.nscol; ++i) t[i] = y[r[i]];
    for (int i = L.nscol; i < L.nsrow; ++i) t[i] = 0.0;
    int j = 0;
    for (; j + 4 <= L.nscol; j += 4) forward_panel(L, j, t);
    for (; j < L.nscol; ++j) forward_column(L, j, t);
    for (int i = 0; i < L.nscol; ++i) y[r[i]] = t[i];
    for (int i = L.nscol; i < L.nsrow; ++i) y[r[i]] += t[i];
  }
  for (int k = nsuper - 1; k >= 0; --k) {  // y = L^{-T} y
    const SupernodeBlock<Value> L{x + px[k], pi[k + 1] - pi[k], super[k + 1] - super[k]};
    const int* r = rows + pi[k];
    for (int i = 0; i < L.nsrow; ++i) t[i] = y[r[i]];
    const int panels = L.nscol / 4 * 4;
    for (int j = L.nscol - 1; j >= panels; --j) backward_column(L, j, t);
    for (int j = panels - 4; j >= 0; j -= 4) backward_panel(L, j, t);
    for (int i = 0; i < L.nscol; ++i) y[r[i]] = t[i];
  }
}

FASCIA_CLONES void supernodal_solve(const cholmod_factor& factor, double* y, double* t) {
  sweep(factor, static_cast<const double*>(factor.x), y, t);
}

// The same sweeps reading the factor's values rounded to float (values: [factor.xsize]).
FASCIA_CLONES void supernodal_solve(const cholmod_factor& factor, const float* values, double* y, double* t) {
  sweep(factor, values, y, t);
}

}  // namespace

class SparseCholesky::Factor : public Eigen::CholmodDecomposition<Eigen::SparseMatrix<double>, Eigen::Lower> {
 public:
  const cholmod_factor* factor() const { return m_cholmodFactor; }
};

SparseCholesky::SparseCholesky() : m_factor(std::make_unique<Factor>()) {
  cholmod_common& c = m_factor->cholmod();
  c.print = 0;  // failures are reported by factorise(), not on stderr
  // CHOLMOD chooses simplicial or supernodal from the analysis (supernodal where flops per
  // nonzero of L are high: the finer scenes); LL^T in both, so that a matrix that is not
  // positive definite is detected and shifted rather than factorised as an indefinite LDL^T.
  c.supernodal = CHOLMOD_AUTO;
  c.final_asis = 0;
  c.final_ll = 1;
}

SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::factorise(const Eigen::SparseMatrix<double>& H, const std::uint8_t* fixed) {
  const int n = static_cast<int>(H.rows());
  std::vector<std::uint8_t> mask(n, 0);
  if (fixed) std::copy(fixed, fixed + n, mask.begin());
  if (mask != m_fixed || static_cast<int>(m_index.size()) != n) {
    m_fixed = mask;
    m_index.assign(n, -1);
    m_free_dofs.clear();
    for (int k = 0; k < n; ++k)
      if (!mask[k]) {
        m_index[k] = static_cast<int>(m_free_dofs.size());
        m_free_dofs.push_back(k);
      }
    m_analysed = false;
  }
  const int free = static_cast<int>(m_free_dofs.size());
  // A compressed view of H (the assembled tangents are compressed already).
  Eigen::SparseMatrix<double> compressed;
  const Eigen::SparseMatrix<double>* source = &H;
  if (!H.isCompressed()) {
    compressed = H;
    compressed.makeCompressed();
    source = &compressed;
  }
  const int* h_outer = source->outerIndexPtr();
  const int* h_inner = source->innerIndexPtr();
  const Eigen::Index h_nonzeros = source->nonZeros();
  const bool same_source = m_analysed && m_source_outer.size() == static_cast<size_t>(n + 1) &&
                           std::equal(h_outer, h_outer + n + 1, m_source_outer.begin()) &&
                           std::equal(h_inner, h_inner + h_nonzeros, m_source_inner.begin(), m_source_inner.end());
  if (!same_source) {
    // The pattern: the lower triangle of the free-free block, with every diagonal entry present
    // (the shift below writes there without changing the pattern) and every entry of the
    // analysed pattern (assemblies leave out entries that happen to be zero, e.g. load blocks at
    // rest), so that a matrix whose pattern is contained in the analysed one keeps that analysis.
    // Column by column in parallel (the free DOFs keep H's order, so a column's rows are H's
    // column's, mapped): its rows sorted, then each entry of H's at its position (-1: a fixed
    // row or column, or the upper triangle), which the factorisations' values are scattered by.
    const bool keep_analysed = m_analysed && static_cast<int>(m_outer.size()) == free + 1;
    std::vector<std::vector<int>> columns(static_cast<size_t>(free));
#pragma omp parallel for schedule(dynamic, 64)
    for (int col = 0; col < free; ++col) {
      std::vector<int>& rows = columns[static_cast<size_t>(col)];
      const int c = m_free_dofs[static_cast<size_t>(col)];
      rows.push_back(col);
      for (int k = h_outer[c]; k < h_outer[c + 1]; ++k) {
        const int r = m_index[h_inner[k]];
        if (r >= col) rows.push_back(r);
      }
      if (keep_analysed) rows.insert(rows.end(), m_inner.begin() + m_outer[col], m_inner.begin() + m_outer[col + 1]);
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    }
    std::vector<int> outer(static_cast<size_t>(free) + 1, 0);
    for (int col = 0; col < free; ++col)
      outer[static_cast<size_t>(col) + 1] = outer[static_cast<size_t>(col)] + static_cast<int>(columns[static_cast<size_t>(col)].size());
    m_reduced.resize(free, free);
    m_reduced.resizeNonZeros(outer.back());
    std::copy(outer.begin(), outer.end(), m_reduced.outerIndexPtr());
    int* inner = m_reduced.innerIndexPtr();
    m_source_outer.assign(h_outer, h_outer + n + 1);
    m_source_inner.assign(h_inner, h_inner + h_nonzeros);
    m_scatter.assign(static_cast<size_t>(h_nonzeros), -1);
#pragma omp parallel for schedule(dynamic, 64)
    for (int col = 0; col < free; ++col) {
      const std::vector<int>& rows = columns[static_cast<size_t>(col)];
      const int first = outer[static_cast<size_t>(col)];
      std::copy(rows.begin(), rows.end(), inner + first);
      const int c = m_free_dofs[static_cast<size_t>(col)];
      for (int k = h_outer[c]; k < h_outer[c + 1]; ++k) {
        const int r = m_index[h_inner[k]];
        if (r >= col) m_scatter[static_cast<size_t>(k)] = first + static_cast<int>(std::lower_bound(rows.begin(), rows.end(), r) - rows.begin());
      }
    }
    const int* inner_begin = inner;
    const int* inner_end = inner + m_reduced.nonZeros();
    if (!m_analysed || outer != m_outer || !std::equal(inner_begin, inner_end, m_inner.begin(), m_inner.end())) {
      m_factor->analyzePattern(m_reduced);
      m_outer = std::move(outer);
      m_inner.assign(inner_begin, inner_end);
      m_analysed = true;
      ++m_analyses;
      std::uint64_t h = fnv1a_bytes(kFnv1aOffset, m_fixed.data(), m_fixed.size());
      h = fnv1a_bytes(h, m_outer.data(), m_outer.size() * sizeof(int));
      m_pattern_fingerprint = fnv1a_bytes(h, m_inner.data(), m_inner.size() * sizeof(int));
    }
  }
  // The values: each entry of H at its position (each position receives at most one).
  double* values = m_reduced.valuePtr();
  std::fill(values, values + m_reduced.nonZeros(), 0.0);
  const double* h_values = source->valuePtr();
  for (std::size_t k = 0; k < m_scatter.size(); ++k)
    if (m_scatter[k] >= 0) values[m_scatter[k]] += h_values[k];
  ++m_factorisations;
  m_single_values.clear();  // the next preconditioning sweep copies this factorisation's values
  const int threads = team_size();
  const TeamSize team(threads);
  std::optional<SerialRegions> serial;
  if (threads == 1) serial.emplace();
  // |H_ii|, floored at 1e-12 of their mean: D of the shifts (found at the first shifted try).
  std::vector<double> diag;
  const int step = search_shift(m_first_shift_step, [&](int k) {
    if (k < 0) {
      m_factor->factorize(m_reduced);
    } else {
      if (diag.empty()) {
        diag.resize(static_cast<std::size_t>(free));
        double mean = 0;
        for (int i = 0; i < free; ++i) mean += (diag[i] = std::abs(m_reduced.coeff(i, i)));
        mean = free > 0 ? mean / free : 1.0;
        for (double& d : diag) d = std::max(d, 1e-12 * mean);
      }
      Eigen::SparseMatrix<double> shifted = m_reduced;
      for (int i = 0; i < free; ++i) shifted.coeffRef(i, i) += kShifts[k] * diag[i];
      m_factor->factorize(shifted);
    }
    return m_factor->info() == Eigen::Success;
  });
  m_factorised = step < kShiftSteps && m_factor->info() == Eigen::Success;
  m_shift_step = m_factorised ? step : -1;
  m_shift = m_shift_step < 0 ? 0.0 : kShifts[m_shift_step];
  m_first_shift_step = fascia::first_shift_step(m_shift_step);
  return m_factorised;
}

void SparseCholesky::set_first_shift_step(int k) {
  require_shifted_step(k);
  m_first_shift_step = k;
}

bool SparseCholesky::supernodal() const {
  const cholmod_factor* L = m_factor->factor();
  return L && L->is_super;
}

int SparseCholesky::team_size() const {
  const cholmod_factor* L = m_factor->factor();
  const bool large = L && L->is_super && L->nsuper > 0 &&
                     m_factor->cholmod().fl >= kParallelSupernodeFlops * static_cast<double>(L->nsuper);
  return large ? std::min(omp_get_max_threads(), kMaxFactorThreads) : 1;
}

void SparseCholesky::solve(const std::vector<double>& b, std::vector<double>& x, bool preconditioner) const {
  const int n = static_cast<int>(m_index.size()), free = static_cast<int>(m_free_dofs.size());
  const cholmod_factor* L = m_factor->factor();
  if (L && L->is_super && L->is_ll && L->xtype == CHOLMOD_REAL) {
    // L L^T = P H_ff P^T with P's rows Perm: y_k = b at the DOF of free index Perm[k], swept,
    // then put back there; fixed DOFs zero. The scratch is the thread's, kept between solves.
    const int* perm = static_cast<const int*>(L->Perm);
    thread_local std::vector<double> y, t;
    y.resize(static_cast<std::size_t>(free));
    t.resize(static_cast<std::size_t>(free));
    for (int k = 0; k < free; ++k) y[k] = b[m_free_dofs[perm[k]]];
    if (preconditioner && static_cast<double>(L->xsize) >= kSinglePrecisionSweepEntries) {
      if (m_single_values.empty()) {  // this factorisation's values in float, once
        const double* values = static_cast<const double*>(L->x);
        m_single_values.assign(values, values + L->xsize);
      }
      supernodal_solve(*L, m_single_values.data(), y.data(), t.data());
    } else {
      supernodal_solve(*L, y.data(), t.data());
    }
    x.resize(n);
    for (int k = 0; k < n; ++k)
      if (m_index[k] < 0) x[k] = 0.0;
    for (int k = 0; k < free; ++k) x[m_free_dofs[perm[k]]] = y[k];
    return;
  }
  Eigen::VectorXd rhs(free);
  for (int k = 0; k < free; ++k) rhs[k] = b[m_free_dofs[k]];
  {
    const TeamSize team(1);  // a simplicial factor: CHOLMOD's solve makes no BLAS calls
    rhs = m_factor->solve(rhs).eval();
  }
  x.assign(n, 0.0);
  for (int k = 0; k < free; ++k) x[m_free_dofs[k]] = rhs[k];
}

}  // namespace fascia
