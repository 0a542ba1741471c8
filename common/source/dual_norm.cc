#include <deal.II/base/mpi.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/vector.h>

#include <vi/dual_norm.h>
#include <vi/errors.h>
#include <vi/linear_solvers.h>

#include <algorithm>
#include <cmath>

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
  DualNormBound<dim>::~DualNormBound()
  {
    dof_handler.clear();
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

    vertex_dofs.assign(triangulation.n_vertices(), numbers::invalid_dof_index);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (!cell->is_artificial())
        for (const unsigned int v : cell->vertex_indices())
          vertex_dofs[cell->vertex_index(v)] = cell->vertex_dof_index(v, 0);
  }


  template <int dim>
  double
  DualNormBound<dim>::bound(const std::vector<double> &m) const
  {
    return equilibrate(
      [&](const unsigned int cell, const unsigned int) { return m[cell]; });
  }


  template <int dim>
  double
  DualNormBound<dim>::bound_at_points(const std::vector<double> &values) const
  {
    const unsigned int n_q = reconstruction.get_quadrature().size();
    return equilibrate([&](const unsigned int cell, const unsigned int q) {
      return values[cell * n_q + q];
    });
  }


  // m(cell, q): the source at point q of the reconstruction's quadrature on
  // the cell of that active index.
  template <int dim>
  template <typename Source>
  double
  DualNormBound<dim>::equilibrate(const Source &m) const
  {
    const MPI_Comm         comm       = dof_handler.get_communicator();
    const IndexSet        &owned      = dof_handler.locally_owned_dofs();
    const Quadrature<dim> &quadrature = reconstruction.get_quadrature();
    const unsigned int     n          = fe.n_dofs_per_cell();

    // The load (m, v_h) and the Friedrichs bound's |m|^2.
    FEValues<dim>                        values(mapping,
                         fe,
                         quadrature,
                         update_values | update_gradients | update_JxW_values);
    TrilinosWrappers::MPI::Vector        load(owned, comm), z(owned, comm);
    Vector<double>                       cell_load(n);
    std::vector<types::global_dof_index> dofs(n);
    double                               m_squared = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          const unsigned int K = cell->active_cell_index();
          values.reinit(cell);
          cell_load = 0;
          for (const unsigned int q : values.quadrature_point_indices())
            {
              const double m_q = m(K, q);
              m_squared += m_q * m_q * values.JxW(q);
              for (unsigned int i = 0; i < n; ++i)
                cell_load(i) += m_q * values.shape_value(i, q) * values.JxW(q);
            }
          cell->get_dof_indices(dofs);
          constraints.distribute_local_to_global(cell_load, dofs, load);
        }
    load.compress(VectorOperation::add);
    m_squared = Utilities::MPI::sum(m_squared, comm);
    if (m_squared == 0.)
      return 0.;

    // z_h, solved well below the size of the bound (the residual enters it
    // through c_h, not as an error).
    SolverControl control(1000, 1e-10 * load.l2_norm());
    SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
    try
      {
        cg.solve(laplacian, z, load, amg);
      }
    catch (const SolverControl::NoConvergence &)
      {
        throw SolverFailure("the Poisson solve of the multiplier's dual norm "
                            "bound (CG + AMG) did not converge in 1000 "
                            "iterations");
      }
    TrilinosWrappers::MPI::Vector residual(owned, comm);
    laplacian.vmult(residual, z);
    residual.sadd(-1., 1., load);
    // c_a = -r_a / (psi_a, 1) at the regular interior vertices; c_h is the
    // conforming Q1 function of these values.
    TrilinosWrappers::MPI::Vector c(owned, comm);
    for (const auto i : owned)
      if (!constraints.is_constrained(i))
        c(i) = -residual(i) / hat_integrals(i);
    c.compress(VectorOperation::insert);
    constraints.distribute(z);
    constraints.distribute(c);
    TrilinosWrappers::MPI::Vector z_ghosted(owned, relevant, comm),
      c_ghosted(owned, relevant, comm);
    z_ghosted = z;
    c_ghosted = c;

    // rho: equilibrates m (+ c_h) with the flux grad z_h (div rho = m + c_h
    // exactly where m is in Q_p on every cell).
    typename FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = 1;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of z_h
      const auto z_values = std::make_shared<FEValues<dim>>(mapping,
                                                            fe,
                                                            quadrature,
                                                            update_gradients);
      return [&, z_values](const auto &cell, auto &flux, auto &source) {
        typename DoFHandler<dim>::active_cell_iterator dof_cell(
          &dof_handler.get_triangulation(),
          cell->level(),
          cell->index(),
          &dof_handler);
        z_values->reinit(dof_cell);
        z_values->get_function_gradients(z_ghosted, flux[0]);
        for (unsigned int q = 0; q < source[0].size(); ++q)
          source[0][q] = m(cell->active_cell_index(), q);
      };
    };
    sources.vertex_source = [&](const unsigned int vertex, const unsigned int) {
      const auto i = vertex_dofs[vertex];
      return constraints.is_constrained(i) ? 0. : c_ghosted(i);
    };
    TrilinosWrappers::MPI::Vector rho;
    reconstruction.reconstruct(sources, {&rho});

    // ||rho|| and ||c_h||.
    const DoFHandler<dim> &flux_dofs = reconstruction.get_dof_handler();
    FEValues<dim>          flux_values(mapping,
                              flux_dofs.get_fe(),
                              quadrature,
                              update_values);
    const FEValuesExtractors::Vector sigma(0);
    std::vector<Tensor<1, dim>>      rho_values(quadrature.size());
    std::vector<double>              c_values(quadrature.size());
    double                           local_sums[2] = {0., 0.}, sums[2];
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          typename DoFHandler<dim>::active_cell_iterator flux_cell(
            &dof_handler.get_triangulation(),
            cell->level(),
            cell->index(),
            &flux_dofs);
          values.reinit(cell);
          flux_values.reinit(flux_cell);
          flux_values[sigma].get_function_values(rho, rho_values);
          values.get_function_values(c_ghosted, c_values);
          for (const unsigned int q : values.quadrature_point_indices())
            {
              local_sums[0] += rho_values[q].norm_square() * values.JxW(q);
              local_sums[1] += c_values[q] * c_values[q] * values.JxW(q);
            }
        }
    Utilities::MPI::sum(ArrayView<const double>(local_sums, 2),
                        comm,
                        ArrayView<double>(sums, 2));
    const double equilibrated =
      std::sqrt(sums[0]) + friedrichs_constant * std::sqrt(sums[1]);
    return std::min(equilibrated, friedrichs_constant * std::sqrt(m_squared));
  }


  template class DualNormBound<2>;
} // namespace VI
