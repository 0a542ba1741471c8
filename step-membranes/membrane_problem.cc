#include "membrane_problem.h"

#include <cmath>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_solver.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

namespace StepMembranes
{
  using VI::NodalFields::index;
  using VI::NodalFields::multiplier;
  using VI::NodalFields::n_fields;

  void
  Parameters::declare(ParameterHandler &prm)
  {
    VI::ProblemParameters::declare(prm,
                                   VI::membrane_test_case_names(),
                                   "seed-smooth");
    VI::MeshParameters::declare(prm, "global");
    VI::DiscretizationParameters::declare(prm, "fem");
    VI::NonlinearSolverParameters::declare(prm, "exact");
    VI::LinearSolverParameters::declare(prm, "direct", "direct");
    VI::OutputParameters::declare(prm);
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    problem.parse(prm);
    mesh.parse(prm);
    discretization.parse(prm);
    nonlinear_solver.parse(prm);
    linear_solver.parse(prm);
    output.parse(prm);
  }


  template <int dim>
  MembraneProblem<dim>::MembraneProblem(const Parameters &parameters,
                                        ParameterHandler &prm,
                                        const MPI_Comm    comm)
      : parameters(parameters)
      , prm(prm)
      , comm(comm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      // Wall times of rank 0: a TimerOutput without communicator needs no MPI
    // in its destructor, which also runs when a failure unwinds the stack.
    , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , geometry(VI::geometry_from_name(parameters.mesh.geometry))
      , data(VI::make_membrane_data<dim>(parameters.problem,
                                         VI::geometry_center<dim>(geometry)))
      , C(VI::ComplementarityFunction::from_name(
          parameters.nonlinear_solver.c_function))
      , triangulation(comm)
      , mapping(
          VI::make_mapping<dim>(geometry, parameters.discretization.degree))
      , fe(parameters.discretization.degree)
      , dof_handler(triangulation)
  {
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (otherwise the constraint u1 >= u2 contradicts the boundary condition).
  // Checked on the first mesh (forces at the quadrature points, boundary
  // data at the boundary support points) before anything is written.
  template <int dim>
  void
  MembraneProblem<dim>::check_data() const
  {
    std::string violation;
    const auto  report = [&](const std::string &message) {
      if (violation.empty())
        violation = message;
    };

    const QGauss<dim> quadrature(fe.degree + 2);
    const auto &      unit_points = fe.get_unit_support_points();
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned() && violation.empty())
        {
          for (const auto &unit_point : quadrature.get_points())
            {
              const Point<dim> p =
                mapping->transform_unit_to_real_cell(cell, unit_point);
              for (const auto &[name, f] :
                   {std::pair<const char *, const Function<dim> *>{
                      "f1", data.f1.get()},
                    {"f2", data.f2.get()}})
                if (!std::isfinite(f->value(p)))
                  {
                    std::ostringstream message;
                    message << name << " is not finite at (" << p
                            << "): " << f->value(p);
                    report(message.str());
                  }
            }
          for (const unsigned int f : cell->face_indices())
            if (cell->face(f)->at_boundary())
              for (const auto &unit_point : unit_points)
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
                            << "): g1 = " << g1 << ", g2 = " << g2;
                  else if (g1 - g2 < -1e-12 * std::max({1.,
                                                        std::abs(g1),
                                                        std::abs(g2)}))
                    message << "g1 < g2 on the boundary at (" << p
                            << "): g1 = " << g1 << ", g2 = " << g2
                            << "; the constraint u1 >= u2 cannot hold there";
                  if (!message.str().empty())
                    report(message.str());
                }
        }
    for (const std::string &message :
         Utilities::MPI::all_gather(comm, violation))
      if (!message.empty())
        throw VI::InputError("Problem: " + message);
  }



  template <int dim>
  void
  MembraneProblem<dim>::make_grid()
  {
    VI::make_coarse_mesh(geometry, triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
  }


  // Distribute the nodes, build the constraints (hanging nodes, Dirichlet
  // data, no multiplier on constrained nodes), the contact rows and the
  // sparsity of A.
  template <int dim>
  void
  MembraneProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");

    dof_handler.distribute_dofs(fe);
    owned_nodes = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_nodes);
    owned_system    = VI::NodalFields::system_index_set(owned_nodes);
    relevant_system = VI::NodalFields::system_index_set(relevant_nodes);

    hanging_node_constraints.clear();
    hanging_node_constraints.reinit(relevant_nodes);
    DoFTools::make_hanging_node_constraints(dof_handler,
                                            hanging_node_constraints);
    hanging_node_constraints.close();

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
    contact_rows.reinit(owned_nodes, u1_constraints);

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
    system_matrix.reinit(owned_system, owned_system, system_pattern, comm);

    system_rhs.reinit(owned_system, comm);
    solution.reinit(owned_system, comm);
    coupling.reinit(owned_nodes, comm);
    for (auto *field : {&u1_h, &u2_h, &gap_h, &lambda_h, &contact_set})
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
  }


  // The linear part of the system, once per mesh: the stiffness blocks and
  // the load F (with the Dirichlet lifting) through the constraints, the
  // coupling D (lumped masses (psi_i, 1) for p = 1, the identity for p >= 2
  // by duality), and for p >= 2 the mass matrix that maps X3 to lambda_h.
  template <int dim>
  void
  MembraneProblem<dim>::assemble_system()
  {
    TimerOutput::Scope t(timer, "assembly");

    system_matrix = 0;
    system_rhs    = 0;
    TrilinosWrappers::MPI::Vector lumped_mass(owned_nodes, comm);
    if (fe.degree > 1)
      mass_matrix = 0;

    // mesh_loop calls the copier for every cell of the range it is given,
    // so the range is filtered to the locally owned cells.
    const auto owned_cells =
      dof_handler.active_cell_iterators() | IteratorFilters::LocallyOwnedCell();
    using Iterator = typename DoFHandler<dim>::active_cell_iterator;
    // Matrices: stiffness, mass. Vectors: (f1, psi), (f2, psi), (1, psi).
    using CopyData = MeshWorker::CopyData<2, 3, 1>;

    const QGauss<dim>            quadrature(fe.degree + 2);
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

      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double f1 = data.f1->value(points[q]);
          const double f2 = data.f2->value(points[q]);
          const double dx = fe_values.JxW(q);
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
              copy.vectors[0](i) += f1 * phi_i * dx;
              copy.vectors[1](i) += f2 * phi_i * dx;
              copy.vectors[2](i) += phi_i * dx;
            }
        }
    };

    std::vector<types::global_dof_index> system_dofs(fe.n_dofs_per_cell());
    FullMatrix<double>                   scaled_stiffness(fe.n_dofs_per_cell());
    const auto                           copier = [&](const CopyData &copy) {
      const auto  &dofs  = copy.local_dof_indices[0];
      const double mu[2] = {data.mu1, data.mu2};
      for (const unsigned int field :
           {VI::NodalFields::u1, VI::NodalFields::u2})
        {
          for (unsigned int i = 0; i < dofs.size(); ++i)
            system_dofs[i] = index(dofs[i], field);
          scaled_stiffness.equ(mu[field], copy.matrices[0]);
          // With the inhomogeneities in the right-hand side, the row of a
          // constrained node reads d X_i = d g_i: X satisfies every row of
          // E X = F, and Newton updates vanish on the boundary.
          system_constraints.distribute_local_to_global(
            scaled_stiffness,
            copy.vectors[field],
            system_dofs,
            system_matrix,
            system_rhs,
            /*use_inhomogeneities_for_rhs=*/true);
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
    system_matrix.compress(VectorOperation::add);
    system_rhs.compress(VectorOperation::add);
    lumped_mass.compress(VectorOperation::add);
    if (fe.degree > 1)
      mass_matrix.compress(VectorOperation::add);

    // Coupling -D / +D in the rows of u1 / u2, and X3 = 0 as the row of each
    // constrained node (boundary, hanging), where there is no contact row.
    coupling = 0;
    for (const types::global_dof_index i : contact_rows.nodes())
      {
        const double D = fe.degree == 1 ? lumped_mass(i) : 1.;
        coupling(i)    = D;
        system_matrix.set(index(i, VI::NodalFields::u1),
                          index(i, multiplier),
                          -D);
        system_matrix.set(index(i, VI::NodalFields::u2),
                          index(i, multiplier),
                          +D);
      }
    for (const types::global_dof_index i : owned_nodes)
      if (u1_constraints.is_constrained(i))
        system_matrix.set(index(i, multiplier), index(i, multiplier), 1.);
    system_matrix.compress(VectorOperation::insert);
    coupling.compress(VectorOperation::insert);

    // Scales of the dimensionless residuals: |F| over the rows of the
    // unconstrained nodes, and the multiplier coefficient |F|_inf / max D
    // that would balance the load.
    double local[2] = {0., 0.};
    for (const types::global_dof_index i : contact_rows.nodes())
      for (const unsigned int field :
           {VI::NodalFields::u1, VI::NodalFields::u2})
        {
          const double F = system_rhs(index(i, field));
          local[0] += F * F;
          local[1] = std::max(local[1], std::abs(F));
        }
    load_norm = std::sqrt(Utilities::MPI::sum(local[0], comm));
    multiplier_scale =
      Utilities::MPI::max(local[1], comm) /
      std::max(coupling.linfty_norm(), std::numeric_limits<double>::min());

    if (!std::isfinite(system_rhs.l2_norm()))
      throw VI::InputError(
        "Problem: the load vector is not finite: f1, f2, g1 or g2 evaluate "
        "to NaN or Inf somewhere in the domain");
  }


  // The Newton iterate on a new mesh: the previous mesh's solution
  // transferred (nested iteration), or zero interior values and multiplier.
  // Either way the Dirichlet data of this mesh are imposed.
  template <int dim>
  void
  MembraneProblem<dim>::initialize_iterate()
  {
    solution = 0;
    if (solution_transfer)
      {
        TrilinosWrappers::MPI::Vector u1(owned_nodes, comm),
          u2(owned_nodes, comm), lambda(owned_nodes, comm),
          X3(owned_nodes, comm);
        std::vector<TrilinosWrappers::MPI::Vector *> fields = {&u1,
                                                               &u2,
                                                               &lambda};
        solution_transfer->interpolate(fields);
        solution_transfer.reset();

        VI::NodalFields::insert(u1, VI::NodalFields::u1, solution);
        VI::NodalFields::insert(u2, VI::NodalFields::u2, solution);
        compute_dual_coefficients(lambda, X3);
        VI::NodalFields::insert(X3, multiplier, solution);
      }
    system_constraints.distribute(solution);
  }


  // R(X) = [E X - F ; C(X)]: the rows of the balance equations come from the
  // matrix, whose multiplier rows are then overwritten by the C-function.
  template <int dim>
  VI::ResidualNorms
  MembraneProblem<dim>::residual(const TrilinosWrappers::MPI::Vector &X,
                                 TrilinosWrappers::MPI::Vector       &R) const
  {
    TimerOutput::Scope t(timer, "newton: residual");
    system_matrix.vmult(R, X);
    R -= system_rhs;

    VI::ResidualNorms norms;
    norms.complementarity = contact_rows.evaluate(C, X, multiplier_scale, R);

    double        local = 0;
    const double *r     = R.begin();
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      local += r[n_fields * k] * r[n_fields * k] +
               r[n_fields * k + 1] * r[n_fields * k + 1];
    norms.equations = std::sqrt(Utilities::MPI::sum(local, comm)) /
                      std::max(load_norm, std::numeric_limits<double>::min());
    return norms;
  }


  template <int dim>
  void
  MembraneProblem<dim>::solve()
  {
    const auto &p = parameters.nonlinear_solver;
    typename VI::SemismoothNewton<TrilinosWrappers::MPI::Vector>::AdditionalData
      settings;
    settings.max_iterations = p.max_iterations;
    settings.tolerance      = p.tolerance;
    settings.line_search    = C.has_smooth_merit_function();
    settings.name           = "semismooth Newton-" + C.name();

    VI::LinearSolver linear_solver(parameters.linear_solver);

    VI::SemismoothNewton<TrilinosWrappers::MPI::Vector> newton(settings);
    newton.residual = [&](const auto &X, auto &R) { return residual(X, R); };
    newton.setup_jacobian = [&](const auto &X) {
      {
        TimerOutput::Scope t(timer, "newton: jacobian");
        contact_rows.set_jacobian_rows(C, X, system_matrix);
        system_matrix.compress(VectorOperation::insert);
      }
      TimerOutput::Scope t(timer, "newton: factorisation");
      linear_solver.initialize(system_matrix);
    };
    newton.solve_with_jacobian = [&](const auto &rhs, auto &dX) {
      TimerOutput::Scope t(timer, "newton: linear solve");
      return linear_solver.solve(rhs, dX);
    };
    if (parameters.output.verbose)
      newton.monitor = [&](const VI::NewtonStep &step) {
        pcout << "      k = " << std::setw(2) << step.iteration
              << ": residuals " << std::scientific << std::setprecision(2)
              << step.residual.equations << " (equations), "
              << step.residual.complementarity << " (complementarity)"
              << std::defaultfloat;
        if (step.step_length < 1)
          pcout << ", step " << step.step_length;
        pcout << std::endl;
      };

    newton_report = newton.solve(solution);
  }


  // lambda_h from X3: its nodal values for p = 1; for p >= 2 the solution of
  // M c = X3 (X3 = 0 on constrained nodes), since X3_i = (lambda_h, psi_i).
  template <int dim>
  void
  MembraneProblem<dim>::compute_multiplier(
    const TrilinosWrappers::MPI::Vector &X3,
    TrilinosWrappers::MPI::Vector       &lambda) const
  {
    TrilinosWrappers::MPI::Vector coefficients(owned_nodes, comm);
    if (fe.degree == 1)
      coefficients = X3;
    else
      {
        SolverControl              control(1000, 1e-13 * X3.l2_norm());
        TrilinosWrappers::SolverCG cg(control);
        TrilinosWrappers::PreconditionJacobi jacobi;
        jacobi.initialize(mass_matrix);
        cg.solve(mass_matrix, coefficients, X3, jacobi);
      }
    hanging_node_constraints.distribute(coefficients);
    lambda = coefficients;
  }


  // The inverse map: X3_i = <lambda_h, psi_i>_h / D_i, i.e. lambda_h(x_i)
  // for p = 1 and (lambda_h, psi_i) for p >= 2, on the contact nodes.
  template <int dim>
  void
  MembraneProblem<dim>::compute_dual_coefficients(
    const TrilinosWrappers::MPI::Vector &lambda,
    TrilinosWrappers::MPI::Vector       &X3) const
  {
    TrilinosWrappers::MPI::Vector values(owned_nodes, comm);
    if (fe.degree == 1)
      values = lambda;
    else
      mass_matrix.vmult(values, lambda);
    X3 = 0;
    for (const types::global_dof_index i : contact_rows.nodes())
      X3(i) = values(i);
    X3.compress(VectorOperation::insert);
  }


  // The discrete solution as finite element functions, the contact set.
  template <int dim>
  void
  MembraneProblem<dim>::postprocess()
  {
    TimerOutput::Scope            t(timer, "postprocess");
    TrilinosWrappers::MPI::Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      field(owned_nodes, comm);
    VI::NodalFields::extract(solution, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(solution, VI::NodalFields::u2, u2);
    u1_h = u1;
    u2_h = u2;
    u1 -= u2;
    gap_h = u1;

    VI::NodalFields::extract(solution, multiplier, field);
    compute_multiplier(field, u2);
    lambda_h = u2;

    n_contact_nodes = contact_rows.contact_set(solution, field);
    contact_set     = field;
  }


  // Energy norm |||u - u_h|||^2 = mu1 |u1 - u1h|_1^2 + mu2 |u2 - u2h|_1^2,
  // and the L2 error of the multiplier where it is known.
  template <int dim>
  void
  MembraneProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope t(timer, "errors");

    const QGauss<dim> quadrature(fe.degree + 3);
    Vector<float>     cellwise(triangulation.n_active_cells());
    const auto        error = [&](const TrilinosWrappers::MPI::Vector &uh,
                           const Function<dim>                 &exact,
                           const VectorTools::NormType          norm) {
      VectorTools::integrate_difference(
        *mapping, dof_handler, uh, exact, cellwise, quadrature, norm);
      return VectorTools::compute_global_error(triangulation, cellwise, norm);
    };
    const double e1 = error(u1_h, *data.exact_u1, VectorTools::H1_seminorm);
    const double e2 = error(u2_h, *data.exact_u2, VectorTools::H1_seminorm);
    error_energy    = std::sqrt(data.mu1 * e1 * e1 + data.mu2 * e2 * e2);
    if (data.exact_lambda)
      error_multiplier =
        error(lambda_h, *data.exact_lambda, VectorTools::L2_norm);
  }


  template <int dim>
  void
  MembraneProblem<dim>::output_results(const unsigned int cycle) const
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
    Vector<float> subdomain(triangulation.n_active_cells());
    subdomain = triangulation.locally_owned_subdomain();
    data_out.add_data_vector(subdomain, "partition");
    data_out.build_patches(*mapping,
                           fe.degree,
                           geometry == VI::Geometry::disk ?
                             DataOut<dim>::curved_inner_cells :
                             DataOut<dim>::curved_boundary);
    data_out.write_vtu_with_pvtu_record(
      parameters.output.directory + "/", "solution", cycle, comm, 2, 8);
  }


  // Global refinement; with nested iteration the current solution is
  // carried to the new mesh by SolutionTransfer (as finite element
  // functions: the dual coefficients X3 are recomputed on the new mesh).
  template <int dim>
  void
  MembraneProblem<dim>::refine_mesh()
  {
    TimerOutput::Scope t(timer, "refinement");
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned())
        cell->set_refine_flag();
    triangulation.prepare_coarsening_and_refinement();

    if (parameters.nonlinear_solver.nested_iteration)
      {
        solution_transfer = std::make_unique<
          parallel::distributed::
            SolutionTransfer<dim, TrilinosWrappers::MPI::Vector>>(dof_handler);
        solution_transfer->prepare_for_coarsening_and_refinement(
          std::vector<const TrilinosWrappers::MPI::Vector *>{&u1_h,
                                                             &u2_h,
                                                             &lambda_h});
      }
    triangulation.execute_coarsening_and_refinement();
  }


  template <int dim>
  void
  MembraneProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const double wall = cycle_timer.wall_time();

    table.add_value("cycle", cycle);
    table.add_value("cells", triangulation.n_global_active_cells());
    table.add_value("dofs", dof_handler.n_dofs());
    table.add_value("newton", newton_report.iterations);
    table.add_value("linear", newton_report.linear_iterations);
    table.add_value("contact", n_contact_nodes);
    if (data.has_exact_solution())
      {
        table.add_value("error_energy", error_energy);
        table.set_scientific("error_energy", true);
        table.set_precision("error_energy", 4);
        if (data.exact_lambda)
          {
            table.add_value("error_lambda", error_multiplier);
            table.set_scientific("error_lambda", true);
            table.set_precision("error_lambda", 4);
          }
      }
    table.add_value("wall_s", wall);
    table.set_precision("wall_s", 3);

    VI::Json record             = VI::Json::object();
    record["cycle"]             = cycle;
    record["cells"]             = triangulation.n_global_active_cells();
    record["dofs"]              = n_fields * dof_handler.n_dofs();
    record["dofs_per_field"]    = dof_handler.n_dofs();
    record["newton_iterations"] = newton_report.iterations;
    record["linear_iterations"] = newton_report.linear_iterations;
    record["contact_nodes"]     = n_contact_nodes;
    if (data.has_exact_solution())
      record["error_energy"] = error_energy;
    if (data.exact_lambda)
      record["error_lambda_l2"] = error_multiplier;
    record["wall_seconds"] = wall;
    VI::Json iterations    = VI::Json::array();
    for (const VI::NewtonStep &step : newton_report.steps)
      {
        VI::Json it                    = VI::Json::object();
        it["k"]                        = step.iteration;
        it["i"]                        = step.linear_iterations;
        it["residual_equations"]       = step.residual.equations;
        it["residual_complementarity"] = step.residual.complementarity;
        it["step_length"]              = step.step_length;
        iterations.push_back(it);
      }
    record["iterations"] = iterations;
    summary["cycles"].push_back(record);
  }


  // The convergence table, with rates in h (from the DoF counts, d = 2):
  // to the screen with the wall time, and to convergence.txt without it, so
  // that the file is reproducible and diffable.
  template <int dim>
  void
  MembraneProblem<dim>::write_tables() const
  {
    std::vector<std::string> errors;
    if (data.has_exact_solution())
      errors.push_back("error_energy");
    if (data.exact_lambda)
      errors.push_back("error_lambda");

    ConvergenceTable with_rates = table;
    for (const std::string &key : errors)
      with_rates.evaluate_convergence_rates(
        key, "dofs", ConvergenceTable::reduction_rate_log2, dim);
    pcout << std::endl;
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        with_rates.write_text(std::cout, TableHandler::org_mode_table);
        std::ofstream file(parameters.output.directory + "/convergence.txt");
        std::vector<std::string> columns = {
          "cycle", "cells", "dofs", "newton", "linear", "contact"};
        // An error key names the supercolumn of the error and its rate.
        columns.insert(columns.end(), errors.begin(), errors.end());
        ConvergenceTable file_table = with_rates;
        file_table.set_column_order(columns);
        file_table.write_text(file, TableHandler::org_mode_table);
      }
  }


  template <int dim>
  void
  MembraneProblem<dim>::run()
  {
    pcout << VI::run_header("step-membranes", comm) << std::endl;
    pcout << "Test case " << data.name << " on the " << parameters.mesh.geometry
          << ", Q" << fe.degree << " elements, Newton-" << C.name()
          << (parameters.nonlinear_solver.nested_iteration ? " with" :
                                                             " without")
          << " nested iteration, direct solver "
          << parameters.linear_solver.direct_package << std::endl;

    summary           = VI::make_summary("step-membranes", comm, prm);
    summary["cycles"] = VI::Json::array();

    make_grid();
    check_data();
    VI::prepare_output_directory(parameters.output.directory, comm);

    for (unsigned int cycle = 0; cycle < parameters.mesh.cycles; ++cycle)
      {
        cycle_timer.restart();
        if (cycle > 0)
          refine_mesh();
        setup_system();
        assemble_system();
        initialize_iterate();

        pcout << "Cycle " << cycle << ": "
              << triangulation.n_global_active_cells() << " cells, "
              << n_fields * dof_handler.n_dofs() << " unknowns ("
              << dof_handler.n_dofs() << " per field)" << std::endl;
        try
          {
            solve();
          }
        catch (const VI::SolverFailure &failure)
          {
            // Keep what the completed cycles measured, marked as failed.
            summary["status"]  = "failed";
            summary["failure"] = std::string(failure.what());
            VI::write_summary(summary, parameters.output.directory, comm);
            throw;
          }
        postprocess();
        compute_errors();
        output_results(cycle);
        cycle_timer.stop();

        pcout << "   Newton-" << C.name() << ": " << newton_report.iterations
              << " iterations, " << n_contact_nodes << " nodes in contact";
        if (data.has_exact_solution())
          pcout << ", energy error " << std::scientific << std::setprecision(3)
                << error_energy << std::defaultfloat;
        pcout << ", " << std::setprecision(3) << cycle_timer.wall_time() << " s"
              << std::endl;
        record_cycle(cycle);
      }

    write_tables();
    summary["status"] = "converged";
    summary["timing"] = VI::Json::object();
    for (const auto &[section, seconds] :
         timer.get_summary_data(TimerOutput::total_wall_time))
      summary["timing"][section] = seconds;
    VI::write_summary(summary, parameters.output.directory, comm);
    pcout << "\nOutput in " << parameters.output.directory
          << "/: solution_*.pvtu (ParaView), convergence.txt, summary.json"
          << std::endl;
  }


  template class MembraneProblem<2>;
} // namespace StepMembranes
