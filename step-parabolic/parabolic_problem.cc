#include "parabolic_problem.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_solver.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace StepParabolic
{
  using VI::NodalFields::index;
  using VI::NodalFields::multiplier;
  using VI::NodalFields::n_fields;

  // The bound and its components up to the current time (see StepEstimate
  // and doc/step-parabolic.md): with the cone correction d = s~ - u_h,
  //   |||u - u_ht|||_(0,t) + |(u - u_h)(t)| <= eta
  //     = (eta_init^2 + sum_n eta_n^2)^(1/2)
  //       + (sum_n int_In |||d|||^2 + |d(t)|^2)^(1/2),
  // and each part is split by the triangle inequality.
  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta() const
  {
    return std::sqrt(eta_init * eta_init + eta_squared) +
           std::sqrt(nonc_squared + final_nonc * final_nonc);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_disc() const
  {
    return std::sqrt(disc_squared) +
           std::sqrt(nonc_squared_disc + final_nonc_disc * final_nonc_disc);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_lin() const
  {
    return std::sqrt(lin_squared) +
           std::sqrt(nonc_squared_lin + final_nonc_lin * final_nonc_lin);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::eta_alg() const
  {
    return std::sqrt(alg_squared);
  }


  template <int dim>
  double
  ParabolicProblem<dim>::Accumulated::error() const
  {
    return std::sqrt(error_squared + final_error * final_error);
  }


  template <int dim>
  ParabolicProblem<dim>::ParabolicProblem(const Parameters &parameters,
                                          ParameterHandler &prm,
                                          const MPI_Comm    comm)
      : parameters(parameters)
      , prm(prm)
      , comm(comm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , geometry(VI::geometry_from_name(parameters.mesh.geometry))
      , center(VI::geometry_center<dim>(geometry))
      , data(make_parabolic_data<dim>(parameters.problem, center))
      , C(VI::ComplementarityFunction::from_name(
          parameters.nonlinear_solver.c_function))
      , friedrichs_constant(VI::friedrichs_constant(geometry))
      , triangulation(comm)
      , geometry_mapping(
          VI::make_mapping<dim>(geometry, parameters.discretization.degree))
      , mapping(std::make_unique<MappingQCache<dim>>(
          dynamic_cast<const MappingQ<dim> &>(*geometry_mapping).get_degree()))
      , fe(parameters.discretization.degree)
      , dof_handler(triangulation)
      // One quadrature for the load, the mass matrix, the flux reconstruction
      // and the estimators: the patch problems are then exactly compatible
      // with the discrete equations.
      , quadrature(VI::FluxReconstruction<dim>::quadrature_points(
          parameters.discretization.degree))
      , contact_system(C,
                       parameters.nonlinear_solver,
                       parameters.linear_solver,
                       timer)
      , multiplier_function(fe.degree,
                            contact_system.contact_rows(),
                            contact_system.coupling(),
                            mass_matrix,
                            hanging_node_constraints,
                            ghosted_nodes)
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
  {
  }


  template <int dim>
  void
  ParabolicProblem<dim>::make_grid()
  {
    VI::make_coarse_mesh(geometry, triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
    mapping->initialize(*geometry_mapping, triangulation);
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (at t = 0 and at the final time) and an initial state in the cone,
  // u1_0 >= u2_0, checked at the quadrature points and the nodes of the
  // first mesh before anything is written.
  template <int dim>
  void
  ParabolicProblem<dim>::check_data() const
  {
    std::string violation;
    const auto  report = [&](const std::string &message) {
      if (violation.empty())
        violation = message;
    };
    const auto below = [](const double a, const double b) {
      return a - b < -1e-12 * std::max({1., std::abs(a), std::abs(b)});
    };

    std::vector<Point<dim>> unit_points = quadrature.get_points();
    for (const auto &p : fe.get_unit_support_points())
      unit_points.push_back(p);

    for (const double t : {0., parameters.time.final_time})
      {
        data.set_time(t);
        for (const auto &cell : triangulation.active_cell_iterators())
          if (cell->is_locally_owned() && violation.empty())
            {
              for (const auto &unit_point : unit_points)
                {
                  const Point<dim> p =
                    mapping->transform_unit_to_real_cell(cell, unit_point);
                  std::ostringstream message;
                  const double f1 = data.f1->value(p), f2 = data.f2->value(p);
                  const double a = data.initial_u1->value(p),
                               b = data.initial_u2->value(p);
                  if (!std::isfinite(f1) || !std::isfinite(f2))
                    message << "the forces are not finite at (" << p
                            << "), t = " << t << ": f1 = " << f1
                            << ", f2 = " << f2;
                  else if (!std::isfinite(a) || !std::isfinite(b))
                    message << "the initial data are not finite at (" << p
                            << "): u1_0 = " << a << ", u2_0 = " << b;
                  else if (below(a, b))
                    message << "u1_0 < u2_0 at (" << p << "): u1_0 = " << a
                            << ", u2_0 = " << b
                            << "; the initial state must satisfy u1 >= u2";
                  if (!message.str().empty())
                    report(message.str());
                }
              for (const unsigned int f : cell->face_indices())
                if (cell->face(f)->at_boundary())
                  for (const auto &unit_point : fe.get_unit_support_points())
                    {
                      // Face 2d + s of the unit cell is {x_d = s}.
                      if (std::abs(unit_point[f / 2] - double(f % 2)) > 1e-12)
                        continue;
                      const Point<dim> p =
                        mapping->transform_unit_to_real_cell(cell, unit_point);
                      const double g1 = data.g1->value(p),
                                   g2 = data.g2->value(p);
                      std::ostringstream message;
                      if (!std::isfinite(g1) || !std::isfinite(g2))
                        message << "the boundary data are not finite at (" << p
                                << "), t = " << t << ": g1 = " << g1
                                << ", g2 = " << g2;
                      else if (below(g1, g2))
                        message << "g1 < g2 on the boundary at (" << p
                                << "), t = " << t << ": g1 = " << g1
                                << ", g2 = " << g2
                                << "; the constraint u1 >= u2 cannot hold "
                                   "there";
                      if (!message.str().empty())
                        report(message.str());
                    }
            }
      }
    data.set_time(0.);
    for (const std::string &message :
         Utilities::MPI::all_gather(comm, violation))
      if (!message.empty())
        throw VI::InputError("Problem: " + message);
  }


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

    const double dt       = time_step;
    const bool   with_amg = parameters.linear_solver.solver == "gmres" &&
                          parameters.linear_solver.preconditioner == "amg";
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


  // The iterate as the estimators need it (see step-membranes): u_h, s_h,
  // lambda_h and its part from nonnegative coefficients, the residual r_h
  // (<r_h, psi_i>_h = (F - E X)_i), d_t u_h = (u_h - u_h^(n-1)) / dt_n, and
  // the fluxes equilibrated with f(t_n) - d_t u_h -/+ lambda_h - r_h.
  template <int dim>
  void
  ParabolicProblem<dim>::describe_iterate(const Vector &X, Iterate &it) const
  {
    TimerOutput::Scope t(timer, "estimators: fluxes");
    it.X = X;

    Vector u1(owned_nodes, comm), u2(owned_nodes, comm), s1(owned_nodes, comm),
      s2(owned_nodes, comm), moments(owned_nodes, comm),
      function(owned_nodes, comm);
    // (The layout of u1_h, copied, is much cheaper than a new one.)

    VI::NodalFields::extract(X, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(X, VI::NodalFields::u2, u2);
    VI::average_at_violated_nodes(data.mu1, data.mu2, u1, u2, s1, s2);
    ghosted_nodes.copy(u1, it.u1);
    ghosted_nodes.copy(u2, it.u2);
    ghosted_nodes.copy(s1, it.s1);
    ghosted_nodes.copy(s2, it.s2);
    it.owned[0] = u1;
    it.owned[1] = u2;
    it.owned[2] = s1;
    it.owned[3] = s2;

    // d_t u_h, from the owned values of u_h^(n-1).
    for (const auto &[u, old, target] :
         {std::tuple<Vector *, const Vector *, Vector *>{&u1,
                                                         &previous_u1,
                                                         &it.dt_u1},
          {&u2, &previous_u2, &it.dt_u2}})
      {
        for (const types::global_dof_index i : owned_nodes)
          function(i) = ((*u)(i) - (*old)(i)) / time_step;
        function.compress(VectorOperation::insert);
        ghosted_nodes.copy(function, *target);
      }

    VI::NodalFields::extract(X, multiplier, moments);
    moments.scale(contact_system.coupling());
    multiplier_function.with_nonnegative_part(moments,
                                              it.lambda,
                                              it.lambda_nonnegative);

    Vector R(owned_system, comm);
    contact_system.matrix.vmult(R, X);
    R.sadd(-1., 1., contact_system.rhs);
    Vector *r[2] = {&it.r1, &it.r2};
    for (const unsigned int field : {VI::NodalFields::u1, VI::NodalFields::u2})
      {
        VI::NodalFields::extract(R, field, moments);
        for (const types::global_dof_index i : owned_nodes)
          if (u1_constraints.is_constrained(i))
            moments(i) = 0;
        moments.compress(VectorOperation::insert);
        multiplier_function.from_moments(moments, function);
        ghosted_nodes.copy(function, *r[field]);
      }

    // The mass term enters the source at the quadrature points, as in the
    // assembly, so that the patch problems stay compatible; for p = 1 the
    // multiplier and the residual enter as vertex constants (lumping).
    const bool           lumped  = fe.degree == 1;
    const Vector        *u[2]    = {&it.u1, &it.u2};
    const Vector        *dt_u[2] = {&it.dt_u1, &it.dt_u2};
    const Function<dim> *f[2]    = {data.f1.get(), data.f2.get()};
    const double         mu[2]   = {data.mu1, data.mu2};
    const double         sign[2] = {-1., 1.}; // (-1)^alpha

    typename VI::FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = 2;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of the potential and value arrays
      const unsigned int n_q = quadrature.size();
      return [&,
              values_of = std::make_shared<FEValues<dim>>(
                *mapping,
                fe,
                flux_reconstruction->get_quadrature(),
                update_values | update_gradients | update_quadrature_points),
              lambda_values = std::vector<double>(n_q),
              r_values      = std::vector<double>(n_q),
              dt_values     = std::vector<double>(
                n_q)](const auto &cell, auto &flux, auto &source) mutable {
        typename DoFHandler<dim>::active_cell_iterator dof_cell(&triangulation,
                                                                cell->level(),
                                                                cell->index(),
                                                                &dof_handler);
        FEValues<dim>                                 &values = *values_of;
        values.reinit(dof_cell);
        if (!lumped)
          values.get_function_values(it.lambda, lambda_values);
        for (unsigned int a = 0; a < 2; ++a)
          {
            values.get_function_gradients(*u[a], flux[a]);
            for (auto &F : flux[a])
              F *= mu[a];
            f[a]->value_list(values.get_quadrature_points(), source[a]);
            values.get_function_values(*dt_u[a], dt_values);
            if (!lumped)
              values.get_function_values(*r[a], r_values);
            for (unsigned int q = 0; q < source[a].size(); ++q)
              {
                source[a][q] -= dt_values[q];
                if (!lumped)
                  source[a][q] -= sign[a] * lambda_values[q] + r_values[q];
              }
          }
      };
    };
    if (lumped)
      sources.vertex_source = [&](const unsigned int vertex,
                                  const unsigned int a) {
        const auto i = vertex_dofs[vertex];
        return -sign[a] * it.lambda(i) - (*r[a])(i);
      };
    flux_reconstruction->reconstruct(sources, {&it.sigma1, &it.sigma2});
  }


  template <int dim>
  std::vector<std::pair<double, double>>
  ParabolicProblem<dim>::time_points() const
  {
    // The trapezoidal rule. The integrand is convex in t when s~_ht is
    // linear in t, which holds at the end points (where the cone
    // reconstruction is computed), so the rule bounds the integral from
    // above; for the temporal part |||u_h^n - u_h^(n-1)|||^2 it gives 1/2
    // where the exact integral has 1/3.
    return {{0., 0.5}, {1., 0.5}};
  }


  template <int dim>
  void
  ParabolicProblem<dim>::interpolate_in_time(const Vector &a,
                                             const Vector &b,
                                             const double  theta,
                                             Vector       &result) const
  {
    Assert(!a.has_ghost_elements() && !b.has_ghost_elements(),
           ExcMessage("Interpolate vectors without ghosts."));
    if (interpolation_buffer.size() != a.size())
      interpolation_buffer.reinit(owned_nodes, comm);
    interpolation_buffer.equ(1. - theta, a);
    interpolation_buffer.add(theta, b);
    if (!result.has_ghost_elements() || result.size() != a.size())
      result.reinit(u1_h, true);
    result = interpolation_buffer;
  }


  // The terms of the step estimate that are not those of the steady
  // problem, from one loop over the cells: with the cone correction
  // d = s~_h - u_h (d_lin = s_h - u_h at the nodes, d_disc = s~_h - s_h the
  // pointwise correction (theta w, -(1 - theta) w), w = (s2 - s1)^+, zero
  // for p = 1),
  // - eta_dt = C_F (sum_alpha mu_alpha^-1 |d_t d_alpha|^2)^(1/2), which
  //   bounds (d_t d, v) by |||v|||, split into disc and lin parts, and the
  //   part of this step alone, C_F |d_lin^n| / dt (stopping criterion);
  // - |d^n| (L2) and its parts, for the final-time term;
  // - |||u_h^n - u_h^(n-1)|||, for the temporal estimator.
  template <int dim>
  typename ParabolicProblem<dim>::ParabolicTerms
  ParabolicProblem<dim>::parabolic_terms(const Iterate &it) const
  {
    TimerOutput::Scope          t(timer, "estimators: evaluation");
    FEValues<dim>               values(*mapping,
                         fe,
                         quadrature,
                         update_values | update_gradients | update_JxW_values);
    const unsigned int          n_q   = quadrature.size();
    const double                mu[2] = {data.mu1, data.mu2};
    const double                theta = data.mu2 / (data.mu1 + data.mu2);
    std::vector<double>         u[2], s[2], u_old[2], s_old[2];
    std::vector<Tensor<1, dim>> grad_u[2], grad_u_old[2];
    for (unsigned int a = 0; a < 2; ++a)
      for (auto *v : {&u[a], &s[a], &u_old[a], &s_old[a]})
        v->resize(n_q);
    for (unsigned int a = 0; a < 2; ++a)
      {
        grad_u[a].resize(n_q);
        grad_u_old[a].resize(n_q);
      }
    const Vector *now_u[2] = {&it.u1, &it.u2}, *now_s[2] = {&it.s1, &it.s2},
                 *old_u[2] = {&previous_u1, &previous_u2},
                 *old_s[2] = {&previous_s1, &previous_s2};

    // Squared norms: dt-change of d (disc, lin) weighted by 1/mu, d^n
    // (lin, weighted by 1/mu), |d^n|^2 (total, disc, lin), |||du|||^2.
    enum
    {
      change_disc,
      change_lin,
      now_lin_weighted,
      final_total,
      final_disc,
      final_lin,
      time_energy,
      n_sums
    };
    double sums[n_sums] = {};
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              values.get_function_values(*now_u[a], u[a]);
              values.get_function_values(*now_s[a], s[a]);
              values.get_function_values(*old_u[a], u_old[a]);
              values.get_function_values(*old_s[a], s_old[a]);
              values.get_function_gradients(*now_u[a], grad_u[a]);
              values.get_function_gradients(*old_u[a], grad_u_old[a]);
            }
          for (unsigned int q = 0; q < n_q; ++q)
            {
              const double dx      = values.JxW(q);
              const double w       = std::max(s[1][q] - s[0][q], 0.);
              const double w_old   = std::max(s_old[1][q] - s_old[0][q], 0.);
              const double disc[2] = {theta * w, -(1. - theta) * w};
              const double disc_old[2] = {theta * w_old, -(1. - theta) * w_old};
              for (unsigned int a = 0; a < 2; ++a)
                {
                  const double lin     = s[a][q] - u[a][q];
                  const double lin_old = s_old[a][q] - u_old[a][q];
                  sums[change_disc] +=
                    std::pow(disc[a] - disc_old[a], 2) / mu[a] * dx;
                  sums[change_lin] += std::pow(lin - lin_old, 2) / mu[a] * dx;
                  sums[now_lin_weighted] += lin * lin / mu[a] * dx;
                  sums[final_total] += std::pow(lin + disc[a], 2) * dx;
                  sums[final_disc] += disc[a] * disc[a] * dx;
                  sums[final_lin] += lin * lin * dx;
                  sums[time_energy] +=
                    mu[a] * (grad_u[a][q] - grad_u_old[a][q]).norm_square() *
                    dx;
                }
            }
        }
    double total[n_sums];
    Utilities::MPI::sum(ArrayView<const double>(sums, n_sums),
                        comm,
                        ArrayView<double>(total, n_sums));
    std::copy(total, total + n_sums, sums);

    ParabolicTerms terms;
    const double   factor = friedrichs_constant / time_step;
    terms.eta_dt_disc     = factor * std::sqrt(sums[change_disc]);
    terms.eta_dt_lin      = factor * std::sqrt(sums[change_lin]);
    // |d_t d| <= |d_t d_disc| + |d_t d_lin|: the bound and its split.
    terms.eta_dt                = terms.eta_dt_disc + terms.eta_dt_lin;
    terms.eta_dt_lin_controlled = factor * std::sqrt(sums[now_lin_weighted]);
    terms.final_nonc            = std::sqrt(sums[final_total]);
    terms.final_nonc_disc       = std::sqrt(sums[final_disc]);
    terms.final_nonc_lin        = std::sqrt(sums[final_lin]);
    terms.time_energy           = std::sqrt(sums[time_energy]);
    return terms;
  }


  // The estimate of the step for an iterate (with a look-ahead iterate for
  // the algebraic part, see step-membranes): the steady estimators of
  // VI::estimate_contact_error at the points of time_points() for u_ht(t),
  // s_ht(t) (linear in t), lambda_h^n, sigma^n, combined as in StepEstimate.
  // With A(t) = eta_1 + eta_nonc1 + eta_nonc2 + eta_dt and its split
  // A + (eta_C)^(1/2) <= D + L + G,
  //   D = eta_1,disc + eta_nonc1,disc + eta_nonc2,disc + eta_dt,disc
  //       + (eta_C,disc^+)^(1/2),
  //   L = eta_nonc1,lin + eta_nonc2,lin + eta_dt,lin + (eta_C,lin^+)^(1/2),
  //   G = |mu^-1/2 sigma_alg| + remainder,
  // eta_n <= |D|_In + |L|_In + |G|_In + |eta_osc|_In.
  template <int dim>
  StepEstimate
  ParabolicProblem<dim>::estimate(const Iterate &it, const Iterate &ahead) const
  {
    const ParabolicTerms terms = parabolic_terms(it);

    TimerOutput::Scope             t(timer, "estimators: evaluation");
    VI::ContactEstimatorInput<dim> in;
    in.mapping             = mapping.get();
    in.potential           = &dof_handler;
    in.flux                = &flux_reconstruction->get_dof_handler();
    in.quadrature          = &flux_reconstruction->get_quadrature();
    in.flux_signs          = &flux_reconstruction->get_piola_signs();
    in.mu1                 = data.mu1;
    in.mu2                 = data.mu2;
    in.f1                  = data.f1.get();
    in.f2                  = data.f2.get();
    in.friedrichs_constant = friedrichs_constant;
    in.mass_lumped         = fe.degree == 1;
    in.lambda              = &it.lambda;
    in.lambda_nonnegative  = &it.lambda_nonnegative;
    in.sigma1_disc         = &it.sigma1;
    in.sigma2_disc         = &it.sigma2;
    in.dt_u1               = &it.dt_u1;
    in.dt_u2               = &it.dt_u2;
    in.lambda_ahead        = &ahead.lambda;
    in.r1_ahead            = &ahead.r1;
    in.r2_ahead            = &ahead.r2;
    in.sigma1_ahead        = &ahead.sigma1;
    in.sigma2_ahead        = &ahead.sigma2;
    in.dt_u1_ahead         = &ahead.dt_u1;
    in.dt_u2_ahead         = &ahead.dt_u2;

    StepEstimate e;
    double       integral[4] = {}; // of A^2 + eta_C, D^2, L^2, G^2
    Vector       u1, u2, s1, s2;
    double       D_end = 0;
    for (const auto &[theta, weight] : time_points())
      {
        if (theta == 1.)
          {
            in.u1 = &it.u1;
            in.u2 = &it.u2;
            in.s1 = &it.s1;
            in.s2 = &it.s2;
          }
        else if (theta == 0.)
          {
            in.u1 = &previous_u1;
            in.u2 = &previous_u2;
            in.s1 = &previous_s1;
            in.s2 = &previous_s2;
          }
        else
          {
            interpolate_in_time(previous_owned[0], it.owned[0], theta, u1);
            interpolate_in_time(previous_owned[1], it.owned[1], theta, u2);
            interpolate_in_time(previous_owned[2], it.owned[2], theta, s1);
            interpolate_in_time(previous_owned[3], it.owned[3], theta, s2);
            in.u1 = &u1;
            in.u2 = &u2;
            in.s1 = &s1;
            in.s2 = &s2;
          }
        VI::ContactEstimate c = VI::estimate_contact_error(in);

        const double A = c.eta_1 + c.nonc_1 + c.nonc_2 + terms.eta_dt;
        const double D = c.eta_1_disc + c.nonc_1_disc + c.nonc_2_disc +
                         terms.eta_dt_disc +
                         std::sqrt(std::max(c.contact_disc, 0.));
        const double L_other =
          c.nonc_1_lin + c.nonc_2_lin + std::sqrt(std::max(c.contact_lin, 0.));
        const double L = L_other + terms.eta_dt_lin;
        const double G = c.flux_alg + c.remainder;
        integral[0] += weight * (A * A + c.contact_cone);
        integral[1] += weight * D * D;
        integral[2] += weight * L * L;
        integral[3] += weight * G * G;
        e.nonc_squared += weight * c.nonc_1 * c.nonc_1;
        e.nonc_squared_disc += weight * c.nonc_1_disc * c.nonc_1_disc;
        e.nonc_squared_lin += weight * c.nonc_1_lin * c.nonc_1_lin;
        if (theta == 1.)
          {
            D_end = D;
            // What this Newton iteration controls: the iterate at t_n (at
            // earlier times u_ht mixes in u_h^(n-1)).
            e.eta_lin_controlled =
              std::sqrt(time_step) * (L_other + terms.eta_dt_lin_controlled);
            e.at_end = std::move(c);
          }
      }

    const double dt = time_step;
    e.oscillation   = step_oscillation;
    e.eta           = std::sqrt(dt * integral[0]) + e.oscillation;
    e.eta_disc      = std::sqrt(dt * integral[1]) + e.oscillation;
    e.eta_lin       = std::sqrt(dt * integral[2]);
    e.eta_alg       = std::sqrt(dt * integral[3]);
    e.eta_dt        = terms.eta_dt;
    e.nonc_squared *= dt;
    e.nonc_squared_disc *= dt;
    e.nonc_squared_lin *= dt;
    e.final_nonc      = terms.final_nonc;
    e.final_nonc_disc = terms.final_nonc_disc;
    e.final_nonc_lin  = terms.final_nonc_lin;
    e.eta_time        = std::sqrt(dt / 3.) * terms.time_energy;
    e.eta_space       = std::sqrt(dt) * D_end;
    return e;
  }


  // The estimate of X with itself as look-ahead (sigma_alg = 0, the whole
  // algebraic residual in the remainder).
  template <int dim>
  StepEstimate
  ParabolicProblem<dim>::estimate(const Vector &X) const
  {
    Iterate it;
    describe_iterate(X, it);
    return estimate(it, it);
  }


  // eta_init = |u^0 - s~_h^0| (L2, both membranes): the initial error of the
  // cone function the bound is built on (s~_h^0 = u_h^0 for p = 1).
  template <int dim>
  double
  ParabolicProblem<dim>::initial_error_estimate() const
  {
    const QGauss<dim>   error_quadrature(fe.degree + 3);
    FEValues<dim>       values(*mapping,
                         fe,
                         error_quadrature,
                         update_values | update_quadrature_points |
                           update_JxW_values);
    const unsigned int  n_q   = error_quadrature.size();
    const double        theta = data.mu2 / (data.mu1 + data.mu2);
    std::vector<double> uh[2], sh[2], exact[2];
    for (unsigned int a = 0; a < 2; ++a)
      for (auto *v : {&uh[a], &sh[a], &exact[a]})
        v->resize(n_q);
    double local = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          values.get_function_values(previous_u1, uh[0]);
          values.get_function_values(previous_u2, uh[1]);
          values.get_function_values(previous_s1, sh[0]);
          values.get_function_values(previous_s2, sh[1]);
          data.initial_u1->value_list(values.get_quadrature_points(), exact[0]);
          data.initial_u2->value_list(values.get_quadrature_points(), exact[1]);
          for (unsigned int q = 0; q < n_q; ++q)
            {
              const double w             = std::max(sh[1][q] - sh[0][q], 0.);
              const double correction[2] = {theta * w, -(1. - theta) * w};
              for (unsigned int a = 0; a < 2; ++a)
                local += std::pow(exact[a][q] - sh[a][q] - correction[a], 2) *
                         values.JxW(q);
            }
        }
    return std::sqrt(Utilities::MPI::sum(local, comm));
  }


  // |eta_osc|_L2(In) = C_F (int_In sum_alpha mu_alpha^-1
  // |f_alpha(t) - f_alpha(t_n)|^2 dt)^(1/2): the load of the scheme is
  // f(t_n), the equation holds with f(t). Three Gauss points in time; zero
  // for forces independent of t.
  template <int dim>
  double
  ParabolicProblem<dim>::force_oscillation() const
  {
    if (!data.forces_depend_on_time)
      return 0.;
    const double        t_n = time + time_step;
    const QGauss<1>     in_time(3);
    FEValues<dim>       values(*mapping,
                         fe,
                         quadrature,
                         update_quadrature_points | update_JxW_values);
    const unsigned int  n_q   = quadrature.size();
    const double        mu[2] = {data.mu1, data.mu2};
    Function<dim>      *f[2]  = {data.f1.get(), data.f2.get()};
    std::vector<double> now(n_q), then(n_q);
    double              local = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              f[a]->set_time(t_n);
              f[a]->value_list(values.get_quadrature_points(), now);
              for (unsigned int k = 0; k < in_time.size(); ++k)
                {
                  f[a]->set_time(time + time_step * in_time.point(k)[0]);
                  f[a]->value_list(values.get_quadrature_points(), then);
                  for (unsigned int q = 0; q < n_q; ++q)
                    local += in_time.weight(k) * time_step *
                             std::pow(then[q] - now[q], 2) / mu[a] *
                             values.JxW(q);
                }
            }
        }
    data.set_time(t_n);
    return friedrichs_constant * std::sqrt(Utilities::MPI::sum(local, comm));
  }


  // The solution of the step as finite element functions; the contact set
  // (and, for the ring test, its size in every ring).
  template <int dim>
  void
  ParabolicProblem<dim>::postprocess()
  {
    TimerOutput::Scope t(timer, "postprocess");
    Vector             u1(owned_nodes, comm), u2(owned_nodes, comm),
      field(owned_nodes, comm), lambda(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, u2);
    u1_h = u1;
    u2_h = u2;
    u1 -= u2;
    gap_h = u1;

    VI::NodalFields::extract(solution, multiplier, field);
    field.scale(contact_system.coupling());
    multiplier_function.from_moments(field, lambda);
    lambda_h = lambda;

    n_contact_nodes =
      contact_system.contact_rows().contact_set(solution, field);
    contact_set = field;
    contact_per_ring.clear();
    if (!node_ring.empty())
      {
        std::vector<double> local(5, 0.), total(5);
        for (std::size_t k = 0; k < node_ring.size(); ++k)
          if (field(owned_nodes.nth_index_in_set(k)) > 0.5)
            local[node_ring[k]] += 1.;
        Utilities::MPI::sum(local, comm, total);
        for (const double n : total)
          contact_per_ring.push_back(std::llround(n));
      }
  }


  // With an exact solution: int_In |||u - u_ht|||^2 dt (two Gauss points in
  // time, u_ht linear between u_h^(n-1) and u_h^n), |u(t_n) - u_h^n| and
  // |||u(t_n) - u_h^n|||.
  template <int dim>
  void
  ParabolicProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope t(timer, "errors");

    const QGauss<dim>      error_quadrature(fe.degree + 3);
    dealii::Vector<double> cellwise(triangulation.n_active_cells());
    const auto             error = [&](const Vector               &uh,
                           const Function<dim>        &exact,
                           const VectorTools::NormType norm) {
      VectorTools::integrate_difference(
        *mapping, dof_handler, uh, exact, cellwise, error_quadrature, norm);
      return VectorTools::compute_global_error(triangulation, cellwise, norm);
    };
    const auto energy_error = [&](const Vector &v1, const Vector &v2) {
      const double e1 = error(v1, *data.exact_u1, VectorTools::H1_seminorm);
      const double e2 = error(v2, *data.exact_u2, VectorTools::H1_seminorm);
      return data.mu1 * e1 * e1 + data.mu2 * e2 * e2;
    };

    Vector u1(owned_nodes, comm), u2(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, u2);
    const QGauss<1> in_time(2);
    Vector          v1, v2;
    double          integral = 0;
    for (unsigned int k = 0; k < in_time.size(); ++k)
      {
        const double theta = in_time.point(k)[0];
        data.set_time(time + theta * time_step);
        interpolate_in_time(previous_owned[0], u1, theta, v1);
        interpolate_in_time(previous_owned[1], u2, theta, v2);
        integral += in_time.weight(k) * time_step * energy_error(v1, v2);
      }
    data.set_time(time + time_step);
    totals.error_squared += integral;
    step_error_energy  = std::sqrt(energy_error(u1_h, u2_h));
    const double l1    = error(u1_h, *data.exact_u1, VectorTools::L2_norm);
    const double l2    = error(u2_h, *data.exact_u2, VectorTools::L2_norm);
    totals.final_error = std::sqrt(l1 * l1 + l2 * l2);
  }


  // Adaptive time steps: the temporal estimator eta_time^n + |eta_osc|_In
  // ((dt/3)^(1/2) |||u^n - u^(n-1)||| ~ dt^(3/2), and the change of the
  // forces, also ~ dt^(3/2)) over the spatial one eta_space^n (~ dt^(1/2))
  // grows like dt, so the step that meets the target ratio is
  // dt target / ratio; it is
  // taken with a safety factor 0.9, limited to a change by a factor in
  // [1/5, Growth factor] and to [Minimal, Maximal time step]. A step whose
  // ratio exceeds Rejection factor times the target is recomputed.
  template <int dim>
  void
  ParabolicProblem<dim>::choose_next_time_step(const StepEstimate &e,
                                               bool               &accept)
  {
    const auto &ts = parameters.time;
    accept         = true;
    if (!ts.adaptive)
      {
        next_time_step = ts.time_step;
        return;
      }
    const double target = ts.time_space_ratio;
    const double ratio =
      e.eta_space > 0 ? (e.eta_time + e.oscillation) / e.eta_space : 0.;
    const double factor =
      ratio > 0 ? std::clamp(0.9 * target / ratio, 0.2, ts.growth_factor) :
                  ts.growth_factor;
    next_time_step = std::clamp(time_step * factor,
                                ts.minimal_time_step,
                                ts.maximal_time_step);
    if (ratio > ts.rejection_factor * target &&
        time_step > ts.minimal_time_step * (1. + 1e-12))
      accept = false;
  }


  namespace
  {
    VI::Json
    to_json(const StepEstimate &e)
    {
      VI::Json json         = VI::Json::object();
      json["eta"]           = e.eta;
      json["eta_disc"]      = e.eta_disc;
      json["eta_lin"]       = e.eta_lin;
      json["eta_alg"]       = e.eta_alg;
      json["eta_time"]      = e.eta_time;
      json["eta_space"]     = e.eta_space;
      json["oscillation"]   = e.oscillation;
      json["eta_dt"]        = e.eta_dt;
      json["nonc_squared"]  = e.nonc_squared;
      json["final_nonc"]    = e.final_nonc;
      json["flux_disc_end"] = e.at_end.flux_disc;
      json["residual_end"]  = e.at_end.residual;
      json["contact_end"]   = e.at_end.contact_cone;
      return json;
    }
  } // namespace


  template <int dim>
  void
  ParabolicProblem<dim>::record_step(const double wall_seconds)
  {
    StepRecord r;
    r.step     = step;
    r.time     = time;
    r.dt       = time_step;
    r.newton   = newton_this_step;
    r.linear   = linear_this_step;
    r.rejected = rejected_this_step;
    r.contact  = n_contact_nodes;
    if (final_estimate)
      {
        r.eta_step = final_estimate->eta;
        r.eta_time = final_estimate->eta_time;
        r.eta      = totals.eta();
      }
    if (data.has_exact_solution())
      {
        r.error = totals.error();
        if (final_estimate)
          r.effectivity = r.eta / r.error;
      }
    records.push_back(r);

    VI::Json json             = VI::Json::object();
    json["step"]              = step;
    json["time"]              = time;
    json["dt"]                = time_step;
    json["rejected"]          = rejected_this_step;
    json["newton_iterations"] = newton_this_step;
    json["linear_iterations"] = linear_this_step;
    json["contact_nodes"]     = n_contact_nodes;
    if (!contact_per_ring.empty())
      {
        VI::Json rings = VI::Json::array();
        for (const auto n : contact_per_ring)
          rings.push_back(n);
        json["contact_nodes_per_ring"] = rings;
      }
    if (final_estimate)
      {
        json["estimate"]       = to_json(*final_estimate);
        json["eta"]            = totals.eta();
        json["eta_init"]       = totals.eta_init;
        json["eta_disc_total"] = totals.eta_disc();
        json["eta_lin_total"]  = totals.eta_lin();
        json["eta_alg_total"]  = totals.eta_alg();
      }
    if (data.has_exact_solution())
      {
        json["error_energy"] = step_error_energy;
        json["error_l2"]     = totals.final_error;
        json["error"]        = totals.error();
        if (final_estimate)
          json["effectivity"] = totals.eta() / totals.error();
      }
    json["wall_seconds"] = wall_seconds;
    json["newton_steps"] = VI::newton_steps(newton_report);
    json["iterations"]   = VI::to_json(stopping.records, false);
    std::ostringstream text;
    json.write(text, 4);
    step_json.push_back(text.str());
  }


  template <int dim>
  void
  ParabolicProblem<dim>::output_results()
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    DataOut<dim> data_out;
    data_out.attach_dof_handler(dof_handler);
    data_out.add_data_vector(u1_h, "u1");
    data_out.add_data_vector(u2_h, "u2");
    data_out.add_data_vector(gap_h, "gap");
    data_out.add_data_vector(lambda_h, "lambda");
    data_out.add_data_vector(contact_set, "contact");
    dealii::Vector<float> subdomain(triangulation.n_active_cells());
    subdomain = triangulation.locally_owned_subdomain();
    data_out.add_data_vector(subdomain, "partition");

    // Per-cell estimators.
    std::vector<std::pair<std::string, dealii::Vector<float>>> indicators;
    if (final_estimate)
      indicators = VI::cell_indicators(final_estimate->at_end);
    for (const auto &[name, values] : indicators)
      data_out.add_data_vector(values, name, DataOut<dim>::type_cell_data);

    data_out.build_patches(*mapping,
                           fe.degree,
                           VI::has_curved_cells(geometry) ?
                             DataOut<dim>::curved_inner_cells :
                             DataOut<dim>::curved_boundary);
    DataOutBase::VtkFlags flags;
    flags.time  = time;
    flags.cycle = step;
    data_out.set_flags(flags);
    const std::string name = data_out.write_vtu_with_pvtu_record(
      parameters.output.directory + "/", "solution", step, comm, 5, 8);
    vtu_files.emplace_back(time, name);
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        std::ofstream pvd(parameters.output.directory + "/solution.pvd");
        DataOutBase::write_pvd_record(pvd, vtu_files);
      }
  }


  // The table of the steps, to the screen (the last rows) and to
  // convergence.txt, with the totals below it.
  template <int dim>
  void
  ParabolicProblem<dim>::write_tables() const
  {
    ConvergenceTable table;
    const bool       estimate = parameters.estimators.enabled;
    const bool       exact    = data.has_exact_solution();
    for (const StepRecord &r : records)
      {
        table.add_value("step", r.step);
        table.add_value("time", r.time);
        table.add_value("dt", r.dt);
        table.add_value("newton", r.newton);
        table.add_value("linear", r.linear);
        table.add_value("contact", r.contact);
        if (parameters.time.adaptive)
          table.add_value("rejected", r.rejected);
        if (estimate)
          {
            table.add_value("eta_time", r.eta_time);
            table.add_value("eta_n", r.eta_step);
            table.add_value("eta", r.eta);
          }
        if (exact)
          {
            table.add_value("error", r.error);
            if (estimate)
              table.add_value("effectivity", r.effectivity);
          }
      }
    table.set_precision("time", 6);
    table.set_precision("dt", 4);
    table.set_scientific("dt", true);
    for (const std::string key : {"eta_time", "eta_n", "eta", "error"})
      {
        table.set_precision(key, 4);
        table.set_scientific(key, true);
      }
    table.set_precision("effectivity", 4);

    std::ostringstream totals_text;
    totals_text << "# steps " << records.size() << ", rejected "
                << totals.rejected << "; cumulative Newton " << totals.newton
                << ", linear " << totals.linear << "\n";
    if (estimate)
      totals_text << std::scientific << std::setprecision(4) << "# eta "
                  << totals.eta() << " <= eta_init " << totals.eta_init
                  << " + eta_disc " << totals.eta_disc() << " + eta_lin "
                  << totals.eta_lin() << " + eta_alg " << totals.eta_alg()
                  << "\n";
    if (exact)
      totals_text << std::scientific << std::setprecision(4) << "# error "
                  << totals.error() << std::defaultfloat
                  << (estimate ? ", effectivity " : "")
                  << (estimate ? std::to_string(totals.eta() / totals.error()) :
                                 "")
                  << "\n";

    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        std::ofstream file(parameters.output.directory + "/convergence.txt");
        table.write_text(file, TableHandler::org_mode_table);
        file << totals_text.str();
        pcout << std::endl << totals_text.str();
      }
  }


  template <int dim>
  void
  ParabolicProblem<dim>::write_summary(const std::string &status,
                                       const std::string &failure)
  {
    VI::Json json  = summary;
    VI::Json steps = VI::Json::array();
    for (const std::string &text : step_json)
      steps.push_back(VI::Json::raw(text));
    json["steps"]  = steps;
    json["status"] = status;
    if (!failure.empty())
      json["failure"] = failure;
    VI::Json total             = VI::Json::object();
    total["steps"]             = records.size();
    total["time"]              = time;
    total["rejected_steps"]    = totals.rejected;
    total["newton_iterations"] = totals.newton;
    total["linear_iterations"] = totals.linear;
    if (parameters.estimators.enabled)
      {
        total["eta"]      = totals.eta();
        total["eta_init"] = totals.eta_init;
        total["eta_disc"] = totals.eta_disc();
        total["eta_lin"]  = totals.eta_lin();
        total["eta_alg"]  = totals.eta_alg();
      }
    if (data.has_exact_solution() && !records.empty())
      {
        total["error"] = totals.error();
        if (parameters.estimators.enabled)
          total["effectivity"] = totals.eta() / totals.error();
      }
    json["totals"] = total;
    json["timing"] = VI::Json::object();
    for (const auto &[section, seconds] :
         timer.get_summary_data(TimerOutput::total_wall_time))
      json["timing"][section] = seconds;
    VI::write_summary(json, parameters.output.directory, comm);
  }


  template <int dim>
  void
  ParabolicProblem<dim>::run()
  {
    const auto &nonlinear = parameters.nonlinear_solver;
    const auto &linear    = parameters.linear_solver;
    const auto &ts        = parameters.time;
    pcout << VI::run_header("step-parabolic", comm) << std::endl;
    pcout << "Test case " << data.name << " on the " << parameters.mesh.geometry
          << ", Q" << fe.degree << " elements, backward Euler with "
          << (ts.adaptive ? "adaptive dt from " : "dt = ") << ts.time_step
          << " to T = " << ts.final_time << ", Newton-" << C.name() << " ("
          << nonlinear.strategy << "), "
          << (linear.solver == "direct" ?
                "direct solver " + linear.direct_package :
                "GMRES + " + linear.preconditioner)
          << (parameters.estimators.enabled ? ", estimators on" : "")
          << std::endl;

    summary = VI::make_summary("step-parabolic", comm, prm);
    if (!parameters.compare_with.empty())
      {
        const std::string file  = parameters.compare_with + "/checkpoint.txt";
        bool              found = false;
        if (Utilities::MPI::this_mpi_process(comm) == 0)
          found = static_cast<bool>(std::ifstream(file));
        if (!Utilities::MPI::broadcast(comm, found, 0))
          throw VI::InputError("Output/Compare with: there is no checkpoint <" +
                               file + ">");
      }

    if (ts.resume)
      {
        read_checkpoint();
        pcout << "Resuming at t = " << time << " (step " << step << ")"
              << std::endl;
      }
    else
      {
        make_grid();
        check_data();
        VI::prepare_output_directory(parameters.output.directory, comm);
        setup_system();
        set_initial_values();
        next_time_step = ts.time_step;
        output_results();
      }
    summary["mesh"]                   = VI::Json::object();
    summary["mesh"]["cells"]          = triangulation.n_global_active_cells();
    summary["mesh"]["dofs"]           = n_fields * dof_handler.n_dofs();
    summary["mesh"]["dofs_per_field"] = dof_handler.n_dofs();
    pcout << "Mesh: " << triangulation.n_global_active_cells() << " cells, "
          << n_fields * dof_handler.n_dofs() << " unknowns ("
          << dof_handler.n_dofs() << " per field)";
    if (parameters.estimators.enabled)
      pcout << "; eta_init = " << std::scientific << std::setprecision(3)
            << totals.eta_init << std::defaultfloat;
    pcout << std::endl;

    const double end_tolerance = 1e-12 * ts.final_time;
    std::string  stop_reason;
    while (time < ts.final_time - end_tolerance)
      {
        if (ts.steps_per_run > 0 && steps_this_run == ts.steps_per_run)
          {
            stop_reason = "stopped";
            break;
          }
        Timer step_timer;
        rejected_this_step = newton_this_step = linear_this_step = 0;
        for (;;)
          {
            // The last step ends at T (and is not left shorter than 1% of dt).
            time_step = next_time_step;
            if (time + 1.01 * time_step >= ts.final_time)
              time_step = ts.final_time - time;
            try
              {
                solve_time_step();
              }
            catch (const VI::SolverFailure &failure)
              {
                // Keep what the completed steps measured, marked as failed.
                pcout << "Step " << step + 1 << " (t = " << time + time_step
                      << ") failed." << std::endl;
                write_summary("failed", failure.what());
                throw;
              }
            newton_this_step += newton_report.iterations;
            linear_this_step += newton_report.linear_iterations;
            totals.newton += newton_report.iterations;
            totals.linear += newton_report.linear_iterations;

            bool accept = true;
            choose_next_time_step(final_estimate ? *final_estimate :
                                                   StepEstimate(),
                                  accept);
            if (accept)
              break;
            ++rejected_this_step;
            ++totals.rejected;
            pcout << "   step to t = " << time + time_step << " rejected: "
                  << "(eta_time + eta_osc) / eta_space = "
                  << (final_estimate->eta_time + final_estimate->oscillation) /
                       final_estimate->eta_space
                  << ", dt " << time_step << " -> " << next_time_step
                  << std::endl;
          }

        // Accept the step: errors on I_n, the totals, then u_h^n becomes
        // the previous solution.
        postprocess();
        compute_errors();
        time += time_step;
        ++step;
        ++steps_this_run;
        if (final_estimate)
          {
            const StepEstimate &e = *final_estimate;
            totals.eta_squared += e.eta * e.eta;
            totals.disc_squared += e.eta_disc * e.eta_disc;
            totals.lin_squared += e.eta_lin * e.eta_lin;
            totals.alg_squared += e.eta_alg * e.eta_alg;
            totals.nonc_squared += e.nonc_squared;
            totals.nonc_squared_disc += e.nonc_squared_disc;
            totals.nonc_squared_lin += e.nonc_squared_lin;
            totals.final_nonc      = e.final_nonc;
            totals.final_nonc_disc = e.final_nonc_disc;
            totals.final_nonc_lin  = e.final_nonc_lin;
          }
        store_previous_step();
        const double wall = step_timer.wall_time();
        record_step(wall);

        const bool at_end = time >= ts.final_time - end_tolerance;
        if (at_end ||
            (ts.output_interval > 0 && step % ts.output_interval == 0))
          output_results();
        if (ts.checkpoint_interval > 0 && step % ts.checkpoint_interval == 0 &&
            !at_end)
          write_checkpoint();

        // Progress.
        const StepRecord &r = records.back();
        pcout << "Step " << std::setw(4) << step << " t = " << std::setw(9)
              << std::left << time << std::right << " dt = " << std::setw(9)
              << std::left << time_step << std::right << ": Newton "
              << std::setw(2) << r.newton;
        if (linear.solver == "gmres")
          pcout << " (" << std::setw(4) << r.linear << " GMRES)";
        pcout << ", contact " << std::setw(5) << r.contact;
        if (final_estimate)
          pcout << std::scientific << std::setprecision(2) << ", eta_n "
                << final_estimate->eta << " (disc " << final_estimate->eta_disc
                << ", lin " << final_estimate->eta_lin << ", alg "
                << final_estimate->eta_alg << ", time "
                << final_estimate->eta_time << ")" << std::defaultfloat;
        if (data.has_exact_solution())
          pcout << std::scientific << std::setprecision(3) << ", error "
                << r.error << std::defaultfloat;
        if (final_estimate && data.has_exact_solution())
          pcout << std::setprecision(3) << ", effectivity " << r.effectivity;
        if (r.rejected > 0)
          pcout << ", " << r.rejected << " rejected";
        pcout << std::setprecision(3) << ", " << wall << " s" << std::endl;
      }

    write_checkpoint();
    write_tables();
    if (!parameters.compare_with.empty() && stop_reason.empty())
      compare_with_run(parameters.compare_with);
    if (stop_reason == "stopped")
      {
        write_summary("stopped", "");
        pcout << "\nStopped after " << steps_this_run
              << " steps (Time stepping/Steps per run) at t = " << time
              << "; continue with Time stepping/Resume = true." << std::endl;
      }
    else
      write_summary("completed", "");
    pcout << "Output in " << parameters.output.directory
          << "/: solution.pvd (ParaView), convergence.txt, summary.json, "
             "checkpoint"
          << std::endl;
  }


  template class ParabolicProblem<2>;
} // namespace StepParabolic
