// step-parabolic: the discrete system (DoFs, constraints, E^n and F^n of a
// backward Euler step), the initial values, and semismooth Newton on a step.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>

#include "parabolic_problem.h"

#include <cmath>
#include <map>

namespace StepParabolic
{
  // Nodes, constraints (hanging nodes, the Dirichlet data at the current
  // time of `data`, no multiplier on constrained nodes), contact rows,
  // sparsity; the patches of the flux reconstruction. The mesh is the same
  // for all time steps.
  template <int dim>
  void
  ParabolicProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");

    distribute_nodes();
    make_constraints(*data.g1, *data.g2, data.obstacle.get());
    contact_system.reinit(owned_nodes, u1_constraints, comm);
    preconditioner_dt = 0; // none for the new matrices yet
    reinit_matrices(contact_system);
    solution.reinit(owned_system, comm);
    previous_solution.reinit(owned_system, comm);
    for (auto *field : {&previous_u1, &previous_u2, &previous_s1, &previous_s2})
      field->reinit(owned_nodes, relevant_nodes, comm);

    if (parameters.estimators.enabled)
      {
        flux_reconstruction = std::make_unique<VI::FluxReconstruction<dim>>(
          *mapping,
          parameters.estimators.flux_degree_for(fe.degree),
          fe.degree);
        flux_reconstruction->reinit(dof_handler, domain.free_boundary_ids());
        make_vertex_dofs();
        // (the bounds that take a membrane's load in L2 want g on every
        // cell at the contact set: VI::TransmittedLoad; with it, Q2 is
        // sharper at equal tensions too, doc/step-parabolic.md)
        setup_estimate_multiplier(parameters.estimators,
                                  data.mu1,
                                  data.mu2,
                                  flux_reconstruction->get_quadrature(),
                                  VI::TransmittedLoad<dim>::BoundaryCells::all);
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

    // The loads (f(t_n), psi) + (u_h^(n-1), psi) / dt of the backward Euler
    // step, from f(t_n) tabulated at the quadrature points (which the
    // estimates read too); the copier puts the blocks mu_alpha S + M / dt
    // into A and F through the constraints, and S + M / (mu dt) into the
    // matrix of AMG.
    tabulate_loads(*data.f1, *data.f2);
    const auto cell_loads = [&](const auto          &cell,
                                const FEValues<dim> &fe_values,
                                std::vector<double>(&loads)[2]) {
      const std::size_t first  = cell->active_cell_index() * quadrature.size();
      const Vector     *old[2] = {&previous_u1, &previous_u2};
      for (unsigned int a = 0; a < 2; ++a)
        {
          fe_values.get_function_values(*old[a], loads[a]);
          for (const unsigned int q : fe_values.quadrature_point_indices())
            loads[a][q] = load_values[a][first + q] + loads[a][q] / dt;
        }
    };
    std::vector<types::global_dof_index> system_dofs(fe.n_dofs_per_cell());
    FullMatrix<double>                   block(fe.n_dofs_per_cell());
    const double                         mu[2]       = {data.mu1, data.mu2};
    const auto                           copy_system = [&](const auto &copy) {
      const auto &dofs = copy.local_dof_indices[0];
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
    };
    const Vector lumped_mass = assemble_cells(cell_loads,
                                              update_default,
                                              /*mass_term=*/true,
                                              copy_system);
    contact_system.matrix.compress(VectorOperation::add);
    contact_system.rhs.compress(VectorOperation::add);
    if (with_amg)
      stiffness_matrix.compress(VectorOperation::add);

    // The constraint rows must weigh like the balance rows (forces): a row
    // that enforces u1 = u2 gets the diagonal of the gap operator,
    // (E1^-1 + E2^-1)^-1 ~ E1_ii E2_ii / (E1_ii + E2_ii) (mu_r S_ii in the
    // steady case; E1_ii over a rigid obstacle), a row that enforces X3 = 0
    // the coupling D_i.
    std::vector<double> stiffness_weight(owned_nodes.n_elements());
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      {
        const auto   i = owned_nodes.nth_index_in_set(k);
        const double e1 =
          contact_system.matrix.diag_element(index(i, VI::NodalFields::u1));
        const double e2 =
          contact_system.matrix.diag_element(index(i, VI::NodalFields::u2));
        stiffness_weight[k] = data.obstacle ? e1 : e1 * e2 / (e1 + e2);
      }
    contact_system.set_stiffness_weights(std::move(stiffness_weight));

    // The coupling D: lumped masses for p = 1, the identity for p >= 2.
    set_coupling(contact_system, lumped_mass, data.mu1, data.mu2);

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
    VI::NodalFields::insert_displacements(u1, u2, solution);
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
    potentials(solution,
               data.mu1,
               data.mu2,
               previous_owned,
               {{&previous_u1, &previous_u2, &previous_s1, &previous_s2}});
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
    // (the constraints carry the boundary data, and u2 = I_h psi over an
    // obstacle, of t_n)
    if (data.boundary_depends_on_time || data.obstacle_depends_on_time)
      make_constraints(*data.g1, *data.g2, data.obstacle.get());
    assemble_system();
    step_oscillation = force_oscillation();

    solution = previous_solution;
    system_constraints.distribute(solution);

    stopping.start_solve({double(dof_handler.n_dofs()), dim, fe.degree});
    final_estimate.reset();

    VI::SemismoothNewton<Vector> newton =
      contact_system.make_newton(parameters.output.verbose ? &pcout : nullptr);
    // Every Newton iterate is estimated by the adaptive strategy (its
    // stopping test) and on request (At every check); otherwise only the
    // final one, after Newton. GMRES is watched alike.
    const auto &estimators = parameters.estimators;
    if (estimators.enabled && (stopping.adaptive() || estimators.every_check))
      {
        newton.setup_jacobian = [&](const Vector &X) {
          stopping.start_step(X);
          if (multiplier_needs_contact_set())
            contact_nodes(contact_system, X, step_contact_nodes);
          contact_system.setup_jacobian(X);
        };
        newton.solve_with_jacobian = [&](const Vector &rhs, Vector &dX) {
          return stopping.solve_watched(contact_system, rhs, dX);
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
      describe_iterate(X, step_contact_nodes, it);
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
