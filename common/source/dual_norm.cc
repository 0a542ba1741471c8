#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/vector.h>

#include <vi/dual_norm.h>
#include <vi/errors.h>
#include <vi/linear_solvers.h>
#include <vi/nodal_fields.h>
#include <vi/piola_divergence.h>
#include <vi/same_cell.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace VI
{
  using namespace dealii;

  template <int dim>
  DualNormBound<dim>::DualNormBound(
    const Mapping<dim>            &mapping,
    const FluxReconstruction<dim> &reconstruction,
    const double                   friedrichs_constant)
      : mapping(mapping)
      , reconstruction(reconstruction)
      , friedrichs_constant(friedrichs_constant)
      , fe(1)
  {
  }


  template <int dim>
  void
  DualNormBound<dim>::reinit(const Triangulation<dim> &triangulation)
  {
    dof_handler.reinit(triangulation);
    dof_handler.distribute_dofs(fe);
    const MPI_Comm  comm  = dof_handler.get_communicator();
    const IndexSet &owned = dof_handler.locally_owned_dofs();
    relevant.clear();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant);
    constraints.clear();
    constraints.reinit(relevant);
    DoFTools::make_hanging_node_constraints(dof_handler, constraints);
    DoFTools::make_zero_boundary_constraints(dof_handler, constraints);
    constraints.close();

    DynamicSparsityPattern pattern(relevant);
    DoFTools::make_sparsity_pattern(dof_handler, pattern, constraints, false);
    SparsityTools::distribute_sparsity_pattern(pattern, owned, comm, relevant);
    laplacian.reinit(owned, owned, pattern, comm);
    hat_integrals.reinit(owned, comm);

    // The stiffness matrix and (psi_a, 1) with the reconstruction's rule:
    // the residual r_a must be the one its patch problems see.
    FEValues<dim>                        values(mapping,
                         fe,
                         reconstruction.get_quadrature(),
                         update_values | update_gradients | update_JxW_values);
    const unsigned int                   n = fe.n_dofs_per_cell();
    FullMatrix<double>                   cell_matrix(n, n);
    Vector<double>                       cell_integrals(n);
    std::vector<types::global_dof_index> dofs(n);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          cell_matrix    = 0;
          cell_integrals = 0;
          for (const unsigned int q : values.quadrature_point_indices())
            for (unsigned int i = 0; i < n; ++i)
              {
                for (unsigned int j = 0; j < n; ++j)
                  cell_matrix(i, j) += values.shape_grad(i, q) *
                                       values.shape_grad(j, q) * values.JxW(q);
                cell_integrals(i) += values.shape_value(i, q) * values.JxW(q);
              }
          cell->get_dof_indices(dofs);
          constraints.distribute_local_to_global(
            cell_matrix, cell_integrals, dofs, laplacian, hat_integrals);
        }
    laplacian.compress(VectorOperation::add);
    hat_integrals.compress(VectorOperation::add);

    amg.initialize(laplacian, elliptic_amg_settings(false));

    vertex_dofs = NodalFields::vertex_nodes(dof_handler);
  }


  template <int dim>
  double
  DualNormBound<dim>::bound(const std::vector<double> &m) const
  {
    return equilibrate({[&](const unsigned int cell, const unsigned int) {
      return m[cell];
    }})[0];
  }


  template <int dim>
  std::vector<double>
  DualNormBound<dim>::bounds_at_points(
    const std::vector<const std::vector<double> *> &values) const
  {
    const unsigned int  n_q = reconstruction.get_quadrature().size();
    std::vector<Source> sources;
    for (const std::vector<double> *m : values)
      sources.emplace_back(
        [m, n_q](const unsigned int cell, const unsigned int q) {
          return (*m)[cell * n_q + q];
        });
    return equilibrate(sources);
  }


  namespace
  {
    using CellSource = std::function<double(unsigned int, unsigned int)>;

    // One thread's work space: the Q1 values and Jacobians on a cell; the
    // Raviart-Thomas values of rho come from their reference values, the
    // Jacobians and the signs (no Raviart-Thomas FEValues).
    template <int dim>
    struct EquilibrationScratch
    {
      EquilibrationScratch(const Mapping<dim>       &mapping,
                           const FiniteElement<dim> &fe,
                           const FiniteElement<dim> &flux_fe,
                           const Quadrature<dim>    &quadrature)
          : flux_fe(flux_fe)
          , values(mapping,
                   fe,
                   quadrature,
                   PiolaDivergence<dim>::update_flags())
          , piola(flux_fe, quadrature)
          , coefficients(flux_fe.n_dofs_per_cell())
          , rho_values(quadrature.size())
          , rho_divergences(quadrature.size())
          , c_values(quadrature.size())
      {
      }
      EquilibrationScratch(const EquilibrationScratch &other)
          : EquilibrationScratch(other.values.get_mapping(),
                                 other.values.get_fe(),
                                 other.flux_fe,
                                 other.values.get_quadrature())
      {
      }
      const FiniteElement<dim>   &flux_fe;
      FEValues<dim>               values;
      PiolaDivergence<dim>        piola;
      std::vector<double>         coefficients;
      std::vector<Tensor<1, dim>> rho_values;
      std::vector<double>         rho_divergences, c_values;
    };


    // The loads (m, v_h) of the sources and the Friedrichs bounds' |m|^2
    // (on this process).
    template <int dim, class Cells>
    void
    assemble_loads(const Cells                                &owned_cells,
                   const EquilibrationScratch<dim>            &sample,
                   const std::vector<CellSource>              &m,
                   const AffineConstraints<double>            &constraints,
                   const unsigned int                          dofs_per_cell,
                   std::vector<TrilinosWrappers::MPI::Vector> &loads,
                   std::vector<double>                        &m_squared)
    {
      using CellIterator = typename DoFHandler<dim>::active_cell_iterator;
      const unsigned int n_sources = m.size();
      struct LoadShare
      {
        std::vector<Vector<double>>          cell_loads;
        std::vector<types::global_dof_index> dofs;
        std::vector<double>                  m_squared;
      };
      WorkStream::run(
        owned_cells,
        [&](const CellIterator        &cell,
            EquilibrationScratch<dim> &scratch,
            LoadShare                 &share) {
          scratch.values.reinit(cell);
          const FEValues<dim> &values = scratch.values;
          const unsigned int   K      = cell->active_cell_index();
          for (unsigned int k = 0; k < n_sources; ++k)
            {
              share.cell_loads[k] = 0;
              share.m_squared[k]  = 0;
              for (const unsigned int q : values.quadrature_point_indices())
                {
                  const double m_q = m[k](K, q);
                  share.m_squared[k] += m_q * m_q * values.JxW(q);
                  for (const unsigned int i : values.dof_indices())
                    share.cell_loads[k](i) +=
                      m_q * values.shape_value(i, q) * values.JxW(q);
                }
            }
          cell->get_dof_indices(share.dofs);
        },
        [&](const LoadShare &share) {
          for (unsigned int k = 0; k < n_sources; ++k)
            {
              constraints.distribute_local_to_global(share.cell_loads[k],
                                                     share.dofs,
                                                     loads[k]);
              m_squared[k] += share.m_squared[k];
            }
        },
        sample,
        LoadShare{std::vector<Vector<double>>(n_sources,
                                              Vector<double>(dofs_per_cell)),
                  std::vector<types::global_dof_index>(dofs_per_cell),
                  std::vector<double>(n_sources, 0.)},
        /*queue_length=*/2 * MultithreadInfo::n_threads(),
        /*chunk_size=*/32);
    }


    // z_h of a load, solved well below the size of the bound, and c_h, with
    // ghosts.
    void
    solve_potential(const TrilinosWrappers::SparseMatrix       &laplacian,
                    const TrilinosWrappers::PreconditionAMG    &amg,
                    const AffineConstraints<double>            &constraints,
                    const TrilinosWrappers::MPI::Vector        &hat_integrals,
                    const IndexSet                             &owned,
                    const IndexSet                             &relevant,
                    const MPI_Comm                              comm,
                    TrilinosWrappers::MPI::Vector              &load,
                    std::vector<TrilinosWrappers::MPI::Vector> &z_ghosted,
                    std::vector<TrilinosWrappers::MPI::Vector> &c_ghosted)
    {
      load.compress(VectorOperation::add);
      TrilinosWrappers::MPI::Vector z(owned, comm);
      SolverControl                 control(1000, 1e-10 * load.l2_norm());
      SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
      try
        {
          cg.solve(laplacian, z, load, amg);
        }
      catch (const SolverControl::NoConvergence &)
        {
          throw SolverFailure("the Poisson solve of a dual norm bound "
                              "(CG + AMG) did not converge in 1000 "
                              "iterations");
        }
      TrilinosWrappers::MPI::Vector residual(owned, comm);
      laplacian.vmult(residual, z);
      residual.sadd(-1., 1., load);
      TrilinosWrappers::MPI::Vector c(owned, comm);
      for (const auto i : owned)
        if (!constraints.is_constrained(i))
          c(i) = -residual(i) / hat_integrals(i);
      c.compress(VectorOperation::insert);
      constraints.distribute(z);
      constraints.distribute(c);
      z_ghosted.emplace_back(owned, relevant, comm);
      c_ghosted.emplace_back(owned, relevant, comm);
      z_ghosted.back() = z;
      c_ghosted.back() = c;
    }


    // ||rho||^2 and ||c_h||^2 of each field (on this process).
    template <int dim, class Cells>
    std::vector<double>
    flux_and_constant_norms(
      const Cells                                      &owned_cells,
      const EquilibrationScratch<dim>                  &sample,
      const DoFHandler<dim>                            &flux_dofs,
      const std::vector<std::int8_t>                   &signs,
      const std::vector<TrilinosWrappers::MPI::Vector> &rho,
      const std::vector<TrilinosWrappers::MPI::Vector> &c_ghosted)
    {
      using CellIterator = typename DoFHandler<dim>::active_cell_iterator;
      const unsigned int  n_tau    = flux_dofs.get_fe().n_dofs_per_cell();
      const unsigned int  n_fields = rho.size();
      std::vector<double> local_sums(2 * n_fields, 0.);
      WorkStream::run(
        owned_cells,
        [&](const CellIterator        &cell,
            EquilibrationScratch<dim> &scratch,
            std::vector<double>       &share) {
          scratch.values.reinit(cell);
          const FEValues<dim> &values = scratch.values;
          scratch.piola.reinit(
            values,
            ArrayView<const std::int8_t>(signs.data() +
                                           cell->active_cell_index() * n_tau,
                                         n_tau));
          const auto flux_cell = same_cell(cell, flux_dofs);
          std::fill(share.begin(), share.end(), 0.);
          for (unsigned int f = 0; f < n_fields; ++f)
            {
              flux_cell->get_dof_values(rho[f],
                                        scratch.coefficients.begin(),
                                        scratch.coefficients.end());
              scratch.piola.function_values_and_divergences(
                make_array_view(scratch.coefficients),
                scratch.rho_values,
                scratch.rho_divergences);
              values.get_function_values(c_ghosted[f], scratch.c_values);
              for (const unsigned int q : values.quadrature_point_indices())
                {
                  share[2 * f] +=
                    scratch.rho_values[q].norm_square() * values.JxW(q);
                  share[2 * f + 1] +=
                    scratch.c_values[q] * scratch.c_values[q] * values.JxW(q);
                }
            }
        },
        [&](const std::vector<double> &share) {
          for (unsigned int k = 0; k < share.size(); ++k)
            local_sums[k] += share[k];
        },
        sample,
        std::vector<double>(2 * n_fields, 0.),
        /*queue_length=*/2 * MultithreadInfo::n_threads(),
        /*chunk_size=*/32);
      return local_sums;
    }
  } // namespace


  // m[k](cell, q): source k at point q of the reconstruction's quadrature on
  // the cell of that active index. All sources share the cell loops and one
  // reconstruction (a field each); each has its own Poisson solve. The cell
  // loops run on the threads of MultithreadInfo (the sources are only
  // read); their sums are added in the order of the cells, so that the
  // bounds do not depend on the number of threads (see
  // FluxReconstruction::reconstruct() for the one-thread caveat).
  template <int dim>
  std::vector<double>
  DualNormBound<dim>::equilibrate(const std::vector<Source> &m) const
  {
    const MPI_Comm         comm       = dof_handler.get_communicator();
    const IndexSet        &owned      = dof_handler.locally_owned_dofs();
    const Quadrature<dim> &quadrature = reconstruction.get_quadrature();
    const DoFHandler<dim> &flux_dofs  = reconstruction.get_dof_handler();
    const unsigned int     n_sources  = m.size();
    const auto             owned_cells =
      filter_iterators(dof_handler.active_cell_iterators(),
                       IteratorFilters::LocallyOwnedCell());

    const EquilibrationScratch<dim> sample(mapping,
                                           fe,
                                           flux_dofs.get_fe(),
                                           quadrature);

    // The loads (m, v_h) and the Friedrichs bounds' |m|^2.
    std::vector<TrilinosWrappers::MPI::Vector> loads(
      n_sources, TrilinosWrappers::MPI::Vector(owned, comm));
    std::vector<double> m_squared(n_sources, 0.);
    assemble_loads(owned_cells,
                   sample,
                   m,
                   constraints,
                   fe.n_dofs_per_cell(),
                   loads,
                   m_squared);
    Utilities::MPI::sum(ArrayView<const double>(m_squared),
                        comm,
                        ArrayView<double>(m_squared));
    std::vector<double> bounds(n_sources, 0.);
    // The sources that do not vanish everywhere, a field each.
    std::vector<unsigned int> fields;
    for (unsigned int k = 0; k < n_sources; ++k)
      if (m_squared[k] > 0.)
        fields.push_back(k);
    if (fields.empty())
      return bounds;

    // z_h, solved well below the size of the bound (the residual enters it
    // through c_h, not as an error); c_a = -r_a / (psi_a, 1) at the regular
    // interior vertices, c_h the conforming Q1 function of these values.
    std::vector<TrilinosWrappers::MPI::Vector> z_ghosted, c_ghosted;
    for (const unsigned int k : fields)
      solve_potential(laplacian,
                      amg,
                      constraints,
                      hat_integrals,
                      owned,
                      relevant,
                      comm,
                      loads[k],
                      z_ghosted,
                      c_ghosted);

    // rho: equilibrates m (+ c_h) with the flux grad z_h (div rho = m + c_h
    // exactly where m is in Q_p on every cell), one field per source.
    const unsigned int                        n_fields = fields.size();
    typename FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = n_fields;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of z_h
      const auto z_values = std::make_shared<FEValues<dim>>(mapping,
                                                            fe,
                                                            quadrature,
                                                            update_gradients);
      return [&, z_values](const auto &cell, auto &flux, auto &source) {
        const auto dof_cell = same_cell(cell, dof_handler);
        z_values->reinit(dof_cell);
        const unsigned int K = cell->active_cell_index();
        for (unsigned int f = 0; f < n_fields; ++f)
          {
            z_values->get_function_gradients(z_ghosted[f], flux[f]);
            for (unsigned int q = 0; q < source[f].size(); ++q)
              source[f][q] = m[fields[f]](K, q);
          }
      };
    };
    sources.vertex_source = [&](const unsigned int vertex,
                                const unsigned int f) {
      const auto i = vertex_dofs[vertex];
      return constraints.is_constrained(i) ? 0. : c_ghosted[f](i);
    };
    std::vector<TrilinosWrappers::MPI::Vector>   rho(n_fields);
    std::vector<TrilinosWrappers::MPI::Vector *> rho_pointers;
    for (auto &r : rho)
      rho_pointers.push_back(&r);
    reconstruction.reconstruct(sources, rho_pointers);

    // ||rho||^2 and ||c_h||^2 of each field.
    const std::vector<double> local_sums =
      flux_and_constant_norms(owned_cells,
                              sample,
                              flux_dofs,
                              reconstruction.get_piola_signs(),
                              rho,
                              c_ghosted);
    std::vector<double> sums(local_sums.size());
    Utilities::MPI::sum(ArrayView<const double>(local_sums),
                        comm,
                        ArrayView<double>(sums));
    for (unsigned int f = 0; f < n_fields; ++f)
      {
        const double equilibrated =
          std::sqrt(sums[2 * f]) +
          friedrichs_constant * std::sqrt(sums[2 * f + 1]);
        bounds[fields[f]] =
          std::min(equilibrated,
                   friedrichs_constant * std::sqrt(m_squared[fields[f]]));
      }
    return bounds;
  }


  template class DualNormBound<2>;
} // namespace VI
