// step-parabolic: the discrete system (DoFs, constraints, E^n and F^n of a
// backward Euler step), the initial values, and semismooth Newton on a step.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>

#include "parabolic_problem.h"

#include <cmath>
#include <map>

namespace StepParabolic
{
  using VI::NodalFields::index;
  using VI::NodalFields::multiplier;
  using VI::NodalFields::n_fields;


  // Nodes, constraints (hanging nodes, the Dirichlet data at the current
  // time of `data`, no multiplier on constrained nodes), contact rows,
  // sparsity; the patches of the flux reconstruction. The mesh is the same
  // for all time steps.
  template <int dim>
  void
  ParabolicProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");

    mapping->initialize(*geometry_mapping, triangulation);
    dof_handler.distribute_dofs(fe);
    owned_nodes = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_nodes);
    ghosted_nodes.reinit(owned_nodes, relevant_nodes, comm);
    owned_system    = VI::NodalFields::system_index_set(owned_nodes);
    relevant_system = VI::NodalFields::system_index_set(relevant_nodes);

    hanging_node_constraints.clear();
    hanging_node_constraints.reinit(relevant_nodes);
    DoFTools::make_hanging_node_constraints(dof_handler,
                                            hanging_node_constraints);
    hanging_node_constraints.close();
    make_constraints();
    contact_system.reinit(owned_nodes, u1_constraints, comm);
    preconditioner_dt = 0; // none for the new matrices yet

    DynamicSparsityPattern scalar_pattern(relevant_nodes);
    DoFTools::make_sparsity_pattern(dof_handler,
                                    scalar_pattern,
                                    u1_constraints,
                                    /*keep_constrained_dofs=*/false);
    SparsityTools::distribute_sparsity_pattern(scalar_pattern,
                                               owned_nodes,
                                               comm,
                                               relevant_nodes);
    DynamicSparsityPattern system_pattern(relevant_system);
    VI::NodalFields::make_system_sparsity(scalar_pattern,
                                          owned_nodes,
                                          system_pattern);
    contact_system.matrix.reinit(owned_system,
                                 owned_system,
                                 system_pattern,
                                 comm);
    stiffness_matrix.reinit(owned_nodes, owned_nodes, scalar_pattern, comm);
    solution.reinit(owned_system, comm);
    previous_solution.reinit(owned_system, comm);
    for (auto *field : {&u1_h,
                        &u2_h,
                        &gap_h,
                        &lambda_h,
                        &contact_set,
                        &previous_u1,
                        &previous_u2,
                        &previous_s1,
                        &previous_s2})
      field->reinit(owned_nodes, relevant_nodes, comm);

    if (fe.degree > 1)
      {
        DynamicSparsityPattern mass_pattern(relevant_nodes);
        DoFTools::make_sparsity_pattern(dof_handler,
                                        mass_pattern,
                                        hanging_node_constraints,
                                        false);
        SparsityTools::distribute_sparsity_pattern(mass_pattern,
                                                   owned_nodes,
                                                   comm,
                                                   relevant_nodes);
        mass_matrix.reinit(owned_nodes, owned_nodes, mass_pattern, comm);
      }

    if (parameters.estimators.enabled)
      {
        flux_reconstruction = std::make_unique<VI::FluxReconstruction<dim>>(
          *mapping,
          parameters.estimators.flux_degree_for(fe.degree),
          fe.degree);
        flux_reconstruction->reinit(dof_handler);
        vertex_dofs.assign(triangulation.n_vertices(),
                           numbers::invalid_dof_index);
        for (const auto &cell : dof_handler.active_cell_iterators())
          if (!cell->is_artificial())
            for (const unsigned int v : cell->vertex_indices())
              vertex_dofs[cell->vertex_index(v)] = cell->vertex_dof_index(v, 0);
      }

    // The ring of every owned node (ring test: where contact begins).
    node_ring.clear();
    if (data.name == "ring")
      {
        std::map<types::global_dof_index, Point<dim>> support_points;
        DoFTools::map_dofs_to_support_points(*mapping,
                                             dof_handler,
                                             support_points);
        node_ring.resize(owned_nodes.n_elements());
        for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
          node_ring[k] =
            ring_index(support_points.at(owned_nodes.nth_index_in_set(k)),
                       center);
      }
  }


  // The constraints of u1, u2 and X with the boundary data at the time of
  // `data` (rebuilt every step when g depends on t).
  template <int dim>
  void
  ParabolicProblem<dim>::make_constraints()
  {
    const auto make_dirichlet = [&](const Function<dim>       &g,
                                    AffineConstraints<double> &constraints) {
      constraints.clear();
      constraints.reinit(relevant_nodes);
      constraints.merge(hanging_node_constraints);
      std::map<types::boundary_id, const Function<dim> *> boundary_data;
      for (const types::boundary_id id : triangulation.get_boundary_ids())
        boundary_data[id] = &g;
      VectorTools::interpolate_boundary_values(*mapping,
                                               dof_handler,
                                               boundary_data,
                                               constraints);
      constraints.close();
    };
    make_dirichlet(*data.g1, u1_constraints);
    make_dirichlet(*data.g2, u2_constraints);
    VI::NodalFields::make_system_constraints(u1_constraints,
                                             u2_constraints,
                                             relevant_system,
                                             system_constraints);
  }


  // E^n X = F^n for the step (t_(n-1), t_n): the blocks mu_alpha S + M / dt
  // and the load (f(t_n), psi) + (u_h^(n-1), psi) / dt, with the Dirichlet
  // data through the constraints; the coupling D (lumped masses for p = 1,
  // the identity for p >= 2); the scales of the residuals and the weights
  // of the constraint rows; the AMG preconditioner when dt changed.
  template <int dim>
  void
  ParabolicProblem<dim>::assemble_system()
  {
    TimerOutput::Scope t(timer, "assembly");

    const double dt = time_step;
    const bool   with_amg =
      parameters.linear_solver.solver == VI::LinearSolverType::gmres &&
      parameters.linear_solver.preconditioner == VI::PreconditionerType::amg;
    contact_system.matrix = 0;
    contact_system.rhs    = 0;
    if (with_amg)
      stiffness_matrix = 0;
    if (fe.degree > 1)
      mass_matrix = 0;
    Vector lumped_mass(owned_nodes, comm);

    const auto owned_cells =
      dof_handler.active_cell_iterators() | IteratorFilters::LocallyOwnedCell();
    using Iterator = typename DoFHandler<dim>::active_cell_iterator;
    // Matrices: stiffness, mass. Vectors: loads of u1 and u2, (1, psi).
    using CopyData = MeshWorker::CopyData<2, 3, 1>;
    MeshWorker::ScratchData<dim> scratch(*mapping,
                                         fe,
                                         quadrature,
                                         update_values | update_gradients |
                                           update_quadrature_points |
                                           update_JxW_values);
    CopyData                     copy(fe.n_dofs_per_cell());

    const auto cell_worker = [&](const Iterator               &cell,
                                 MeshWorker::ScratchData<dim> &scratch,
                                 CopyData                     &copy) {
      const FEValues<dim> &fe_values = scratch.reinit(cell);
      const auto          &points    = fe_values.get_quadrature_points();
      for (auto &m : copy.matrices)
        m = 0;
      for (auto &v : copy.vectors)
        v = 0;
      cell->get_dof_indices(copy.local_dof_indices[0]);
      std::vector<double> old_u1(points.size()), old_u2(points.size());
      fe_values.get_function_values(previous_u1, old_u1);
      fe_values.get_function_values(previous_u2, old_u2);

      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double load1 = data.f1->value(points[q]) + old_u1[q] / dt;
          const double load2 = data.f2->value(points[q]) + old_u2[q] / dt;
          const double dx    = fe_values.JxW(q);
          for (const unsigned int i : fe_values.dof_indices())
            {
              const double phi_i = fe_values.shape_value(i, q);
              for (const unsigned int j : fe_values.dof_indices())
                {
                  copy.matrices[0](i, j) += fe_values.shape_grad(i, q) *
                                            fe_values.shape_grad(j, q) * dx;
                  copy.matrices[1](i, j) +=
                    phi_i * fe_values.shape_value(j, q) * dx;
                }
              copy.vectors[0](i) += load1 * phi_i * dx;
              copy.vectors[1](i) += load2 * phi_i * dx;
              copy.vectors[2](i) += phi_i * dx;
            }
        }
    };

    std::vector<types::global_dof_index> system_dofs(fe.n_dofs_per_cell());
    FullMatrix<double>                   block(fe.n_dofs_per_cell());
    const auto                           copier = [&](const CopyData &copy) {
      const auto  &dofs  = copy.local_dof_indices[0];
      const double mu[2] = {data.mu1, data.mu2};
      for (const unsigned int field :
           {VI::NodalFields::u1, VI::NodalFields::u2})
        {
          for (unsigned int i = 0; i < dofs.size(); ++i)
            system_dofs[i] = index(dofs[i], field);
          block.equ(mu[field], copy.matrices[0], 1. / dt, copy.matrices[1]);
          system_constraints.distribute_local_to_global(
            block,
            copy.vectors[field],
            system_dofs,
            contact_system.matrix,
            contact_system.rhs,
            /*use_inhomogeneities_for_rhs=*/true);
        }
      if (with_amg)
        {
          block.equ(1.,
                    copy.matrices[0],
                    1. / (data.mu1 * dt),
                    copy.matrices[1]);
          u1_constraints.distribute_local_to_global(block,
                                                    dofs,
                                                    stiffness_matrix);
        }
      hanging_node_constraints.distribute_local_to_global(copy.vectors[2],
                                                          dofs,
                                                          lumped_mass);
      if (fe.degree > 1)
        hanging_node_constraints.distribute_local_to_global(copy.matrices[1],
                                                            dofs,
                                                            mass_matrix);
    };

    MeshWorker::mesh_loop(owned_cells,
                          cell_worker,
                          copier,
                          scratch,
                          copy,
                          MeshWorker::assemble_own_cells);
    contact_system.matrix.compress(VectorOperation::add);
    contact_system.rhs.compress(VectorOperation::add);
    if (with_amg)
      stiffness_matrix.compress(VectorOperation::add);
    lumped_mass.compress(VectorOperation::add);
    if (fe.degree > 1)
      mass_matrix.compress(VectorOperation::add);

    // The constraint rows must weigh like the balance rows (forces): a row
    // that enforces u1 = u2 gets the diagonal of the gap operator,
    // (E1^-1 + E2^-1)^-1 ~ E1_ii E2_ii / (E1_ii + E2_ii) (mu_r S_ii in the
    // steady case), a row that enforces X3 = 0 the coupling D_i.
    std::vector<double> stiffness_weight(owned_nodes.n_elements());
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      {
        const auto   i = owned_nodes.nth_index_in_set(k);
        const double e1 =
          contact_system.matrix.diag_element(index(i, VI::NodalFields::u1));
        const double e2 =
          contact_system.matrix.diag_element(index(i, VI::NodalFields::u2));
        stiffness_weight[k] = e1 * e2 / (e1 + e2);
      }
    contact_system.set_stiffness_weights(std::move(stiffness_weight));

    // The coupling D: lumped masses for p = 1, the identity for p >= 2.
    std::vector<types::global_dof_index> constrained_nodes;
    for (const types::global_dof_index i : owned_nodes)
      if (u1_constraints.is_constrained(i))
        constrained_nodes.push_back(i);
    contact_system.set_coupling(
      [&](const types::global_dof_index i) {
        return fe.degree == 1 ? lumped_mass(i) : 1.;
      },
      constrained_nodes);

    // The AMG hierarchy of S + M / (mu dt): once per value of dt.
    if (with_amg && preconditioner_dt != dt)
      {
        contact_system.use_contact_preconditioner(stiffness_matrix,
                                                  data.mu1,
                                                  data.mu2,
                                                  fe.degree > 1);
        preconditioner_dt = dt;
      }
  }


  // u_h^0: the interpolant of u^0 (in the discrete cone: the nodal values
  // satisfy u1_0 >= u2_0), with zero multiplier; eta_init = |u^0 - s~_h^0|.
  template <int dim>
  void
  ParabolicProblem<dim>::set_initial_values()
  {
    time = 0;
    step = 0;
    data.set_time(0.);
    Vector u1(owned_nodes, comm), u2(owned_nodes, comm);
    VectorTools::interpolate(*mapping, dof_handler, *data.initial_u1, u1);
    VectorTools::interpolate(*mapping, dof_handler, *data.initial_u2, u2);
    hanging_node_constraints.distribute(u1);
    hanging_node_constraints.distribute(u2);
    solution = 0;
    VI::NodalFields::insert(u1, VI::NodalFields::u1, solution);
    VI::NodalFields::insert(u2, VI::NodalFields::u2, solution);
    store_previous_step();
    totals          = Accumulated();
    totals.eta_init = initial_error_estimate();
    postprocess();
  }


  // X^(n-1) = X (the current solution), and u_h^(n-1), s_h^(n-1).
  template <int dim>
  void
  ParabolicProblem<dim>::store_previous_step()
  {
    previous_solution = solution;
    for (Vector &v : previous_owned)
      v.reinit(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, previous_owned[0]);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, previous_owned[1]);
    VI::average_at_violated_nodes(data.mu1,
                                  data.mu2,
                                  previous_owned[0],
                                  previous_owned[1],
                                  previous_owned[2],
                                  previous_owned[3]);
    previous_u1 = previous_owned[0];
    previous_u2 = previous_owned[1];
    previous_s1 = previous_owned[2];
    previous_s2 = previous_owned[3];
  }


  // The step (t_(n-1), t_n = t_(n-1) + dt_n): semismooth Newton from X^(n-1)
  // (with the boundary data of t_n), as in step-membranes; every accepted
  // iterate gets its space-time estimate on I_n, and the adaptive strategy
  // stops Newton when eta_lin <= gamma_lin eta_disc (for the part of
  // eta_lin this step controls).
  template <int dim>
  void
  ParabolicProblem<dim>::solve_time_step()
  {
    const double new_time = time + time_step;
    data.set_time(new_time);
    if (data.boundary_depends_on_time)
      make_constraints();
    assemble_system();
    step_oscillation = force_oscillation();

    solution = previous_solution;
    system_constraints.distribute(solution);

    stopping.start_solve();
    final_estimate.reset();

    VI::SemismoothNewton<Vector> newton(
      typename VI::SemismoothNewton<Vector>::AdditionalData(
        parameters.nonlinear_solver, C));
    contact_system.start_newton();
    contact_system.attach(newton, parameters.output.verbose ? &pcout : nullptr);
    // Every Newton iterate is estimated by the adaptive strategy (its
    // stopping test) and on request (At every check); otherwise only the
    // final one, after Newton. GMRES is watched alike.
    const auto &estimators = parameters.estimators;
    if (estimators.enabled && (stopping.adaptive() || estimators.every_check))
      {
        newton.setup_jacobian = [&](const Vector &X) {
          stopping.start_step(X);
          contact_system.setup_jacobian(X);
        };
        newton.solve_with_jacobian = [&](const Vector &rhs, Vector &dX) {
          return contact_system.solve(rhs,
                                      dX,
                                      stopping.gmres_monitor(),
                                      stopping.accepted_update_of_step());
        };
        newton.stopping_criterion = [&](const Vector         &X,
                                        const VI::NewtonStep &step) {
          return stopping.newton_criterion(X, step);
        };
      }

    newton_report  = newton.solve(solution);
    final_estimate = std::move(stopping.final_estimate);
    if (estimators.enabled && !final_estimate)
      final_estimate = estimate(solution);
  }


  // What the adaptive stopping sees of this program: the iterate with its
  // fields and fluxes, its space-time estimate on I_n, and the part of
  // eta_lin this step controls for the stopping tests.
  template <int dim>
  typename VI::AdaptiveStopping<typename ParabolicProblem<dim>::Iterate,
                                StepEstimate>::Hooks
  ParabolicProblem<dim>::stopping_hooks()
  {
    typename VI::AdaptiveStopping<Iterate, StepEstimate>::Hooks hooks;
    hooks.describe = [this](const Vector &X, Iterate &it) {
      describe_iterate(X, it);
    };
    hooks.estimate = [this](const Iterate &it, const Iterate &ahead) {
      return estimate(it, ahead);
    };
    hooks.estimate_iterate = [this](const Vector &X) { return estimate(X); };
    hooks.components       = [](const StepEstimate &e) {
      return VI::StoppingComponents{
        true, e.eta, e.eta_disc, e.eta_lin, e.eta_alg, e.eta_lin_controlled};
    };
    return hooks;
  }


  // Explicit instantiations of this file's members.
  template void
  ParabolicProblem<2>::setup_system();
  template void
  ParabolicProblem<2>::make_constraints();
  template void
  ParabolicProblem<2>::assemble_system();
  template void
  ParabolicProblem<2>::set_initial_values();
  template void
  ParabolicProblem<2>::store_previous_step();
  template void
  ParabolicProblem<2>::solve_time_step();
  template typename VI::AdaptiveStopping<typename ParabolicProblem<2>::Iterate,
                                         StepEstimate>::Hooks
  ParabolicProblem<2>::stopping_hooks();
} // namespace StepParabolic
