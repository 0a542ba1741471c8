#include <deal.II/base/geometry_info.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/partitioner.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/la_parallel_vector.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/flux_reconstruction.h>
#include <vi/piola_divergence.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <boost/serialization/utility.hpp>
#include <boost/serialization/vector.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <numeric>

namespace VI
{
  using namespace dealii;

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


  template <int dim>
  FluxReconstruction<dim>::FluxReconstruction(
    const Mapping<dim> &mapping,
    const unsigned int  degree,
    const unsigned int  potential_degree)
      : mapping(mapping)
      , fe_flux(degree)
      , fe_divergence(degree)
      , fe_hat(1)
      , quadrature(quadrature_points(
          potential_degree == numbers::invalid_unsigned_int ? degree :
                                                              potential_degree))
  {
    AssertThrow(potential_degree == numbers::invalid_unsigned_int ||
                  potential_degree >= degree,
                ExcMessage("the flux degree exceeds the potential's"));
    // Q_p and the divergence moments on the reference cell: the values of
    // FE_DGQ do not depend on the cell, and (div tau_i, q_k)_K = s_i
    // (div^ tau^_i, q^_k) (see PiolaDivergence).
    const unsigned int n_tau = fe_flux.n_dofs_per_cell(),
                       n_q   = fe_divergence.n_dofs_per_cell();
    const PiolaDivergence<dim> divergence(fe_flux, quadrature);
    q_reference.resize(quadrature.size() * n_q);
    divergence_reference.assign(n_q * n_tau, 0.);
    weighted_flux_reference.resize(quadrature.size() * n_tau * dim);
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      for (unsigned int i = 0; i < n_tau; ++i)
        for (unsigned int d = 0; d < dim; ++d)
          weighted_flux_reference[(q * n_tau + i) * dim + d] =
            fe_flux.shape_value_component(i, quadrature.point(q), d) *
            quadrature.weight(q);
    // int tau^_i^a tau^_j^b on the reference cell (exact: the rule has at
    // least p + 3 points per direction), symmetrised for a < b
    metric_reference.assign(n_metric * n_tau * n_tau, 0.);
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      {
        const double *tau   = &weighted_flux_reference[q * n_tau * dim];
        const double  scale = 1. / quadrature.weight(q);
        unsigned int  m     = 0;
        for (unsigned int a = 0; a < dim; ++a)
          for (unsigned int b = a; b < dim; ++b, ++m)
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int j = 0; j < n_tau; ++j)
                metric_reference[(m * n_tau + i) * n_tau + j] +=
                  (tau[i * dim + a] * tau[j * dim + b] +
                   (a < b ? tau[i * dim + b] * tau[j * dim + a] : 0.)) *
                  scale;
      }
    // Their nonzero entries, for the patch solves (a Raviart-Thomas function
    // of a quadrilateral has one nonzero component: a quarter of the
    // entries of M^_m are nonzero, some of the others round-off).
    for (unsigned int m = 0; m < n_metric; ++m)
      for (unsigned int i = 0; i < n_tau; ++i)
        for (unsigned int j = 0; j < n_tau; ++j)
          if (const double value =
                metric_reference[(m * n_tau + i) * n_tau + j];
              value != 0.)
            metric_entries.push_back({m, i, j, value});
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      for (unsigned int k = 0; k < n_q; ++k)
        {
          const double q_k = fe_divergence.shape_value(k, quadrature.point(q));
          q_reference[q * n_q + k] = q_k;
          for (unsigned int i = 0; i < n_tau; ++i)
            divergence_reference[k * n_tau + i] +=
              divergence.reference_divergence(i, q) * q_k *
              quadrature.weight(q);
        }
  }


  template <int dim>
  unsigned int
  FluxReconstruction<dim>::quadrature_points(const unsigned int degree)
  {
    return degree + 3 + (degree + 3) % 2;
  }


  template <int dim>
  FluxReconstruction<dim>::~FluxReconstruction()
  {
    dof_handler.clear();
  }


  // What a patch needs to know of one of its cells, computed by the cell's
  // owner: its center (which orders the cells of a patch), how its
  // Raviart-Thomas dofs expand across hanging faces (the constraint's
  // entries, or the dof itself), the Piola signs of those dofs, its metric
  // J^T J / det J and the integrals (phi_v, q_k)_K of the Q1 shape functions
  // phi_v against Q_p. The rank that solves a patch needs nothing else of a
  // cell, so it need not see it.
  template <int dim>
  struct FluxReconstruction<dim>::CellData
  {
    double                    center[dim] = {};
    std::vector<unsigned int> expansion_start; ///< per local dof, and the end
    std::vector<std::pair<types::global_dof_index, double>> expansion;
    std::vector<std::int8_t>                                signs;
    std::vector<double>                                     metric;
    std::vector<double> vertex_mass; ///< [v n_q + k]
    CellIterator        cell;        ///< on the owner only

    template <class Archive>
    void
    serialize(Archive &ar, const unsigned int)
    {
      ar &center &expansion_start &expansion &signs &metric &vertex_mass;
    }
  };


  // (patch, cell) pairs: share i says that psi_a of the patch numbered by
  // the degree of freedom patch[i] does not vanish on cells[cell[i]], with
  // the values hat[i n_v ... (i + 1) n_v - 1] at its vertices. What one
  // rank sends another.
  template <int dim>
  struct FluxReconstruction<dim>::Shares
  {
    static constexpr unsigned int n_v = GeometryInfo<dim>::vertices_per_cell;

    std::vector<CellData>                cells;
    std::vector<types::global_dof_index> patch;
    std::vector<unsigned int>            cell;
    std::vector<double>                  hat;

    void
    add(const types::global_dof_index j,
        const unsigned int            c,
        const double                 *values)
    {
      patch.push_back(j);
      cell.push_back(c);
      hat.insert(hat.end(), values, values + n_v);
    }

    template <class Archive>
    void
    serialize(Archive &ar, const unsigned int)
    {
      ar &cells &patch &cell &hat;
    }
  };


  template <int dim>
  void
  FluxReconstruction<dim>::reinit(const DoFHandler<dim> &potential)
  {
    const Triangulation<dim> &tria   = potential.get_triangulation();
    const MPI_Comm            comm   = potential.get_communicator();
    const unsigned int        rank   = Utilities::MPI::this_mpi_process(comm);
    const unsigned int        n_rank = Utilities::MPI::n_mpi_processes(comm);

    dof_handler.reinit(tria);
    dof_handler.distribute_dofs(fe_flux);
    owned_dofs = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);
    ghosted_fluxes.reinit(owned_dofs, relevant_dofs, comm);
    AffineConstraints<double> hanging_constraints(relevant_dofs);
    DoFTools::make_hanging_node_constraints(dof_handler, hanging_constraints);
    hanging_constraints.close();

    patches.clear();
    hat_masses.clear();
    memberships.assign(tria.n_active_cells(), {});
    n_sent.clear();
    received.clear();
    local_solvers.clear();
    product_storage.reset();
    n_reconstructions = 0;

    // The conforming hat functions: Q1 with its hanging node constraints,
    // one patch per unconstrained (regular) vertex, numbered by its degree
    // of freedom and solved by the owner of that degree of freedom (who
    // owns a cell at the vertex).
    DoFHandler<dim> hats(tria);
    hats.distribute_dofs(fe_hat);
    IndexSet relevant_hats;
    DoFTools::extract_locally_relevant_dofs(hats, relevant_hats);
    AffineConstraints<double> hat_constraints(relevant_hats);
    DoFTools::make_hanging_node_constraints(hats, hat_constraints);
    hat_constraints.close();

    constexpr unsigned int n_v   = GeometryInfo<dim>::vertices_per_cell;
    const unsigned int     n_tau = fe_flux.n_dofs_per_cell();
    const unsigned int     n_q   = fe_divergence.n_dofs_per_cell();
    // The Piola signs, for the patch layouts, the right-hand sides of
    // reconstruct() and the estimators, from the mesh (no Raviart-Thomas
    // FEValues, see PiolaDivergence::topological_signs).
    piola_signs.assign(std::size_t(tria.n_active_cells()) * n_tau, 0);
    cell_metric.assign(std::size_t(tria.n_active_cells()) * n_metric, 0.);

    // The data and shares of the owned cells, psi_j on a cell being the Q1
    // function with value 1 at the vertex of j and the constraint weights
    // at the hanging vertices that depend on j.
    Shares                                               mine;
    std::vector<typename DoFHandler<dim>::cell_iterator> owned_cells;
    for (const auto &hat_cell : hats.active_cell_iterators())
      if (hat_cell->is_locally_owned())
        owned_cells.push_back(hat_cell);
    mine.cells.resize(owned_cells.size());

    // The cells' data, on all threads (each cell writes its own entries).
    parallel::apply_to_subranges(
      std::size_t(0),
      owned_cells.size(),
      [&](const std::size_t begin, const std::size_t end) {
        // (The Jacobians from the Q1 element: in deal.II 9.4 an FEValues of
        // a Raviart-Thomas element that asks for mapping data only trips
        // over the face sign changes of unstructured meshes, deal.II PR
        // 15963.)
        FEValues<dim>                        hat_values(mapping,
                                 fe_hat,
                                 quadrature,
                                 update_values | update_jacobians |
                                   update_JxW_values);
        std::vector<types::global_dof_index> rt_dofs(n_tau);
        for (std::size_t c = begin; c < end; ++c)
          {
            const CellIterator cell(owned_cells[c]);
            CellData          &data = mine.cells[c];
            data.cell               = cell;
            for (unsigned int d = 0; d < dim; ++d)
              data.center[d] = cell->center()[d];
            typename DoFHandler<dim>::active_cell_iterator dof_cell(
              &tria, cell->level(), cell->index(), &dof_handler);
            dof_cell->get_dof_indices(rt_dofs);
            std::int8_t *const cell_signs =
              &piola_signs[cell->active_cell_index() * n_tau];
            PiolaDivergence<dim>::topological_signs(
              cell, fe_flux, ArrayView<std::int8_t>(cell_signs, n_tau));
            data.signs.assign(cell_signs, cell_signs + n_tau);
            for (unsigned int k = 0; k < n_tau; ++k)
              {
                data.expansion_start.push_back(data.expansion.size());
                if (hanging_constraints.is_constrained(rt_dofs[k]))
                  for (const auto &entry :
                       *hanging_constraints.get_constraint_entries(rt_dofs[k]))
                    data.expansion.push_back(entry);
                else
                  data.expansion.emplace_back(rt_dofs[k], 1.);
              }
            data.expansion_start.push_back(data.expansion.size());
            hat_values.reinit(cell);
            data.vertex_mass.assign(n_v * n_q, 0.);
            Tensor<2, dim> mean_jacobian;
            for (const unsigned int q : hat_values.quadrature_point_indices())
              {
                for (unsigned int v = 0; v < n_v; ++v)
                  for (unsigned int k = 0; k < n_q; ++k)
                    data.vertex_mass[v * n_q + k] +=
                      hat_values.shape_value(v, q) * q_reference[q * n_q + k] *
                      hat_values.JxW(q);
                mean_jacobian +=
                  quadrature.weight(q) * Tensor<2, dim>(hat_values.jacobian(q));
              }
            // G = J^T J / det J of the mean Jacobian (the jacobian of a
            // bilinear cell at its center)
            const Tensor<2, dim> G = transpose(mean_jacobian) * mean_jacobian /
                                     determinant(mean_jacobian);
            double *const metric =
              &cell_metric[cell->active_cell_index() * n_metric];
            for (unsigned int a = 0, m = 0; a < dim; ++a)
              for (unsigned int b = a; b < dim; ++b, ++m)
                metric[m] = G[a][b];
            data.metric.assign(metric, metric + n_metric);
          }
      },
      /*grainsize=*/1024);

    // The shares, in the order of the cells.
    // the vertex of each unconstrained hat, by its position in relevant_hats
    std::vector<unsigned int> vertex_of(relevant_hats.n_elements(),
                                        numbers::invalid_unsigned_int);
    std::vector<std::pair<types::global_dof_index, std::array<double, n_v>>>
      psi;
    for (std::size_t c = 0; c < owned_cells.size(); ++c)
      {
        const auto &hat_cell = owned_cells[c];
        psi.clear();
        for (const unsigned int v : hat_cell->vertex_indices())
          {
            const auto i   = hat_cell->vertex_dof_index(v, 0);
            const auto add = [&](const types::global_dof_index j,
                                 const double                  w) {
              auto entry =
                std::find_if(psi.begin(), psi.end(), [j](const auto &e) {
                  return e.first == j;
                });
              if (entry == psi.end())
                entry = psi.insert(psi.end(), {j, std::array<double, n_v>{}});
              entry->second[v] = w;
            };
            if (hat_constraints.is_constrained(i))
              for (const auto &[j, w] :
                   *hat_constraints.get_constraint_entries(i))
                add(j, w);
            else
              {
                add(i, 1.);
                vertex_of[relevant_hats.index_within_set(i)] =
                  hat_cell->vertex_index(v);
              }
          }
        for (const auto &[j, values] : psi)
          mine.add(j, c, values.data());
      }

    // The shares of patches solved elsewhere go to their ranks, with the
    // data of their cells; the others stay. The hats of the shares are all
    // in relevant_hats, whose order lists them sorted once marked (a sort
    // of one entry per share would cost more; IndexSet::add_index inserts
    // into a sorted list: sorted ranges go in at once).
    IndexSet patch_hats(hats.n_dofs());
    {
      std::vector<bool> marked(relevant_hats.n_elements(), false);
      for (const types::global_dof_index j : mine.patch)
        {
          const auto position = relevant_hats.index_within_set(j);
          AssertIndexRange(position, marked.size());
          marked[position] = true;
        }
      std::vector<types::global_dof_index> in_order;
      auto                                 hat = relevant_hats.begin();
      for (std::size_t k = 0; k < marked.size(); ++k, ++hat)
        if (marked[k])
          in_order.push_back(*hat);
      patch_hats.add_indices(in_order.begin(), in_order.end());
    }
    const std::vector<unsigned int> owners =
      Utilities::MPI::compute_index_owner(hats.locally_owned_dofs(),
                                          patch_hats,
                                          comm);
    std::map<unsigned int, Shares>                                outgoing;
    std::map<std::pair<unsigned int, unsigned int>, unsigned int> sent_cell;
    std::vector<unsigned int>                                     solved_here;
    for (unsigned int i = 0; i < mine.patch.size(); ++i)
      {
        const unsigned int owner =
          owners[patch_hats.index_within_set(mine.patch[i])];
        const double *hat = &mine.hat[i * n_v];
        if (owner == rank)
          {
            solved_here.push_back(i);
            continue;
          }
        Shares    &to   = outgoing[owner];
        CellData  &data = mine.cells[mine.cell[i]];
        const auto sent = sent_cell.emplace(std::make_pair(owner, mine.cell[i]),
                                            to.cells.size());
        if (sent.second)
          to.cells.push_back(data);
        to.add(mine.patch[i], sent.first->second, hat);
        Membership membership{owner, n_sent[owner]++, 0, {}};
        std::copy_n(hat, n_v, membership.hat.begin());
        memberships[data.cell->active_cell_index()].push_back(membership);
      }
    std::map<unsigned int, Shares> incoming;
    if (n_rank > 1)
      incoming = Utilities::MPI::some_to_some(comm, outgoing);
    outgoing.clear();

    // The shares solved here, grouped by patch in the order of the patch
    // dofs and, within a patch, by rank and index in that rank's Shares: a
    // counting sort on the positions of the patch dofs in relevant_hats
    // (where they all are: on cells here, or owned here).
    struct ShareHere
    {
      unsigned int from, index;
    };
    const auto for_each_share_here = [&](const auto &visit) {
      const auto visit_mine = [&]() {
        for (const unsigned int i : solved_here)
          visit(relevant_hats.index_within_set(mine.patch[i]), rank, i);
      };
      bool mine_visited = false;
      for (const auto &[from, shares] : incoming)
        {
          if (!mine_visited && from > rank)
            {
              visit_mine();
              mine_visited = true;
            }
          for (unsigned int i = 0; i < shares.patch.size(); ++i)
            visit(relevant_hats.index_within_set(shares.patch[i]), from, i);
        }
      if (!mine_visited)
        visit_mine();
    };
    std::vector<std::size_t> group_start(relevant_hats.n_elements() + 1, 0);
    for_each_share_here(
      [&](const std::size_t position, const unsigned int, const unsigned int) {
        ++group_start[position + 1];
      });
    std::partial_sum(group_start.begin(),
                     group_start.end(),
                     group_start.begin());
    std::vector<ShareHere> shares_here(group_start.back());
    {
      std::vector<std::size_t> next(group_start.begin(), group_start.end() - 1);
      for_each_share_here([&](const std::size_t  position,
                              const unsigned int from,
                              const unsigned int index) {
        shares_here[next[position]++] = {from, index};
      });
    }
    // the patches solved here, by the positions of their dofs
    std::vector<unsigned int> patches_here;
    for (unsigned int i = 0; i < relevant_hats.n_elements(); ++i)
      if (group_start[i + 1] > group_start[i])
        patches_here.push_back(i);
    for (const auto &[from, shares] : incoming)
      received[from].resize(shares.patch.size());

    // A cell's data are released after the last of its patches solved here
    // (or after sending, if it has none): what is held is the front of the
    // patch loop, not the mesh.
    std::vector<std::atomic<unsigned int>> pending(mine.cells.size());
    for (const unsigned int i : solved_here)
      pending[mine.cell[i]].fetch_add(1, std::memory_order_relaxed);
    const auto release = [&](CellData &data) {
      const CellIterator cell = data.cell;
      data                    = CellData();
      data.cell               = cell;
    };
    for (unsigned int c = 0; c < mine.cells.size(); ++c)
      if (pending[c].load(std::memory_order_relaxed) == 0)
        release(mine.cells[c]);

    // The patches, in chunks on all threads: per patch, its cells (data,
    // psi_a, where the share came from) in a canonical order, its unknowns,
    // their numbering and its layout. What a chunk finds is gathered after,
    // in the order of the patches, so that nothing depends on the threads.
    struct PatchChunk
    {
      std::vector<Patch> patches; ///< starts relative to the chunk
      std::vector<std::shared_ptr<const PatchLayout>> layouts;
      /// the global dofs of the patch unknowns as they are numbered, and
      /// those of them that are not relevant here
      std::vector<types::global_dof_index> dofs, beyond;
      /// per cell of each patch, in order: (psi_a, q_k)_K, the metric, and
      /// where its share came from
      std::vector<double>    hat_masses, metrics;
      std::vector<ShareHere> cells;
    };
    constexpr unsigned int  chunk_size = 1024;
    std::vector<PatchChunk> chunks((patches_here.size() + chunk_size - 1) /
                                   chunk_size);
    Layouts                 layouts; // shared by the patches of all chunks
    std::mutex              layouts_mutex;

    struct Member
    {
      std::pair<double, double> polar;
      const CellData           *data;
      const double             *hat;
      ShareHere                 share;
      bool
      operator<(const Member &other) const
      {
        return polar < other.polar;
      }
    };
    const auto process_chunks = [&](const std::size_t first_chunk,
                                    const std::size_t end_chunk) {
      std::vector<Member> members;
      // The free dofs of the current patch and their numbers (unnumbered
      // until first met): a patch has a few dozen.
      constexpr unsigned int not_free   = numbers::invalid_unsigned_int;
      constexpr unsigned int unnumbered = not_free - 1;
      std::vector<std::pair<types::global_dof_index, unsigned int>> free_dofs;
      const auto find_free = [&](const types::global_dof_index g) {
        return std::find_if(free_dofs.begin(),
                            free_dofs.end(),
                            [g](const auto &entry) {
                              return entry.first == g;
                            });
      };
      std::vector<bool>                is_free(n_tau);
      std::vector<std::int64_t>        layout_key;
      std::vector<const std::int8_t *> signs_of_cells;
      PatchLayout                      layout; // of the current patch
      Layouts                          cache;

      for (std::size_t ch = first_chunk; ch < end_chunk; ++ch)
        {
          PatchChunk       &chunk = chunks[ch];
          const std::size_t end_patch =
            std::min<std::size_t>((ch + 1) * chunk_size, patches_here.size());
          // (the positions without patches have no shares)
          const std::size_t n_patches = end_patch - ch * chunk_size,
                            n_cells =
                              group_start[patches_here[end_patch - 1] + 1] -
                              group_start[patches_here[ch * chunk_size]];
          chunk.patches.reserve(n_patches);
          chunk.layouts.reserve(n_patches);
          chunk.hat_masses.reserve(n_cells * n_q);
          chunk.metrics.reserve(n_cells * n_metric);
          chunk.cells.reserve(n_cells);
          for (std::size_t p = ch * chunk_size; p < end_patch; ++p)
            {
              const unsigned int position = patches_here[p];
              const unsigned int a        = vertex_of[position];
              Patch              patch;
              patch.vertex          = a;
              patch.dofs_start      = chunk.dofs.size();
              patch.hat_mass        = nullptr; // (set once the chunk is done)
              const Point<dim> &x_a = tria.get_vertices()[a];

              // Cells in a canonical order (by angle around a, then
              // distance), so that patches of the same shape get the same
              // local numbering.
              members.clear();
              for (std::size_t s = group_start[position];
                   s < group_start[position + 1];
                   ++s)
                {
                  const ShareHere share = shares_here[s];
                  const Shares   &shares =
                    share.from == rank ? mine : incoming.at(share.from);
                  Member member;
                  member.data  = &shares.cells[shares.cell[share.index]];
                  member.hat   = &shares.hat[share.index * n_v];
                  member.share = share;
                  Tensor<1, dim> d;
                  for (unsigned int k = 0; k < dim; ++k)
                    d[k] = member.data->center[k] - x_a[k];
                  member.polar = {std::atan2(d[1], d[0]), d.norm()};
                  members.push_back(member);
                }
              std::sort(members.begin(), members.end());

              // The free fluxes: the dofs on faces where psi_a does not
              // vanish (the others carry sigma^a . n = 0), or their parents
              // on the coarse side of a hanging face; and the dofs inside
              // the cells. They are marked, then numbered as first met in
              // the cells' order.
              free_dofs.clear();
              for (const Member &member : members)
                {
                  std::fill(is_free.begin(), is_free.end(), true);
                  for (const unsigned int f : GeometryInfo<dim>::face_indices())
                    {
                      bool nonzero = false;
                      for (unsigned int w = 0;
                           w < GeometryInfo<dim>::vertices_per_face;
                           ++w)
                        nonzero |=
                          member.hat[GeometryInfo<dim>::face_to_cell_vertices(
                            f, w)] != 0.;
                      for (unsigned int i = 0; i < fe_flux.n_dofs_per_face(f);
                           ++i)
                        is_free[fe_flux.face_to_cell_index(i, f)] = nonzero;
                    }
                  for (unsigned int k = 0; k < n_tau; ++k)
                    if (is_free[k])
                      for (unsigned int e = member.data->expansion_start[k];
                           e < member.data->expansion_start[k + 1];
                           ++e)
                        {
                          const types::global_dof_index g =
                            member.data->expansion[e].first;
                          if (find_free(g) == free_dofs.end())
                            free_dofs.emplace_back(g, unnumbered);
                        }
                }
              // sigma^a's unknowns are the free dofs, numbered as first met.
              const auto local_number = [&](const types::global_dof_index g) {
                const auto entry = find_free(g);
                if (entry == free_dofs.end())
                  return not_free;
                if (entry->second == unnumbered)
                  {
                    entry->second = chunk.dofs.size() - patch.dofs_start;
                    chunk.dofs.push_back(g);
                    if (!relevant_dofs.is_element(g))
                      chunk.beyond.push_back(g);
                  }
                return entry->second;
              };
              layout.n_cells = members.size();
              layout.sigma_start.clear();
              layout.sigma_entries.clear();
              signs_of_cells.clear();
              for (const Member &member : members)
                {
                  for (unsigned int k = 0; k < n_tau; ++k)
                    {
                      layout.sigma_start.push_back(layout.sigma_entries.size());
                      for (unsigned int e = member.data->expansion_start[k];
                           e < member.data->expansion_start[k + 1];
                           ++e)
                        {
                          const auto &[g, w]   = member.data->expansion[e];
                          const unsigned int I = local_number(g);
                          if (I != not_free)
                            layout.sigma_entries.emplace_back(I, w);
                        }
                    }
                  layout.sigma_start.push_back(layout.sigma_entries.size());
                  const std::size_t start = chunk.hat_masses.size();
                  chunk.hat_masses.resize(start + n_q, 0.);
                  for (unsigned int v = 0; v < n_v; ++v)
                    for (unsigned int k = 0; k < n_q; ++k)
                      chunk.hat_masses[start + k] +=
                        member.hat[v] * member.data->vertex_mass[v * n_q + k];
                  chunk.metrics.insert(chunk.metrics.end(),
                                       member.data->metric.begin(),
                                       member.data->metric.end());
                  chunk.cells.push_back(member.share);
                  signs_of_cells.push_back(member.data->signs.data());
                }
              layout.n_sigma = chunk.dofs.size() - patch.dofs_start;
              chunk.layouts.push_back(shared_layout(layout,
                                                    signs_of_cells,
                                                    cache,
                                                    layouts,
                                                    layouts_mutex,
                                                    layout_key));
              chunk.patches.push_back(std::move(patch));

              for (const Member &member : members)
                if (member.share.from == rank)
                  {
                    const unsigned int c = mine.cell[member.share.index];
                    if (pending[c].fetch_sub(1, std::memory_order_acq_rel) == 1)
                      release(mine.cells[c]);
                  }
            }
        }
    };
    parallel::apply_to_subranges(std::size_t(0),
                                 chunks.size(),
                                 process_chunks,
                                 /*grainsize=*/1);

    // In the order of the patches: their solvers, shared between patches
    // of the same layout and metrics, and their cells' parts. On curved or
    // perturbed meshes no two patches have the same metrics: once the
    // first patches show that, solvers are no longer looked up (the
    // metrics are invariant under scaling, so on uniformly refined meshes
    // a few solvers serve every level).
    std::unordered_map<std::vector<std::int64_t>,
                       std::shared_ptr<const LocalSolver>,
                       KeyHash>
                                         solvers;
    bool                                 share_solvers = true;
    constexpr unsigned int               sharing_trial = 1000;
    std::vector<std::int64_t>            key;
    std::map<unsigned int, unsigned int> n_received;
    // The new solvers, made (when not shared) and factorised after the
    // loop on all cores: the patch, its layout and its cells' metrics.
    struct NewSolver
    {
      std::size_t                               patch;
      LocalSolver                              *shared; ///< or to be made
      const std::shared_ptr<const PatchLayout> *layout;
      const double                             *metrics;
      std::size_t                               storage_start = 0;
    };
    std::vector<NewSolver>   new_solvers;
    std::vector<std::size_t> dofs_offset(chunks.size() + 1, 0);
    patches.reserve(patches_here.size());
    for (std::size_t ch = 0; ch < chunks.size(); ++ch)
      {
        const PatchChunk &chunk = chunks[ch];
        dofs_offset[ch + 1]     = dofs_offset[ch] + chunk.dofs.size();
        std::size_t first_cell  = 0;
        for (std::size_t i = 0; i < chunk.patches.size(); ++i)
          {
            Patch patch = chunk.patches[i];
            patch.dofs_start += dofs_offset[ch];
            patch.hat_mass = &chunk.hat_masses[first_cell * n_q];
            const std::shared_ptr<const PatchLayout> &layout = chunk.layouts[i];
            const double *metrics = &chunk.metrics[first_cell * n_metric];

            if (share_solvers && patches.size() == sharing_trial &&
                new_solvers.size() > patches.size() / 2)
              {
                share_solvers = false;
                solvers.clear();
              }
            if (share_solvers)
              {
                key.assign({reinterpret_cast<std::intptr_t>(layout.get())});
                for (unsigned int m = 0; m < layout->n_cells * n_metric; ++m)
                  key.push_back(std::llround(metrics[m] * 1e9));
                std::shared_ptr<const LocalSolver> &solver = solvers[key];
                if (!solver)
                  {
                    // made here, to be shared; factorised below
                    auto created    = std::make_shared<LocalSolver>();
                    created->layout = layout;
                    new_solvers.push_back(
                      {patches.size(), created.get(), &layout, metrics});
                    solver = std::move(created);
                  }
                patch.solver = solver;
              }
            else
              {
                new_solvers.push_back(
                  {patches.size(), nullptr, &layout, metrics});
              }

            // Where the right-hand sides of the cells come from.
            const unsigned int patch_number = patches.size();
            for (unsigned int c = 0; c < layout->n_cells; ++c)
              {
                const auto [from, index] = chunk.cells[first_cell + c];
                if (from == rank)
                  {
                    Membership membership{rank, patch_number, c, {}};
                    std::copy_n(&mine.hat[index * n_v],
                                n_v,
                                membership.hat.begin());
                    memberships[mine.cells[mine.cell[index]]
                                  .cell->active_cell_index()]
                      .push_back(membership);
                  }
                else
                  {
                    // a rank computes the right-hand sides of the shares it
                    // sent in the order it sent them
                    received[from][index] = {patch_number, c};
                    ++n_received[from];
                  }
              }
            first_cell += layout->n_cells;
            patches.push_back(std::move(patch));
          }
      }
    // The metrics and factors of all new solvers in one array (0.35 GB on
    // 7.9e5 Q1 patches), first touched on the threads that factorise: one
    // large allocation, which glibc maps in huge pages when asked to
    // (README.md), instead of a vector per patch from the threads' heaps.
    std::size_t storage_size = 0;
    for (NewSolver &job : new_solvers)
      {
        job.storage_start = storage_size;
        storage_size += LocalSolver::storage_size(**job.layout);
      }
    solver_storage.reset(new double[storage_size]);
    local_solvers.resize(new_solvers.size());
    parallel::apply_to_subranges(
      std::size_t(0),
      new_solvers.size(),
      [&](const std::size_t begin, const std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
          {
            const NewSolver             &job    = new_solvers[i];
            LocalSolver                 *solver = job.shared;
            std::shared_ptr<LocalSolver> created;
            if (!solver)
              {
                created         = std::make_shared<LocalSolver>();
                created->layout = *job.layout;
                solver          = created.get();
              }
            solver->metrics = &solver_storage[job.storage_start];
            std::copy_n(job.metrics,
                        solver->layout->n_cells * n_metric,
                        solver->metrics);
            factorise(*solver);
            local_solvers[i] = solver;
            if (created)
              patches[job.patch].solver = std::move(created);
          }
      },
      /*grainsize=*/256);
    for (PatchChunk &chunk : chunks)
      {
        chunk.metrics = std::vector<double>();
        chunk.cells   = std::vector<ShareHere>();
        chunk.layouts = std::vector<std::shared_ptr<const PatchLayout>>();
      }
    for (const auto &[from, shares] : incoming)
      AssertThrow(n_received[from] == shares.patch.size(),
                  ExcMessage("Flux reconstruction: a cell share sent to this "
                             "process belongs to no patch solved here."));
    // Where the fluxes are summed: the owned dofs, and as ghosts the
    // relevant ones (the patches' and the constraints' dofs) and, with
    // hanging nodes in parallel, a few beyond that patches solved here
    // write; the patch unknowns as local indices there, and their cells'
    // (psi_a, q_k)_K, gathered from the chunks.
    std::vector<types::global_dof_index> beyond;
    for (const PatchChunk &chunk : chunks)
      beyond.insert(beyond.end(), chunk.beyond.begin(), chunk.beyond.end());
    std::sort(beyond.begin(), beyond.end());
    beyond.erase(std::unique(beyond.begin(), beyond.end()), beyond.end());
    IndexSet writable_dofs = relevant_dofs;
    writable_dofs.add_indices(beyond.begin(), beyond.end());
    writable_dofs.compress();
    const auto partitioner =
      std::make_shared<Utilities::MPI::Partitioner>(owned_dofs,
                                                    writable_dofs,
                                                    comm);
    flux_partitioner = partitioner;
    patch_positions.resize(dofs_offset.back());
    hat_masses.resize(chunks.size());
    parallel::apply_to_subranges(
      std::size_t(0),
      chunks.size(),
      [&](const std::size_t first_chunk, const std::size_t end_chunk) {
        for (std::size_t ch = first_chunk; ch < end_chunk; ++ch)
          {
            PatchChunk &chunk = chunks[ch];
            for (std::size_t i = 0; i < chunk.dofs.size(); ++i)
              patch_positions[dofs_offset[ch] + i] =
                partitioner->global_to_local(chunk.dofs[i]);
            // (moved: the patches point into them)
            hat_masses[ch] = std::move(chunk.hat_masses);
            chunk          = PatchChunk();
          }
      },
      /*grainsize=*/1);
    // The constraints of the owned dofs (the others are the owners'); their
    // entries, on the coarse side of the face, are relevant.
    constrained_dofs.clear();
    constraint_start.assign(1, 0);
    constraint_entries.clear();
    for (const auto &line : hanging_constraints.get_lines())
      if (owned_dofs.is_element(line.index))
        {
          constrained_dofs.push_back(partitioner->global_to_local(line.index));
          for (const auto &[g, w] : line.entries)
            {
              Assert(writable_dofs.is_element(g), ExcInternalError());
              constraint_entries.emplace_back(partitioner->global_to_local(g),
                                              w);
            }
          constraint_start.push_back(constraint_entries.size());
        }
    cells_with_shares.clear();
    for (const auto &cell : tria.active_cell_iterators())
      if (cell->is_locally_owned() &&
          !memberships[cell->active_cell_index()].empty())
        cells_with_shares.push_back(cell);
    hats.clear();
  }


  // The layout of the patch's connectivity and Piola signs, which
  // determine B: new ones get the divergence basis of B and the energy
  // products P_c,m and Q_c,m (see PatchLayout).
  template <int dim>
  std::shared_ptr<const typename FluxReconstruction<dim>::PatchLayout>
  FluxReconstruction<dim>::shared_layout(
    const PatchLayout                      &layout,
    const std::vector<const std::int8_t *> &signs,
    Layouts                                &cache,
    Layouts                                &layouts,
    std::mutex                             &mutex,
    std::vector<std::int64_t>              &key) const
  {
    const unsigned int n_tau   = fe_flux.n_dofs_per_cell(),
                       n_q_K   = fe_divergence.n_dofs_per_cell();
    const unsigned int n_sigma = layout.n_sigma;
    const unsigned int n_q     = layout.n_cells * n_q_K;
    const auto        &entries = layout.sigma_entries;
    key.assign({layout.n_cells, n_sigma});
    key.insert(key.end(), layout.sigma_start.begin(), layout.sigma_start.end());
    for (const auto &[I, w] : entries)
      {
        key.push_back(I);
        // (the constraint weights are the element's: equal weights have
        // equal bits)
        std::int64_t bits;
        std::memcpy(&bits, &w, sizeof bits);
        key.push_back(bits);
      }
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      key.insert(key.end(), signs[c], signs[c] + n_tau);
    auto &cached = cache[key];
    if (cached)
      return cached;
    const std::lock_guard<std::mutex> lock(mutex);
    auto                             &shared = layouts[key];
    if (shared)
      {
        cached = shared;
        return cached;
      }

    std::vector<double> B(n_q * n_sigma, 0.);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      {
        const auto *start = &layout.sigma_start[c * (n_tau + 1)];
        for (unsigned int i = 0; i < n_tau; ++i)
          for (unsigned int e = start[i]; e < start[i + 1]; ++e)
            for (unsigned int k = 0; k < n_q_K; ++k)
              B[(c * n_q_K + k) * n_sigma + entries[e].first] +=
                entries[e].second *
                (signs[c][i] * divergence_reference[k * n_tau + i]);
      }
    auto new_layout = std::make_shared<PatchLayout>(layout);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      new_layout->signs.insert(new_layout->signs.end(),
                               signs[c],
                               signs[c] + n_tau);
    new_layout->basis =
      std::make_shared<const DivergenceBasis>(n_sigma, n_q, B);
    const DivergenceBasis &basis    = *new_layout->basis;
    const unsigned int     d        = basis.n_free;
    const unsigned int     n_packed = new_layout->n_packed();
    const unsigned int     n_block  = new_layout->energy_block();
    new_layout->energy.assign(std::size_t(layout.n_cells) * n_metric * n_block,
                              0.);

    // Per cell: SZ = S_c E_c Z (n_tau x d) and SB = S_c E_c B^+ (n_tau x
    // n_q), by rows; then per metric entry T = M^_m SZ and the products.
    std::vector<double> SZ(n_tau * d), SB(n_tau * n_q), T(n_tau * d);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      {
        std::fill(SZ.begin(), SZ.end(), 0.);
        std::fill(SB.begin(), SB.end(), 0.);
        const auto *start = &layout.sigma_start[c * (n_tau + 1)];
        for (unsigned int i = 0; i < n_tau; ++i)
          for (unsigned int e = start[i]; e < start[i + 1]; ++e)
            {
              const auto   I = entries[e].first;
              const double w = entries[e].second * signs[c][i];
              for (unsigned int j = 0; j < d; ++j)
                SZ[i * d + j] += w * basis.kernel[j * n_sigma + I];
              for (unsigned int k = 0; k < n_q; ++k)
                SB[i * n_q + k] += w * basis.pseudo_inverse[k * n_sigma + I];
            }
        for (unsigned int m = 0; m < n_metric; ++m)
          {
            const double *M = &metric_reference[m * n_tau * n_tau];
            std::fill(T.begin(), T.end(), 0.);
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int l = 0; l < n_tau; ++l)
                if (const double M_il = M[i * n_tau + l]; M_il != 0.)
                  for (unsigned int j = 0; j < d; ++j)
                    T[i * d + j] += M_il * SZ[l * d + j];
            double *const P =
              &new_layout->energy[(std::size_t(c) * n_metric + m) * n_block];
            double *const Q = P + n_packed;
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int j = 0; j < d; ++j)
                {
                  const double t = T[i * d + j];
                  for (unsigned int l = 0; l <= j; ++l)
                    P[j * (j + 1) / 2 + l] += t * SZ[i * d + l];
                  for (unsigned int k = 0; k < n_q; ++k)
                    Q[j * n_q + k] += t * SB[i * n_q + k];
                }
          }
      }
    shared = new_layout;
    cached = shared;
    return cached;
  }


  // The patch energy on the divergence-free fluxes from the cells'
  // metrics: Z^T A Z = sum G_c,m P_c,m = L L^T.
  template <int dim>
  void
  FluxReconstruction<dim>::factorise(LocalSolver &solver) const
  {
    const PatchLayout &layout = *solver.layout;
    const unsigned int d      = layout.basis->n_free;
    double *const      L      = solver.cholesky();
    layout.combine(solver.metrics, 0, layout.n_packed(), L);
    // Cholesky in place, row by row of the packed lower triangle.
    for (unsigned int j = 0; j < d; ++j)
      {
        double *const row_j = L + j * (j + 1) / 2;
        for (unsigned int m = 0; m <= j; ++m)
          {
            const double *const row_m = L + m * (m + 1) / 2;
            double              value = row_j[m];
            for (unsigned int r = 0; r < m; ++r)
              value -= row_j[r] * row_m[r];
            if (m < j)
              row_j[m] = value / row_m[m];
            else
              {
                AssertThrow(value > 0.,
                            ExcMessage("Flux reconstruction: the energy of a "
                                       "patch is not positive definite on "
                                       "its divergence-free fluxes (a "
                                       "degenerate cell?)."));
                row_j[j] = std::sqrt(value);
              }
          }
      }
  }


  // C = Z^T A B^+ = sum G_c,m Q_c,m of every solver, in one array.
  template <int dim>
  void
  FluxReconstruction<dim>::keep_products() const
  {
    std::vector<std::size_t> start(local_solvers.size() + 1, 0);
    for (std::size_t s = 0; s < local_solvers.size(); ++s)
      start[s + 1] = start[s] + local_solvers[s]->layout->n_products();
    product_storage.reset(new double[start.back()]);
    parallel::apply_to_subranges(
      std::size_t(0),
      local_solvers.size(),
      [&](const std::size_t begin, const std::size_t end) {
        for (std::size_t s = begin; s < end; ++s)
          {
            LocalSolver       &solver = *local_solvers[s];
            const PatchLayout &layout = *solver.layout;
            double *const      C      = &product_storage[start[s]];
            layout.combine(solver.metrics,
                           layout.n_packed(),
                           layout.n_products(),
                           C);
            solver.products = C;
          }
      },
      /*grainsize=*/256);
  }


  // What one thread needs for the right-hand sides of a cell: the hat
  // functions' values, its own evaluator of the data, and arrays.
  template <int dim>
  struct FluxReconstruction<dim>::CellScratch
  {
    CellScratch(const FluxReconstruction<dim> &reconstruction,
                const Sources                 &sources)
        : sources(sources)
        , hat_values(reconstruction.mapping,
                     reconstruction.fe_hat,
                     reconstruction.quadrature,
                     update_values | update_gradients | update_jacobians |
                       update_JxW_values)
        , cell_values(sources.make_cell_values())
        , flux(sources.n_fields,
               std::vector<Tensor<1, dim>>(reconstruction.quadrature.size()))
        , source(sources.n_fields,
                 std::vector<double>(reconstruction.quadrature.size()))
    {
    }

    // WorkStream copies the scratch once per thread: a new FEValues and a
    // new evaluator of the data.
    CellScratch(const CellScratch &other)
        : sources(other.sources)
        , hat_values(other.hat_values.get_mapping(),
                     other.hat_values.get_fe(),
                     other.hat_values.get_quadrature(),
                     other.hat_values.get_update_flags())
        , cell_values(sources.make_cell_values())
        , flux(other.flux)
        , source(other.source)
    {
    }

    const Sources                           &sources;
    FEValues<dim>                            hat_values;
    typename Sources::CellValues             cell_values;
    std::vector<std::vector<Tensor<1, dim>>> flux;
    std::vector<std::vector<double>>         source;
    std::vector<double>                      flux_moments, vertex_rhs;
  };


  // The right-hand sides of one cell's parts in its patches, in the order
  // of memberships[cell], record = (n_tau + n_q) n_fields numbers each.
  template <int dim>
  struct FluxReconstruction<dim>::CellShare
  {
    CellIterator        cell;
    std::vector<double> rhs;
  };


  // In the metric G of the cell, (psi F, tau_j) is int psi (G F^) . (s_j
  // tau^_j) over the reference cell, with the Piola pull-back F^ = adj(J) F
  // = det J J^-1 F (so that F in RT_p gives the product of the patch
  // energy): the sum over the quadrature points of psi s_j (G adj(J) F) .
  // tau^_j w_q, which on parallelograms is the L2 product psi s_j (J^T F) .
  // tau^_j w_q. No Raviart-Thomas values on the cell are needed, only J, G
  // and the signs.
  template <int dim>
  void
  FluxReconstruction<dim>::cell_share(const CellIterator &cell,
                                      CellScratch        &scratch,
                                      CellShare          &share) const
  {
    const unsigned int n_fields       = scratch.sources.n_fields;
    const unsigned int n_tau          = fe_flux.n_dofs_per_cell(),
                       n_q            = fe_divergence.n_dofs_per_cell();
    const unsigned int     record     = (n_tau + n_q) * n_fields;
    constexpr unsigned int n_v        = GeometryInfo<dim>::vertices_per_cell;
    const auto            &parts      = memberships[cell->active_cell_index()];
    FEValues<dim>         &hat_values = scratch.hat_values;
    auto                  &flux       = scratch.flux;
    auto                  &source     = scratch.source;
    auto                  &flux_moments = scratch.flux_moments;
    auto                  &vertex_rhs   = scratch.vertex_rhs;
    flux_moments.resize(n_fields * n_tau);
    vertex_rhs.assign(n_v * record, 0.);

    hat_values.reinit(cell);
    scratch.cell_values(cell, flux, source);
    Tensor<2, dim> G;
    {
      const double *metric = &cell_metric[cell->active_cell_index() * n_metric];
      for (unsigned int a = 0, m = 0; a < dim; ++a)
        for (unsigned int b = a; b < dim; ++b, ++m)
          G[a][b] = G[b][a] = metric[m];
    }

    // The right-hand sides of the cell's Q1 shape functions phi_v,
    // vertex_rhs[v record ...]; psi_a on the cell is the combination with
    // the weights of its membership (one phi_v, or constraint weights at
    // hanging vertices).
    for (const unsigned int q : hat_values.quadrature_point_indices())
      {
        const double         dx = hat_values.JxW(q);
        const Tensor<2, dim> J(hat_values.jacobian(q));
        // the metric's product with the Piola pull-back adj(J) F of F:
        // G adj(J) = J^T on parallelograms
        const Tensor<2, dim> pull = G * (determinant(J) * invert(J));
        const double *reference   = &weighted_flux_reference[q * n_tau * dim];
        // (G adj(J) F_f) . tau^_j w_q, without the signs
        for (unsigned int f = 0; f < n_fields; ++f)
          {
            double mapped[dim];
            for (unsigned int e = 0; e < dim; ++e)
              {
                mapped[e] = 0;
                for (unsigned int d = 0; d < dim; ++d)
                  mapped[e] += pull[e][d] * flux[f][q][d];
              }
            for (unsigned int j = 0; j < n_tau; ++j)
              {
                double value = 0;
                for (unsigned int e = 0; e < dim; ++e)
                  value += mapped[e] * reference[j * dim + e];
                flux_moments[f * n_tau + j] = value;
              }
          }
        const double *q_k = &q_reference[q * n_q];
        for (unsigned int v = 0; v < n_v; ++v)
          {
            const double          phi      = hat_values.shape_value(v, q);
            const Tensor<1, dim> &grad_phi = hat_values.shape_grad(v, q);
            double               *values   = &vertex_rhs[v * record];
            for (unsigned int f = 0; f < n_fields; ++f, values += n_tau + n_q)
              {
                const double *moments = &flux_moments[f * n_tau];
                for (unsigned int j = 0; j < n_tau; ++j)
                  values[j] -= phi * moments[j];
                const double g =
                  (source[f][q] * phi - flux[f][q] * grad_phi) * dx;
                for (unsigned int k = 0; k < n_q; ++k)
                  values[n_tau + k] += g * q_k[k];
              }
          }
      }
    share.cell = cell;
    share.rhs.assign(parts.size() * record, 0.);
    for (unsigned int m = 0; m < parts.size(); ++m)
      for (unsigned int v = 0; v < n_v; ++v)
        if (const double w = parts[m].hat[v]; w != 0.)
          {
            const double *from = &vertex_rhs[v * record];
            double       *to   = &share.rhs[m * record];
            for (unsigned int i = 0; i < record; ++i)
              to[i] += w * from[i];
          }
    const std::int8_t *signs = &piola_signs[cell->active_cell_index() * n_tau];
    for (unsigned int m = 0; m < parts.size(); ++m)
      for (unsigned int f = 0; f < n_fields; ++f)
        {
          double *values = share.rhs.data() + m * record + f * (n_tau + n_q);
          for (unsigned int j = 0; j < n_tau; ++j)
            if (signs[j] < 0)
              values[j] = -values[j];
        }
  }


  // values[f (n_tau + n_q) + j] = -(psi_a F_f, tau_j)_K and
  // values[f (n_tau + n_q) + n_tau + k] = (s_f psi_a - F_f . grad psi_a,
  // q_k)_K.
  template <int dim>
  void
  FluxReconstruction<dim>::add_cell_share(const unsigned int p,
                                          const unsigned int position,
                                          const double      *values,
                                          const unsigned int n_fields,
                                          double *const      rhs) const
  {
    const PatchLayout &layout   = *patches[p].solver->layout;
    const unsigned int n_tau    = fe_flux.n_dofs_per_cell(),
                       n_q      = fe_divergence.n_dofs_per_cell();
    const unsigned int  n_sigma = layout.n_sigma;
    const unsigned int  n       = patches[p].solver->n();
    const unsigned int *start   = &layout.sigma_start[position * (n_tau + 1)];
    const auto         *entries = layout.sigma_entries.data();
    for (unsigned int f = 0; f < n_fields; ++f, values += n_tau + n_q)
      {
        double *const column = rhs + std::size_t(f) * n;
        for (unsigned int j = 0; j < n_tau; ++j)
          for (unsigned int e = start[j]; e < start[j + 1]; ++e)
            column[entries[e].first] += entries[e].second * values[j];
        for (unsigned int k = 0; k < n_q; ++k)
          column[n_sigma + position * n_q + k] += values[n_tau + k];
      }
  }


  template <int dim>
  void
  FluxReconstruction<dim>::reconstruct(
    const Sources                                      &sources,
    const std::vector<TrilinosWrappers::MPI::Vector *> &sigma) const
  {
    const MPI_Comm     comm     = dof_handler.get_communicator();
    const unsigned int rank     = Utilities::MPI::this_mpi_process(comm);
    const unsigned int n_fields = sources.n_fields;
    const unsigned int n_tau    = fe_flux.n_dofs_per_cell(),
                       n_q      = fe_divergence.n_dofs_per_cell();
    const unsigned int record   = (n_tau + n_q) * n_fields;
    AssertDimension(sigma.size(), n_fields);

    // Right-hand sides of all patches solved here, one column per field
    // (patch p from rhs_start[p] on), and those of owned cells in patches
    // solved elsewhere.
    std::vector<std::size_t> rhs_start(patches.size() + 1, 0);
    for (unsigned int p = 0; p < patches.size(); ++p)
      rhs_start[p + 1] =
        rhs_start[p] + std::size_t(patches[p].solver->n()) * n_fields;
    // (zeroed on all threads: on a large mesh this is the first touch of
    // much memory, whose page faults then run in parallel)
    const std::unique_ptr<double[]> rhs_storage(new double[rhs_start.back()]);
    double *const                   rhs = rhs_storage.get();
    parallel::apply_to_subranges(
      std::size_t(0),
      rhs_start.back(),
      [&](const std::size_t begin, const std::size_t end) {
        std::fill(rhs + begin, rhs + end, 0.);
      },
      /*grainsize=*/std::size_t(1) << 16);
    std::map<unsigned int, std::vector<double>> outgoing;
    for (const auto &[to, n] : n_sent)
      outgoing[to].assign(n * record, 0.);

    // One pass over the owned cells: each cell computes its part of the
    // right-hand sides of the patches it belongs to (concurrently, see
    // cell_share()), and the parts are added to the patches' right-hand
    // sides, or to what is sent to other processes, in the order of the
    // cells.
    const auto worker =
      [&](const typename std::vector<CellIterator>::const_iterator &cell,
          CellScratch                                              &scratch,
          CellShare &share) { cell_share(*cell, scratch, share); };
    const auto copier = [&](const CellShare &share) {
      const auto &parts = memberships[share.cell->active_cell_index()];
      for (unsigned int m = 0; m < parts.size(); ++m)
        if (parts[m].rank == rank)
          add_cell_share(parts[m].index,
                         parts[m].position,
                         share.rhs.data() + m * record,
                         n_fields,
                         rhs + rhs_start[parts[m].index]);
        else
          std::copy_n(share.rhs.data() + m * record,
                      record,
                      outgoing[parts[m].rank].data() + parts[m].index * record);
    };
    WorkStream::run(cells_with_shares.cbegin(),
                    cells_with_shares.cend(),
                    worker,
                    copier,
                    CellScratch(*this, sources),
                    CellShare(),
                    /*queue_length=*/2 * MultithreadInfo::n_threads(),
                    /*chunk_size=*/64);

    // The parts computed by the owners of cells in patches solved here.
    if (Utilities::MPI::n_mpi_processes(comm) > 1)
      {
        const auto incoming = Utilities::MPI::some_to_some(comm, outgoing);
        for (const auto &[from, values] : incoming)
          {
            const auto &targets = received.at(from);
            AssertDimension(values.size(), targets.size() * record);
            for (unsigned int i = 0; i < targets.size(); ++i)
              add_cell_share(targets[i].first,
                             targets[i].second,
                             values.data() + i * record,
                             n_fields,
                             rhs + rhs_start[targets[i].first]);
          }
      }

    // The constants c_a of the vertices: c_a (psi_a, q_k) on every cell.
    if (sources.vertex_source)
      for (unsigned int p = 0; p < patches.size(); ++p)
        {
          const Patch       &patch    = patches[p];
          const PatchLayout &layout   = *patch.solver->layout;
          const double      *hat_mass = patch.hat_mass;
          for (unsigned int f = 0; f < n_fields; ++f)
            {
              const double c_a    = sources.vertex_source(patch.vertex, f);
              double      *column = rhs + rhs_start[p] +
                               std::size_t(f) * patch.solver->n() +
                               layout.n_sigma;
              for (unsigned int k = 0; k < layout.n_cells * n_q; ++k)
                column[k] += c_a * hat_mass[k];
            }
        }

    // The patch problems, independent of each other (concurrently): the
    // patch solution overwrites its right-hand sides, sigma^a is the head
    // of each column. A mesh reconstructed more than once keeps the
    // products C of its solvers (see LocalSolver).
    if (++n_reconstructions == 2)
      keep_products();
    parallel::apply_to_subranges(
      0u,
      static_cast<unsigned int>(patches.size()),
      [&](const unsigned int begin, const unsigned int end) {
        std::vector<double> work;
        for (unsigned int p = begin; p < end; ++p)
          patches[p].solver->solve(
            rhs + rhs_start[p], n_fields, metric_entries, n_tau, work);
      },
      /*grainsize=*/256);
    // The fluxes of the patches summed in patch order, the fields
    // concurrently; then the sums of dofs other processes own added
    // there (in serial, nothing to send).
    std::vector<LinearAlgebra::distributed::Vector<double>> sums(n_fields);
    for (auto &sum : sums)
      sum.reinit(flux_partitioner);
    parallel::apply_to_subranges(
      0u,
      n_fields,
      [&](const unsigned int first_field, const unsigned int end_field) {
        for (unsigned int f = first_field; f < end_field; ++f)
          {
            double *const values = sums[f].get_values();
            for (unsigned int p = 0; p < patches.size(); ++p)
              {
                const LocalSolver &solver = *patches[p].solver;
                const double      *column =
                  rhs + rhs_start[p] + std::size_t(f) * solver.n();
                const unsigned int *positions =
                  &patch_positions[patches[p].dofs_start];
                for (unsigned int i = 0; i < solver.layout->n_sigma; ++i)
                  values[positions[i]] += column[i];
              }
          }
      },
      /*grainsize=*/1);
    TrilinosWrappers::MPI::Vector owned(owned_dofs, comm);
    for (unsigned int f = 0; f < n_fields; ++f)
      {
        LinearAlgebra::distributed::Vector<double> &sum = sums[f];
        sum.compress(VectorOperation::add);
        // The fluxes on the fine side of hanging faces from the coarse side
        // (the patches wrote none there), which may be owned elsewhere.
        sum.update_ghost_values();
        double *const values = sum.get_values();
        for (std::size_t c = 0; c < constrained_dofs.size(); ++c)
          {
            double value = 0;
            for (unsigned int e = constraint_start[c];
                 e < constraint_start[c + 1];
                 ++e)
              value += constraint_entries[e].second *
                       values[constraint_entries[e].first];
            values[constrained_dofs[c]] = value;
          }
        // The owned entries come first, in the order of owned_dofs, as in
        // the Trilinos vector; the ghosts of sigma from their owners.
        std::copy_n(values, sum.locally_owned_size(), owned.begin());
        ghosted_fluxes.copy(owned, *sigma[f]);
      }
  }


  template <int dim>
  const DoFHandler<dim> &
  FluxReconstruction<dim>::get_dof_handler() const
  {
    return dof_handler;
  }


  template <int dim>
  const Quadrature<dim> &
  FluxReconstruction<dim>::get_quadrature() const
  {
    return quadrature;
  }


  template <int dim>
  const IndexSet &
  FluxReconstruction<dim>::locally_owned_dofs() const
  {
    return owned_dofs;
  }


  template <int dim>
  const std::vector<std::int8_t> &
  FluxReconstruction<dim>::get_piola_signs() const
  {
    return piola_signs;
  }


  template <int dim>
  const IndexSet &
  FluxReconstruction<dim>::locally_relevant_dofs() const
  {
    return relevant_dofs;
  }


  template <int dim>
  std::pair<unsigned int, unsigned int>
  FluxReconstruction<dim>::statistics() const
  {
    return {patches.size(), local_solvers.size()};
  }


  template class FluxReconstruction<2>;
} // namespace VI
