#pragma once

// The patch solvers of FluxReconstruction, shared by its set-up
// (flux_reconstruction_setup.cc: reinit()) and its reconstruction
// (flux_reconstruction.cc): a private header of vi_common.

#include <deal.II/base/parallel.h>
#include <deal.II/lac/lapack_full_matrix.h>

#include <vi/flux_reconstruction.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace VI
{
  using namespace dealii;

  // body(i) for every i in [0, n), on the threads of MultithreadInfo in
  // ranges of at least `grainsize` indices: the loops of the set-up and the
  // reconstruction whose iterations are independent.
  template <typename Index, typename Body>
  void
  parallel_for_each(const Index        n,
                    const Body        &body,
                    const unsigned int grainsize)
  {
    parallel::apply_to_subranges(
      Index(0),
      n,
      [&](const Index begin, const Index end) {
        for (Index i = begin; i < end; ++i)
          body(i);
      },
      grainsize);
  }

  // The mixed patch problem, A sigma + B^T gamma = b, B sigma = g, in its
  // divergence-free form. B_{k,i} = (div tau_i, q_k) does not depend on the
  // geometry beyond the signs of the Piola transform and the hanging-node
  // weights, so a few distinct B serve a whole mesh: for each, an SVD gives
  // an orthonormal basis Z of the fluxes of the patch with zero divergence
  // (and zero normal trace where prescribed) and the pseudo-inverse B^+.
  // Then sigma = B^+ g + Z y with (Z^T A Z) y = Z^T (b - A B^+ g): the
  // minimiser of the energy among the fluxes with divergence g. For an
  // interior patch B has the constants in its left kernel (the flux through
  // the patch boundary is zero) and g is compatible, (g, 1) = 0, when the
  // data satisfy the discrete equations, as in the mixed problem with its
  // mean-value condition; gamma is not needed. Per patch this costs the
  // Cholesky factor of Z^T A Z, of order dim ker B (9 for an interior Q1
  // patch, against an LU factorisation of order 41 for the saddle-point
  // matrix), and each solve a few small matrix-vector products: B^+ g,
  // Z^T A B^+ g (see LocalSolver), Z^T b, the triangular solves and Z y.
  template <int dim>
  struct FluxReconstruction<dim>::DivergenceBasis
  {
    unsigned int        n_sigma = 0, n_q = 0, n_free = 0;
    std::vector<double> kernel;         ///< Z, n_sigma x n_free, by columns
    std::vector<double> pseudo_inverse; ///< B^+, n_sigma x n_q, by columns

    /// From B, row-major (n_q rows of n_sigma).
    DivergenceBasis(const unsigned int         n_sigma,
                    const unsigned int         n_q,
                    const std::vector<double> &B)
        : n_sigma(n_sigma)
        , n_q(n_q)
    {
      LAPACKFullMatrix<double> matrix(n_q, n_sigma);
      for (unsigned int k = 0; k < n_q; ++k)
        for (unsigned int i = 0; i < n_sigma; ++i)
          matrix(k, i) = B[k * n_sigma + i];
      matrix.compute_svd();
      const LAPACKFullMatrix<double> &U  = matrix.get_svd_u(),
                                     &VT = matrix.get_svd_vt();
      // The rank: B has entries of order one, its zero singular values are
      // round-off.
      const unsigned int n_singular = std::min(n_q, n_sigma);
      unsigned int       rank       = 0;
      while (rank < n_singular &&
             matrix.singular_value(rank) > 1e-10 * matrix.singular_value(0))
        ++rank;
      // Onto Q_p of the patch, or onto its mean-zero part for an interior
      // patch (the constants are the left kernel); anything smaller means
      // a degenerate patch.
      AssertThrow(rank + 1 >= n_q,
                  ExcMessage("Flux reconstruction: the divergence of the "
                             "Raviart-Thomas fluxes of a patch has rank " +
                             std::to_string(rank) + " on " +
                             std::to_string(n_q) +
                             " moments; at least all but one are needed."));
      n_free = n_sigma - rank;
      kernel.resize(n_sigma * n_free);
      for (unsigned int j = 0; j < n_free; ++j)
        for (unsigned int i = 0; i < n_sigma; ++i)
          kernel[j * n_sigma + i] = VT(rank + j, i);
      pseudo_inverse.assign(n_sigma * n_q, 0.);
      for (unsigned int r = 0; r < rank; ++r)
        {
          const double inverse = 1. / matrix.singular_value(r);
          for (unsigned int k = 0; k < n_q; ++k)
            for (unsigned int i = 0; i < n_sigma; ++i)
              pseudo_inverse[k * n_sigma + i] += VT(r, i) * inverse * U(k, r);
        }
    }
  };


  // How the cells of a patch connect to its unknowns: local RT dof k of the
  // patch's cell c contributes to the (sigma^a index, weight) pairs
  // sigma_entries[sigma_start[c (n_tau + 1) + k]] ...
  // sigma_entries[sigma_start[c (n_tau + 1) + k + 1] - 1] (one pair of
  // weight 1 for a free dof, the constraint's entries for a dof on a
  // hanging face, none for a dof fixed to zero), and its moments are the
  // Q_p indices c n_q ... (c + 1) n_q - 1. These maps and the cells'
  // Piola signs determine the divergence block B, whose basis the layout
  // holds. A layout depends on the connectivity, the hanging faces and the
  // signs only: a few serve a whole mesh, curved or not.
  //
  // With the cells' metrics G_c = J_c^T J_c / det J_c (J_c the mean
  // Jacobian of the patch's cell c), the patch energy is A = sum_c E_c^T
  // S_c (sum_m G_c,m M^_m) S_c E_c, E_c the expansion into the cell's
  // dofs, S_c its signs (`signs`, n_tau per cell), M^_m the reference
  // products. So Z^T A Z and Z^T A B^+ are the sums of G_c,m P_c,m and
  // G_c,m Q_c,m with P_c,m = (S_c E_c Z)^T M^_m (S_c E_c Z) (packed lower
  // triangle) and Q_c,m = (S_c E_c Z)^T M^_m (S_c E_c B^+) (n_free x n_q by
  // rows), which the layout keeps in `energy`, block (c n_metric + m).
  template <int dim>
  struct FluxReconstruction<dim>::PatchLayout
  {
    unsigned int                                 n_cells = 0, n_sigma = 0;
    std::vector<unsigned int>                    sigma_start;
    std::vector<std::pair<unsigned int, double>> sigma_entries;
    std::vector<std::int8_t>                     signs;
    std::shared_ptr<const DivergenceBasis>       basis;
    std::vector<double>                          energy;

    unsigned int
    n_packed() const
    {
      return basis->n_free * (basis->n_free + 1) / 2;
    }

    unsigned int
    n_products() const
    {
      return basis->n_free * basis->n_q;
    }

    unsigned int
    energy_block() const
    {
      return n_packed() + n_products();
    }

    /// sum_c,m G_c,m (P_c,m or Q_c,m) for the cells' metrics G: the n
    /// numbers of each energy block from `offset` on (0 and n_packed()
    /// for P, n_packed() and n_products() for Q).
    void
    combine(const double      *metrics,
            const unsigned int offset,
            const unsigned int n,
            double            *sum) const
    {
      std::fill_n(sum, n, 0.);
      for (unsigned int c = 0; c < n_cells; ++c)
        for (unsigned int m = 0; m < n_metric; ++m)
          {
            const double  G = metrics[c * n_metric + m];
            const double *block =
              &energy[(std::size_t(c) * n_metric + m) * energy_block() +
                      offset];
            for (unsigned int i = 0; i < n; ++i)
              sum[i] += G * block[i];
          }
    }
  };


  // A patch's energy, once per mesh and patch metrics: its cells' metrics
  // (n_metric numbers per cell) and the Cholesky factor L of Z^T A Z (its
  // rows, packed), one after the other in solver_storage. The reduced
  // problem's right-hand side needs Z^T A B^+ g: the first reconstruction
  // on a mesh computes it cell by cell, A B^+ g from the metrics, and
  // from the second on (a mesh whose fluxes are reconstructed often, at
  // the checks of an adaptive solve) C = Z^T A B^+ is kept
  // (keep_products()). C is n_free n_q numbers per patch, 144 for an
  // interior Q1 patch against 45 for L: kept on a mesh reconstructed once,
  // it would be the largest array of the reconstruction, and its memory
  // costs more to touch than its products save.
  template <int dim>
  struct FluxReconstruction<dim>::LocalSolver
  {
    std::shared_ptr<const PatchLayout> layout;
    double                            *metrics = nullptr; ///< in solver_storage
    /// C by rows (n_free x n_q), in product_storage, or none
    double *products = nullptr;

    /// L, right after the metrics
    double *
    cholesky() const
    {
      return metrics + std::size_t(layout->n_cells) * n_metric;
    }

    /// How many numbers of solver_storage a solver of `layout` holds.
    static std::size_t
    storage_size(const PatchLayout &layout)
    {
      return std::size_t(layout.n_cells) * n_metric + layout.n_packed();
    }

    /// Length of a right-hand side column: b (n_sigma), then g (n_q).
    unsigned int
    n() const
    {
      return layout->basis->n_sigma + layout->basis->n_q;
    }

    /// Overwrite the head of each of the n_columns columns (b, g) with
    /// sigma = B^+ g + Z y, (Z^T A Z) y = Z^T b - C g, C g = Z^T A B^+ g
    /// from the products or else from the cells' metrics and the nonzero
    /// entries of the reference products M^_m (`reference`); n_tau
    /// Raviart-Thomas dofs per cell.
    void
    solve(double                         *columns,
          const unsigned int              n_columns,
          const std::vector<MetricEntry> &reference,
          const unsigned int              n_tau,
          std::vector<double>            &work) const
    {
      const DivergenceBasis &basis   = *layout->basis;
      const unsigned int     n_sigma = basis.n_sigma, n_q = basis.n_q,
                         d  = basis.n_free;
      const double *const L = cholesky();
      work.resize(n_sigma + d + 2 * n_tau);
      double *const particular = work.data();
      double *const y          = particular + n_sigma;
      double *const v          = y + d; // a cell's part of B^+ g
      double *const Av         = v + n_tau;
      for (unsigned int c = 0; c < n_columns; ++c)
        {
          double *const       x = columns + std::size_t(c) * n();
          const double *const g = x + n_sigma;
          std::fill(particular, particular + n_sigma, 0.);
          for (unsigned int k = 0; k < n_q; ++k)
            {
              const double *column = &basis.pseudo_inverse[k * n_sigma];
              for (unsigned int i = 0; i < n_sigma; ++i)
                particular[i] += column[i] * g[k];
            }
          if (!products) // b - A B^+ g, then Z^T of it
            subtract_energy(x, particular, reference, n_tau, v, Av);
          for (unsigned int j = 0; j < d; ++j)
            {
              const double *z = &basis.kernel[j * n_sigma];
              double        t = 0;
              for (unsigned int i = 0; i < n_sigma; ++i)
                t += z[i] * x[i];
              if (products)
                for (unsigned int k = 0; k < n_q; ++k)
                  t -= products[j * n_q + k] * g[k];
              y[j] = t;
            }
          // L (row j from j (j + 1) / 2 on) and L^T
          for (unsigned int j = 0; j < d; ++j)
            {
              const double *row = L + j * (j + 1) / 2;
              for (unsigned int m = 0; m < j; ++m)
                y[j] -= row[m] * y[m];
              y[j] /= row[j];
            }
          for (unsigned int j = d; j-- > 0;)
            {
              for (unsigned int m = j + 1; m < d; ++m)
                y[j] -= L[m * (m + 1) / 2 + j] * y[m];
              y[j] /= L[j * (j + 1) / 2 + j];
            }
          for (unsigned int j = 0; j < d; ++j)
            {
              const double *z = &basis.kernel[j * n_sigma];
              for (unsigned int i = 0; i < n_sigma; ++i)
                particular[i] += z[i] * y[j];
            }
          std::copy_n(particular, n_sigma, x);
        }
    }

    /// x -= A p, cell by cell: A = sum_K E_K^T S_K (sum_m G_K,m M^_m) S_K
    /// E_K; v and Av have room for a cell's dofs.
    void
    subtract_energy(double                         *x,
                    const double                   *p,
                    const std::vector<MetricEntry> &reference,
                    const unsigned int              n_tau,
                    double *const                   v,
                    double *const                   Av) const
    {
      const auto *entries = layout->sigma_entries.data();
      for (unsigned int K = 0; K < layout->n_cells; ++K)
        {
          const unsigned int *start = &layout->sigma_start[K * (n_tau + 1)];
          const std::int8_t  *s     = &layout->signs[K * n_tau];
          const double       *G     = &metrics[K * n_metric];
          for (unsigned int i = 0; i < n_tau; ++i)
            {
              double value = 0;
              for (unsigned int e = start[i]; e < start[i + 1]; ++e)
                value += entries[e].second * p[entries[e].first];
              v[i]  = s[i] * value;
              Av[i] = 0;
            }
          for (const MetricEntry &entry : reference)
            Av[entry.i] += G[entry.m] * entry.value * v[entry.j];
          for (unsigned int i = 0; i < n_tau; ++i)
            {
              const double value = s[i] * Av[i];
              for (unsigned int e = start[i]; e < start[i + 1]; ++e)
                x[entries[e].first] -= entries[e].second * value;
            }
        }
    }
  };
} // namespace VI
