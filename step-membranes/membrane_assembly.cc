// step-membranes, conforming Q_p: the discrete system on a mesh (DoFs,
// constraints, sparsity, assembly of E, F and the coupling D) and the
// initial iterate.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/trilinos_index_access.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>
#include <vi/reduced_tension.h>

#include "membrane_problem.h"

#include <algorithm>
#include <cmath>

namespace StepMembranes
{
  // Distribute the nodes, build the constraints (hanging nodes, Dirichlet
  // data, no multiplier on constrained nodes), the contact rows and the
  // sparsity of A; and the patches of the flux reconstruction.
  template <int dim>
  void
  MembraneProblem<dim>::setup_system()
  {
    // What the contact problem costs on this mesh is measured from here to
    // the end of solve().
    solve_timer.restart();
    usage_at_solve_start = VI::ProcessUsage::now(comm);
    TimerOutput::Scope t(timer, "setup");

    distribute_nodes();
    make_constraints(*data.g1,
                     *data.g2,
                     data.obstacle.get(),
                     data.smooth_obstacle);
    VI::NodalFields::make_system_constraints(hanging_node_constraints,
                                             hanging_node_constraints,
                                             relevant_system,
                                             system_hanging_constraints);
    // The balance rows of hanging nodes are condensed away: the residual
    // leaves them out.
    IndexSet hanging_nodes(owned_nodes.size());
    for (const types::global_dof_index i : owned_nodes)
      if (hanging_node_constraints.is_constrained(i))
        hanging_nodes.add_index(i);
    contact_system.reinit(owned_nodes, u1_constraints, comm, hanging_nodes);
    reinit_matrices(contact_system);
    solution.reinit(owned_system, comm);

    t.stop();
    if (parameters.estimators.enabled)
      {
        // The patch matrices: a cost of the estimators.
        TimerOutput::Scope t(timer, "estimators: patch matrices");
        flux_reconstruction = std::make_unique<VI::FluxReconstruction<dim>>(
          *mapping,
          parameters.estimators.flux_degree_for(fe.degree),
          fe.degree);
        flux_reconstruction->reinit(dof_handler, domain.free_boundary_ids());
        if (parameters.output.verbose)
          {
            const auto [n_patches, n_matrices] =
              flux_reconstruction->statistics();
            pcout << "   Flux reconstruction: " << n_patches
                  << " vertex patches, " << n_matrices
                  << " distinct patch matrices" << std::endl;
          }
        setup_estimate_multiplier(parameters.estimators,
                                  data.mu1,
                                  data.mu2,
                                  flux_reconstruction->get_quadrature());
        dual_norm.reset();
        if (parameters.estimators.needs_dual_norm_bound())
          {
            dual_norm = std::make_unique<VI::DualNormBound<dim>>(
              *mapping, *flux_reconstruction, domain.friedrichs_constant());
            dual_norm->reinit(triangulation);
          }
        make_vertex_dofs();
      }
  }


  // The linear part of the system, once per mesh: the stiffness blocks and
  // the load F (with the Dirichlet lifting) through the constraints, the
  // coupling D (lumped masses (psi_i, 1) for p = 1, the identity for p >= 2
  // by duality), and the scalar stiffness S (for AMG) and mass matrices.
  template <int dim>
  void
  MembraneProblem<dim>::assemble_system()
  {
    TimerOutput::Scope t(timer, "assembly");

    // The loads f1, f2 at the quadrature points, tabulated once per mesh: the
    // assembly integrates them, and the flux reconstruction and every
    // estimate read them (a parsed expression costs more than the rest of a
    // cell's work in an estimate). They are part of the assembly with or
    // without estimators: the estimators add no evaluation of f. (Timed
    // also on their own, inside the assembly.)
    TimerOutput::Scope loads(timer, "assembly: loads");
    tabulate_loads(*data.f1, *data.f2);
    loads.stop();

    contact_system.matrix = 0;
    contact_system.rhs    = 0;
    stiffness_matrix      = 0;

    // The cells' loads are the tabulated f1, f2; the copier moves the
    // Dirichlet data g_j to the right-hand side of the unconstrained rows
    // through the stiffness mu_alpha S, and assembles S. (The blocks
    // mu_alpha S themselves are copied from S below.)
    std::vector<types::global_dof_index> system_dofs(fe.n_dofs_per_cell());
    FullMatrix<double>                   scaled_stiffness(fe.n_dofs_per_cell());
    const double                         mu[2]      = {data.mu1, data.mu2};
    const auto                           cell_loads = [&](const auto &cell,
                                const FEValues<dim> &,
                                std::vector<double>(&loads)[2]) {
      const std::size_t first = cell->active_cell_index() * quadrature.size();
      for (unsigned int a = 0; a < 2; ++a)
        std::copy(load_values[a].begin() + first,
                  load_values[a].begin() + first + quadrature.size(),
                  loads[a].begin());
    };
    const auto copy_system =
      [&](const typename Discretisation::CellSystem &copy) {
        const auto &dofs = copy.local_dof_indices[0];
        for (const unsigned int field :
             {VI::NodalFields::u1, VI::NodalFields::u2})
          {
            for (unsigned int i = 0; i < dofs.size(); ++i)
              system_dofs[i] = index(dofs[i], field);
            scaled_stiffness.equ(mu[field], copy.matrices[0]);
            system_constraints.distribute_local_to_global(copy.vectors[field],
                                                          system_dofs,
                                                          contact_system.rhs,
                                                          scaled_stiffness);
          }
        u1_constraints.distribute_local_to_global(copy.matrices[0],
                                                  dofs,
                                                  stiffness_matrix);
      };
    const Vector lumped_mass = assemble_cells(cell_loads,
                                              update_default,
                                              /*mass_term=*/false,
                                              copy_system);
    contact_system.rhs.compress(VectorOperation::add);
    stiffness_matrix.compress(VectorOperation::add);

    // The blocks of u1 and u2 are mu1 S and mu2 S (the constraints of u1
    // and u2 constrain the same nodes, with the same weights), copied row
    // by row instead of assembled twice more through the constraints. The
    // row of a constrained node reads d X_i = d g_i: X satisfies every row
    // of E X = F, and Newton updates vanish on the boundary.
    // (S's rows read through Epetra: deal.II's row iterators copy a row
    // at every step)
    Assert(this->obstacle != nullptr ||
             u1_constraints.n_constraints() == u2_constraints.n_constraints(),
           ExcInternalError());
    const Epetra_CrsMatrix              &S = stiffness_matrix.trilinos_matrix();
    std::vector<types::global_dof_index> columns, system_columns;
    std::vector<double>                  scaled_values;
    for (int row = 0; row < S.NumMyRows(); ++row)
      {
        int     n_entries;
        double *values;
        int    *local_columns;
        S.ExtractMyRowView(row, n_entries, values, local_columns);
        const types::global_dof_index i =
          TrilinosWrappers::global_row_index(S, row);
        columns.resize(n_entries);
        for (int k = 0; k < n_entries; ++k)
          columns[k] =
            TrilinosWrappers::global_column_index(S, local_columns[k]);
        system_columns.resize(n_entries);
        scaled_values.resize(n_entries);
        // Over an obstacle, u2 is fixed at every node that is not hanging:
        // its row there reads d X_i = d psi_i alone.
        const bool fixed_u2 = this->obstacle != nullptr &&
                              !hanging_node_constraints.is_constrained(i);
        for (const unsigned int field :
             {VI::NodalFields::u1, VI::NodalFields::u2})
          {
            const bool diagonal_only = fixed_u2 && field == VI::NodalFields::u2;
            for (int k = 0; k < n_entries; ++k)
              {
                system_columns[k] = index(columns[k], field);
                scaled_values[k] =
                  diagonal_only && columns[k] != i ? 0. : mu[field] * values[k];
              }
            const types::global_dof_index system_row = index(i, field);
            contact_system.matrix.set(system_row,
                                      n_entries,
                                      system_columns.data(),
                                      scaled_values.data());
            if (system_constraints.is_inhomogeneously_constrained(system_row))
              contact_system.rhs(system_row) =
                mu[field] * stiffness_matrix.diag_element(i) *
                system_constraints.get_inhomogeneity(system_row);
          }
      }
    contact_system.rhs.compress(VectorOperation::insert);

    // Coupling -D / +D in the rows of u1 / u2, and X3 = 0 as the row of each
    // constrained node (boundary, hanging), where there is no contact row.
    set_coupling(contact_system, lumped_mass, data.mu1, data.mu2);

    // Rows that enforce u1 = u2 weigh mu_r S_ii.
    const double        mu_r = VI::reduced_tension(data.mu1, data.mu2);
    std::vector<double> stiffness_weight(owned_nodes.n_elements());
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      stiffness_weight[k] =
        mu_r * stiffness_matrix.diag_element(owned_nodes.nth_index_in_set(k));
    contact_system.set_stiffness_weights(std::move(stiffness_weight));

    if (parameters.linear_solver.solver == VI::LinearSolverType::gmres &&
        parameters.linear_solver.preconditioner == VI::PreconditionerType::amg)
      contact_system.use_contact_preconditioner(stiffness_matrix,
                                                data.mu1,
                                                data.mu2,
                                                fe.degree > 1);
  }


  // The Newton iterate on a new mesh: the previous mesh's solution
  // transferred (nested iteration), or the initial guess (zero, or the
  // boundary data interpolated in the whole domain) with zero multiplier.
  // Either way the Dirichlet data of this mesh are imposed.
  template <int dim>
  void
  MembraneProblem<dim>::initialize_iterate()
  {
    const bool from_data =
      parameters.nonlinear_solver.initial_guess == VI::InitialGuess::data;
    VI::initial_nodal_iterate(
      solution_transfer,
      [this](const Vector &lambda, Vector &X3) {
        compute_dual_coefficients(lambda, X3);
      },
      *mapping,
      dof_handler,
      from_data ? data.g1.get() : nullptr,
      from_data ? data.g2.get() : nullptr,
      solution);
    system_constraints.distribute(solution);
  }


  // Explicit instantiations of this file's members.
  template void
  MembraneProblem<2>::setup_system();
  template void
  MembraneProblem<2>::assemble_system();
  template void
  MembraneProblem<2>::initialize_iterate();
} // namespace StepMembranes
