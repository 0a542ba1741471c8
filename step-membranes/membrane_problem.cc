#include "membrane_problem.h"

#include <deal.II/base/parallel.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_index_access.h>
#include <deal.II/lac/trilinos_solver.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/cell_function_values.h>
#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/petsc_vi.h>
#include <vi/program.h>

#include "reference_poisson.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <fstream>
#include <iomanip>
#include <sstream>

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
    VI::MeshParameters::declare(prm, "global|adaptive");
    VI::DiscretizationParameters::declare(prm, "fem|sipg|nipg|iipg");
    VI::NonlinearSolverParameters::declare(prm, "exact|inexact|adaptive");
    VI::LinearSolverParameters::declare(prm, "direct|gmres", "direct");
    VI::EstimatorParameters::declare(prm);
    VI::OutputParameters::declare(prm);
    prm.enter_subsection("Nonlinear solver");
    prm.declare_entry(
      "Solver",
      "semismooth-newton",
      Patterns::Selection("semismooth-newton|petsc-vi"),
      "semismooth-newton: ours (C-function, Strategy). petsc-vi: the peer, "
      "PETSc's SNES VI on the same discrete problem (Method = fem; Strategy "
      "exact or inexact sets the KSP tolerance to Linear solver/Tolerance or "
      "the forcing term; Linear solver: direct = MUMPS, gmres with "
      "Preconditioner amg = BoomerAMG or ilu). PETSC_OPTIONS overrides.");
    prm.declare_entry("PETSc VI type",
                      "rsls",
                      Patterns::Selection("rsls|ssls"),
                      "SNESVINEWTONRSLS (reduced-space active set) or "
                      "SNESVINEWTONSSLS (semismooth Fischer-Burmeister with "
                      "line search).");
    prm.leave_subsection();
    prm.enter_subsection("Benchmark");
    prm.declare_entry("Reference Poisson solve",
                      "false",
                      Patterns::Bool(),
                      "After each cycle, solve -mu Lap u = f, u = g for each "
                      "membrane on the same mesh with CG + AMG and record its "
                      "wall time in summary.json (reference_poisson): the "
                      "cost unit of bench/membranes_cost.py.");
    prm.declare_entry("Compare with PETSc VI",
                      "false",
                      Patterns::Bool(),
                      "With Solver = semismooth-newton: solve every mesh a "
                      "second time with PETSc's SNES VI (PETSc VI type and "
                      "the Linear solver section, as for Solver = petsc-vi) "
                      "from the same initial iterate, and record its "
                      "iterations, wall time, error and distance to our "
                      "solution in summary.json (petsc_vi). The run goes on "
                      "with our solution.");
    prm.leave_subsection();
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    problem.parse(prm);
    mesh.parse(prm);
    discretization.parse(prm);
    nonlinear_solver.parse(prm);
    linear_solver.parse(prm);
    estimators.parse(prm);
    output.parse(prm);
    prm.enter_subsection("Benchmark");
    reference_poisson_solve = prm.get_bool("Reference Poisson solve");
    compare_with_petsc_vi   = prm.get_bool("Compare with PETSc VI");
    prm.leave_subsection();
    prm.enter_subsection("Nonlinear solver");
    nonlinear_method = prm.get("Solver");
    petsc_vi_type    = prm.get("PETSc VI type");
    prm.leave_subsection();

    if (nonlinear_method == "petsc-vi")
      {
        if (nonlinear_solver.strategy == "adaptive")
          throw VI::InputError(
            "Nonlinear solver/Strategy = adaptive stops our semismooth "
            "Newton by the estimators, which PETSc's SNES VI cannot do: use "
            "exact or inexact with Solver = petsc-vi");
        if (compare_with_petsc_vi)
          throw VI::InputError(
            "Benchmark/Compare with PETSc VI compares our semismooth Newton "
            "with PETSc's: set Nonlinear solver/Solver = semismooth-newton");
      }

    const std::string &strategy = nonlinear_solver.strategy;
    if (strategy != "exact" && linear_solver.solver != "gmres")
      throw VI::InputError("Nonlinear solver/Strategy = " + strategy +
                           " needs an iterative linear solver: set Linear "
                           "solver/Solver = gmres");
    if (mesh.refinement == "adaptive" && !estimators.enabled)
      throw VI::InputError("Mesh/Refinement = adaptive marks the cells with "
                           "the estimators: set Estimators/Enabled = true");
    if (strategy == "adaptive" && !estimators.enabled)
      throw VI::InputError("Nonlinear solver/Strategy = adaptive stops the "
                           "solvers with the estimators: set "
                           "Estimators/Enabled = true");
    if (estimators.equilibrated_dual_norms() && discretization.method != "fem")
      throw VI::InputError("Estimators/Equilibrated dual norms is "
                           "implemented for Discretization/Method = fem: "
                           "leave it empty for the dG methods");
    if (estimators.sharpen_final && discretization.method != "fem")
      throw VI::InputError("Estimators/Sharpen final estimate is implemented "
                           "for Discretization/Method = fem: set it to false "
                           "for the dG methods");
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
      , geometry_mapping(
          VI::make_mapping<dim>(geometry, parameters.discretization.degree))
      , mapping(std::make_unique<MappingQCache<dim>>(
          dynamic_cast<const MappingQ<dim> &>(*geometry_mapping).get_degree()))
      , fe(parameters.discretization.degree)
      , dof_handler(triangulation)
      // One quadrature for the load, the flux reconstruction and the
      // estimators, so that the patch problems are exactly compatible with the
      // discrete equations (see FluxReconstruction::quadrature_points).
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
      , run_record("step-membranes", parameters.output.directory, timer, comm)
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
    VI::check_membrane_data(data,
                            triangulation,
                            *mapping,
                            quadrature.get_points(),
                            fe.get_unit_support_points(),
                            comm);
  }


  template <int dim>
  void
  MembraneProblem<dim>::make_grid()
  {
    VI::make_coarse_mesh(geometry, triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
    mapping->initialize(*geometry_mapping, triangulation);
  }


  // Distribute the nodes, build the constraints (hanging nodes, Dirichlet
  // data, no multiplier on constrained nodes), the contact rows and the
  // sparsity of A; and the patches of the flux reconstruction.
  template <int dim>
  void
  MembraneProblem<dim>::setup_system()
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

    t.stop();
    if (parameters.estimators.enabled)
      {
        // The patch matrices: a cost of the estimators.
        TimerOutput::Scope t(timer, "estimators: patch matrices");
        flux_reconstruction = std::make_unique<VI::FluxReconstruction<dim>>(
          *mapping,
          parameters.estimators.flux_degree_for(fe.degree),
          fe.degree);
        flux_reconstruction->reinit(dof_handler);
        if (parameters.output.verbose)
          {
            const auto [n_patches, n_matrices] =
              flux_reconstruction->statistics();
            pcout << "   Flux reconstruction: " << n_patches
                  << " vertex patches, " << n_matrices
                  << " distinct patch matrices" << std::endl;
          }
        cell_multiplier.reset();
        if (fe.degree > 1 &&
            parameters.estimators.multiplier == "contact cells")
          {
            cell_multiplier = std::make_unique<VI::CellMultiplier<dim>>();
            cell_multiplier->reinit(*mapping,
                                    dof_handler,
                                    u1_constraints,
                                    flux_reconstruction->get_quadrature());
          }
        dual_norm.reset();
        if (parameters.estimators.needs_dual_norm_bound())
          {
            dual_norm =
              std::make_unique<VI::DualNormBound<dim>>(*mapping,
                                                       *flux_reconstruction,
                                                       VI::friedrichs_constant(
                                                         geometry));
            dual_norm->reinit(triangulation);
          }
        vertex_dofs.assign(triangulation.n_vertices(),
                           numbers::invalid_dof_index);
        for (const auto &cell : dof_handler.active_cell_iterators())
          if (!cell->is_artificial())
            for (const unsigned int v : cell->vertex_indices())
              vertex_dofs[cell->vertex_index(v)] = cell->vertex_dof_index(v, 0);
      }
  }


  template <int dim>
  void
  MembraneProblem<dim>::on_owned_cells_in_parallel(
    const std::function<
      void(const std::vector<typename DoFHandler<dim>::active_cell_iterator> &,
           const std::size_t,
           const std::size_t)> &work) const
  {
    std::vector<typename DoFHandler<dim>::active_cell_iterator> cells;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        cells.push_back(cell);
    parallel::apply_to_subranges(
      std::size_t(0),
      cells.size(),
      [&](const std::size_t begin, const std::size_t end) {
        work(cells, begin, end);
      },
      /*grainsize=*/1024);
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
    for (unsigned int a = 0; a < 2; ++a)
      load_values[a].assign(triangulation.n_active_cells() * quadrature.size(),
                            0.);
    on_owned_cells_in_parallel(
      [&](const auto &cells, const std::size_t begin, const std::size_t end) {
        const Function<dim> *f[2] = {data.f1.get(), data.f2.get()};
        FEValues<dim> where(*mapping, fe, quadrature, update_quadrature_points);
        std::vector<double> values(quadrature.size());
        for (std::size_t c = begin; c < end; ++c)
          {
            where.reinit(cells[c]);
            for (unsigned int a = 0; a < 2; ++a)
              {
                f[a]->value_list(where.get_quadrature_points(), values);
                std::copy(values.begin(),
                          values.end(),
                          load_values[a].begin() +
                            cells[c]->active_cell_index() * quadrature.size());
              }
          }
      });
    loads.stop();

    // (a mass matrix for p >= 2 only, see setup_system())
    const bool with_mass_matrix = fe.degree > 1;
    contact_system.matrix       = 0;
    contact_system.rhs          = 0;
    stiffness_matrix            = 0;
    Vector lumped_mass(owned_nodes, comm);
    if (with_mass_matrix)
      mass_matrix = 0;

    // mesh_loop calls the copier for every cell of the range it is given,
    // so the range is filtered to the locally owned cells.
    const auto owned_cells =
      dof_handler.active_cell_iterators() | IteratorFilters::LocallyOwnedCell();
    using Iterator = typename DoFHandler<dim>::active_cell_iterator;
    // Matrices: stiffness, mass. Vectors: (f1, psi), (f2, psi), (1, psi).
    using CopyData = MeshWorker::CopyData<2, 3, 1>;

    MeshWorker::ScratchData<dim> scratch(*mapping,
                                         fe,
                                         quadrature,
                                         update_values | update_gradients |
                                           update_JxW_values);
    CopyData                     copy(fe.n_dofs_per_cell());

    const auto cell_worker = [&](const Iterator               &cell,
                                 MeshWorker::ScratchData<dim> &scratch,
                                 CopyData                     &copy) {
      const FEValues<dim> &fe_values = scratch.reinit(cell);
      for (auto &m : copy.matrices)
        m = 0;
      for (auto &v : copy.vectors)
        v = 0;
      cell->get_dof_indices(copy.local_dof_indices[0]);

      const std::size_t first = cell->active_cell_index() * quadrature.size();
      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double f1 = load_values[0][first + q];
          const double f2 = load_values[1][first + q];
          const double dx = fe_values.JxW(q);
          for (const unsigned int i : fe_values.dof_indices())
            {
              const double phi_i = fe_values.shape_value(i, q);
              for (const unsigned int j : fe_values.dof_indices())
                copy.matrices[0](i, j) +=
                  fe_values.shape_grad(i, q) * fe_values.shape_grad(j, q) * dx;
              if (with_mass_matrix)
                for (const unsigned int j : fe_values.dof_indices())
                  copy.matrices[1](i, j) +=
                    phi_i * fe_values.shape_value(j, q) * dx;
              copy.vectors[0](i) += f1 * phi_i * dx;
              copy.vectors[1](i) += f2 * phi_i * dx;
              copy.vectors[2](i) += phi_i * dx;
            }
        }
    };

    std::vector<types::global_dof_index> system_dofs(fe.n_dofs_per_cell());
    FullMatrix<double>                   scaled_stiffness(fe.n_dofs_per_cell());
    const double                         mu[2]  = {data.mu1, data.mu2};
    const auto                           copier = [&](const CopyData &copy) {
      const auto &dofs = copy.local_dof_indices[0];
      // The loads; the stiffness mu_alpha S moves the Dirichlet data g_j to
      // the right-hand side of the unconstrained rows. (The blocks mu_alpha
      // S themselves are copied from S below.)
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
      hanging_node_constraints.distribute_local_to_global(copy.vectors[2],
                                                          dofs,
                                                          lumped_mass);
      if (with_mass_matrix)
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
    contact_system.rhs.compress(VectorOperation::add);
    stiffness_matrix.compress(VectorOperation::add);
    lumped_mass.compress(VectorOperation::add);
    if (with_mass_matrix)
      mass_matrix.compress(VectorOperation::add);

    // The blocks of u1 and u2 are mu1 S and mu2 S (the constraints of u1
    // and u2 constrain the same nodes, with the same weights), copied row
    // by row instead of assembled twice more through the constraints. The
    // row of a constrained node reads d X_i = d g_i: X satisfies every row
    // of E X = F, and Newton updates vanish on the boundary.
    // (S's rows read through Epetra: deal.II's row iterators copy a row
    // at every step)
    Assert(u1_constraints.n_constraints() == u2_constraints.n_constraints(),
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
        for (const unsigned int field :
             {VI::NodalFields::u1, VI::NodalFields::u2})
          {
            for (int k = 0; k < n_entries; ++k)
              {
                system_columns[k] = index(columns[k], field);
                scaled_values[k]  = mu[field] * values[k];
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
    std::vector<types::global_dof_index> constrained_nodes;
    for (const types::global_dof_index i : owned_nodes)
      if (u1_constraints.is_constrained(i))
        constrained_nodes.push_back(i);
    contact_system.set_coupling(
      [&](const types::global_dof_index i) {
        return fe.degree == 1 ? lumped_mass(i) : 1.;
      },
      constrained_nodes);

    // Rows that enforce u1 = u2 weigh mu_r S_ii.
    const double        mu_r = data.mu1 * data.mu2 / (data.mu1 + data.mu2);
    std::vector<double> stiffness_weight(owned_nodes.n_elements());
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      stiffness_weight[k] =
        mu_r * stiffness_matrix.diag_element(owned_nodes.nth_index_in_set(k));
    contact_system.set_stiffness_weights(std::move(stiffness_weight));

    if (parameters.linear_solver.solver == "gmres" &&
        parameters.linear_solver.preconditioner == "amg")
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
    solution = 0;
    Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      lambda(owned_nodes, comm), X3(owned_nodes, comm);
    if (solution_transfer)
      {
        std::vector<Vector *> fields = {&u1, &u2, &lambda};
        solution_transfer->interpolate(fields);
        solution_transfer.reset();
        compute_dual_coefficients(lambda, X3);
        VI::NodalFields::insert(X3, multiplier, solution);
      }
    else if (parameters.nonlinear_solver.initial_guess == "data")
      {
        VectorTools::interpolate(*mapping, dof_handler, *data.g1, u1);
        VectorTools::interpolate(*mapping, dof_handler, *data.g2, u2);
      }
    VI::NodalFields::insert(u1, VI::NodalFields::u1, solution);
    VI::NodalFields::insert(u2, VI::NodalFields::u2, solution);
    system_constraints.distribute(solution);
  }


  // Semismooth Newton with the chosen strategy. Every Newton iterate gets an
  // a posteriori estimate (when the estimators are on): the one computed by
  // the linear solver's checks if the iterate is the one it accepted,
  // otherwise one computed for it. The adaptive strategy stops Newton when
  // eta_lin <= gamma_lin eta_disc.
  template <int dim>
  void
  MembraneProblem<dim>::solve()
  {
    stopping.start_solve();
    final_estimate.reset();
    final_estimate_sharpened = false;
    if (parameters.nonlinear_method == "petsc-vi")
      {
        std::string reason;
        newton_report = solve_with_petsc_vi(solution, reason);
        if (parameters.output.verbose)
          pcout << "      SNES VI: " << reason << std::endl;
        if (parameters.estimators.enabled)
          final_estimate = estimate(solution);
        sharpen_final_estimate();
        return;
      }

    VI::SemismoothNewton<Vector> newton(
      typename VI::SemismoothNewton<Vector>::AdditionalData(
        parameters.nonlinear_solver, C));
    contact_system.start_newton();
    contact_system.attach(newton, parameters.output.verbose ? &pcout : nullptr);
    newton.setup_jacobian = [&](const Vector &X) {
      stopping.start_step(X);
      if (cell_multiplier)
        contact_nodes(X, step_contact_nodes);
      contact_system.setup_jacobian(X);
    };
    newton.solve_with_jacobian = [&](const Vector &rhs, Vector &dX) {
      const unsigned int iterations = solve_linearized(rhs, dX);
      // The rows of hanging nodes are trivial in the condensed matrix: the
      // update there follows the constraints (linear, homogeneous), so
      // that every iterate stays conforming.
      system_hanging_constraints.distribute(dX);
      return iterations;
    };
    if (parameters.estimators.enabled)
      {
        newton.stopping_criterion = [&](const Vector         &X,
                                        const VI::NewtonStep &step) {
          return stopping.newton_criterion(X, step);
        };
        // With the line search (Fischer-Burmeister), the full step is taken
        // when GMRES accepted it with an estimate that meets the adaptive
        // stopping criterion: it ends the iteration with a guaranteed bound,
        // so the Armijo test on the residual, which an inexact direction
        // need not pass, is not asked (on the nested disk meshes it cut such
        // steps to 1/32 and 1/4, three Newton steps and five estimates
        // instead of one).
        newton.accept_full_step = [&](const Vector &) {
          return stopping.step_is_certified();
        };
      }

    newton_report  = newton.solve(solution);
    final_estimate = std::move(stopping.final_estimate);
    // (no Newton step was needed, or Newton met its tolerance at a step
    // whose fluxes were deferred)
    if (parameters.estimators.enabled && !final_estimate)
      {
        final_estimate = estimate(solution);
        remember_eta_disc(*final_estimate);
      }
    sharpen_final_estimate();
  }


  // One linearised system A dX = rhs (ContactSystem::solve): with the
  // estimators watching GMRES for the adaptive strategy (or on request,
  // Estimators/At every check), every nu iterations.
  template <int dim>
  unsigned int
  MembraneProblem<dim>::solve_linearized(const Vector &rhs, Vector &dX)
  {
    const auto &estimators = parameters.estimators;
    if (!estimators.enabled || !(stopping.adaptive() || estimators.every_check))
      return contact_system.solve(rhs, dX);
    // Estimators/Defer fluxes: the flux-free terms first (see
    // stopping_hooks()), against the eta_disc predicted for this mesh.
    step_predicted_eta_disc = stopping.adaptive() && estimators.defer_fluxes &&
                                  !estimators.dual_norm_undershoots ?
                                predicted_eta_disc() :
                                std::nullopt;
    return contact_system.solve(rhs,
                                dX,
                                stopping.gmres_monitor(),
                                stopping.accepted_update_of_step());
  }


  // What the adaptive stopping sees of this program. At every check the
  // current iterate is certified with its own fluxes (its algebraic residual
  // bounded by the Friedrichs constant), and the previous check's iterate
  // with the current one as look-ahead (sharper).
  template <int dim>
  typename VI::AdaptiveStopping<typename MembraneProblem<dim>::Iterate,
                                VI::ContactEstimate>::Hooks
  MembraneProblem<dim>::stopping_hooks()
  {
    typename VI::AdaptiveStopping<Iterate, VI::ContactEstimate>::Hooks hooks;
    hooks.describe = [this](const Vector &X, Iterate &it) {
      describe_iterate(X, step_contact_nodes, it, !step_predicted_eta_disc);
    };
    // Estimators/Equilibrated dual norms = remainder: the sharper bound of
    // the remainder is skipped where the test would fail with it too: a
    // sharper bound lowers eta_alg to flux_alg at most and does not raise
    // eta_disc or eta_lin. The decisions are those of the sharper estimate.
    // The other strategies decide nothing at the checks: their records keep
    // Friedrichs' bound.
    hooks.estimate = [this](const Iterate &it, const Iterate &ahead) {
      const VI::ContactEstimate e =
        estimate(it, ahead, false, [&](const VI::ContactEstimate &e) {
          return stopping.adaptive() &&
                 parameters.nonlinear_solver.algebraic_error_small(e.eta_disc,
                                                                   e.eta_lin,
                                                                   e.flux_alg);
        });
      // An iterate's own estimate predicts eta_disc on the next meshes.
      if (&it == &ahead)
        remember_eta_disc(e);
      return e;
    };
    hooks.estimate_iterate = [this](const Vector &X) { return estimate(X); };
    hooks.components       = [](const VI::ContactEstimate &e) {
      return VI::StoppingComponents{
        e.complete, e.eta, e.eta_disc, e.eta_lin, e.eta_alg, e.eta_lin};
    };
    // Estimators/Defer fluxes: the flux-free terms' eta_alg bounds the
    // complete estimate's from above and their eta_lin from below, so when
    // they say that GMRES may stop, it may; if moreover eta_lin exceeds
    // gamma_lin times the predicted eta_disc, Newton will (very likely) go
    // on, and this iterate's fluxes are not needed.
    hooks.decide_early =
      [this](Iterate &current) -> std::optional<VI::ContactEstimate> {
      if (!step_predicted_eta_disc)
        return std::nullopt;
      const auto               &nonlinear = parameters.nonlinear_solver;
      const VI::ContactEstimate flux_free = estimate(current, current);
      if (nonlinear.algebraic_error_small(0.,
                                          flux_free.eta_lin,
                                          flux_free.eta_alg) &&
          !nonlinear.linearisation_error_small(*step_predicted_eta_disc,
                                               flux_free.eta_lin))
        return flux_free;
      add_fluxes(current);
      return std::nullopt;
    };
    hooks.on_newton_estimate = [this](const VI::ContactEstimate &e) {
      remember_eta_disc(e);
    };
    return hooks;
  }


  // The peer solver. PETSc's SNES VI bounds variables, not combinations of
  // them, so the problem is handed over in the variables y = (s, w) of each
  // node, the weighted mean s = theta1 u1 + theta2 u2 and the gap
  // w = u1 - u2 (theta_alpha = mu_alpha / (mu1 + mu2)), X = T y with
  // T (s, w) = (s + theta2 w, s - theta1 w); the constraint is w >= 0.
  // Eliminating the multiplier gives the equivalent mixed complementarity
  // problem
  //
  //   K y - b = T^T (E X - F),   b = T^T F = (F1 + F2, theta2 F1 - theta1 F2),
  //   K = T^T E T = [S1 + S2,                 theta2 S1 - theta1 S2 ;
  //                  theta2 S1 - theta1 S2,   theta2^2 S1 + theta1^2 S2],
  //
  // whose w row at a contact node is (theta2 + theta1) D X3 = D X3 >= 0,
  // complementary to w >= 0: the discrete solution is the same (u1h, u2h)
  // and the multiplier is recovered as X3 = (E X - F)_{u1} / D. With
  // S_alpha = mu_alpha S the off-diagonal blocks vanish and K is two
  // Laplacians, (mu1 + mu2) S for s and mu1 mu2 / (mu1 + mu2) S for w (the
  // mean / gap decoupling of our contact preconditioner): every reduced
  // system of the active-set method is symmetric positive definite, and
  // MUMPS, GMRES + BoomerAMG and ILU all apply. This is the peer at its
  // best: in the variables (u2, u1 - u2) BoomerAMG needs ten times more
  // iterations.
  template <int dim>
  VI::NewtonReport
  MembraneProblem<dim>::solve_with_petsc_vi(Vector      &X,
                                            std::string &reason) const
  {
    TimerOutput::Scope t(timer, "petsc-vi");
    using VI::NodalFields::u1;
    using VI::NodalFields::u2;
    const auto pair = [](const types::global_dof_index i,
                         const unsigned int            c) {
      return 2 * i + c; // c = 0: s, 1: w
    };
    const double theta1 = data.mu1 / (data.mu1 + data.mu2);
    const double theta2 = data.mu2 / (data.mu1 + data.mu2);
    IndexSet     owned_pairs(2 * dof_handler.n_dofs());
    for (auto range = owned_nodes.begin_intervals();
         range != owned_nodes.end_intervals();
         ++range)
      owned_pairs.add_range(pair(*range->begin(), 0),
                            pair(range->last() + 1, 0));

    // Rows u1 and u2 of E without the multiplier column: S1, S2 per node.
    // (Epetra's row views: deal.II's matrix iterators are orders of
    // magnitude slower on distributed matrices.)
    const Epetra_CrsMatrix &E = contact_system.matrix.trilinos_matrix();
    const auto              for_each_entry = [&](const auto &action) {
      for (const types::global_dof_index i : owned_nodes)
        for (const unsigned int field : {u1, u2})
          {
            const int row = E.LRID(
              static_cast<TrilinosWrappers::types::int_type>(index(i, field)));
            int     n_entries = 0;
            double *values    = nullptr;
            int    *columns   = nullptr;
            E.ExtractMyRowView(row, n_entries, values, columns);
            for (int k = 0; k < n_entries; ++k)
              {
                const types::global_dof_index column =
                  TrilinosWrappers::global_column_index(E, columns[k]);
                if (column % n_fields == field)
                  action(i, field, column / n_fields, values[k]);
              }
          }
    };
    DynamicSparsityPattern pattern(owned_pairs.size(),
                                   owned_pairs.size(),
                                   owned_pairs);
    for_each_entry([&](const auto i, const unsigned int, const auto j, double) {
      for (const unsigned int a : {0, 1})
        for (const unsigned int b : {0, 1})
          pattern.add(pair(i, a), pair(j, b));
    });
    PETScWrappers::MPI::SparseMatrix K;
    K.reinit(owned_pairs, owned_pairs, pattern, comm);
    for_each_entry([&](const auto     i,
                       const unsigned field,
                       const auto     j,
                       const double   value) {
      // S_alpha's share of each block of T^T E T.
      const double t = field == u1 ? theta2 : -theta1;
      K.add(pair(i, 0), pair(j, 0), value);
      K.add(pair(i, 0), pair(j, 1), t * value);
      K.add(pair(i, 1), pair(j, 0), t * value);
      K.add(pair(i, 1), pair(j, 1), t * t * value);
    });
    K.compress(VectorOperation::add);

    // RSLS holds a variable within 1e-8 of its bound as active, an absolute
    // tolerance hard-wired in PETSc (SNESVIGetActiveSetIS): y is handed
    // over in units of the size U of the initial iterate, so that this
    // means 1e-8 relative (K (y / U) = b / U).
    double U = 0;
    for (const types::global_dof_index i : owned_nodes)
      U = std::max({U, std::abs(X(index(i, u1))), std::abs(X(index(i, u2)))});
    U = Utilities::MPI::max(U, comm);
    if (!(U > 0) || !std::isfinite(U))
      U = 1.;
    std::vector<types::global_dof_index> indices;
    std::vector<double>                  b_values, y_values;
    for (const types::global_dof_index i : owned_nodes)
      {
        const double F1 = contact_system.rhs(index(i, u1)) / U,
                     F2 = contact_system.rhs(index(i, u2)) / U;
        const double X1 = X(index(i, u1)) / U, X2 = X(index(i, u2)) / U;
        indices.insert(indices.end(), {pair(i, 0), pair(i, 1)});
        b_values.insert(b_values.end(), {F1 + F2, theta2 * F1 - theta1 * F2});
        y_values.insert(y_values.end(), {theta1 * X1 + theta2 * X2, X1 - X2});
      }
    PETScWrappers::MPI::Vector b(owned_pairs, comm), y(owned_pairs, comm);
    b.set(indices, b_values);
    y.set(indices, y_values);
    b.compress(VectorOperation::insert);
    y.compress(VectorOperation::insert);
    IndexSet bounded(owned_pairs.size());
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      bounded.add_index(pair(i, 1));

    const auto                 &linear    = parameters.linear_solver;
    const auto                 &nonlinear = parameters.nonlinear_solver;
    VI::PetscVI::AdditionalData settings;
    settings.type                  = parameters.petsc_vi_type;
    settings.linear_solver         = linear.solver;
    settings.preconditioner        = linear.preconditioner;
    settings.ilu_fill              = linear.ilu_fill;
    settings.linear_tolerance      = VI::linear_tolerance(nonlinear, linear);
    settings.max_linear_iterations = linear.max_iterations;
    settings.krylov_dimension      = linear.krylov_dimension;
    settings.tolerance             = nonlinear.tolerance;
    settings.max_iterations        = nonlinear.max_iterations;
    const VI::PetscVI    peer(settings);
    VI::PetscVI::Monitor monitor;
    if (parameters.output.verbose)
      monitor = [&](const unsigned int step,
                    const double       norm,
                    const unsigned int linear_iterations) {
        pcout << "      k = " << std::setw(2) << step << ": SNES VI residual "
              << std::scientific << std::setprecision(2) << norm
              << std::defaultfloat << ", " << linear_iterations
              << " linear iterations in all" << std::endl;
      };
    const VI::PetscVIReport report = peer.solve(K, b, bounded, y, monitor);
    reason                         = report.reason;

    // Back to X = (v + w, v, X3): conforming at hanging nodes, and the
    // multiplier from the balance rows of u1 (E's multiplier column is -D).
    y.extract_subvector_to(indices, y_values);
    for (std::size_t k = 0; k < indices.size() / 2; ++k)
      {
        const types::global_dof_index i = indices[2 * k] / 2;
        X(index(i, u1)) = U * (y_values[2 * k] + theta2 * y_values[2 * k + 1]);
        X(index(i, u2)) = U * (y_values[2 * k] - theta1 * y_values[2 * k + 1]);
        X(index(i, multiplier)) = 0.;
      }
    X.compress(VectorOperation::insert);
    system_hanging_constraints.distribute(X);
    Vector R(owned_system, comm);
    contact_system.matrix.vmult(R, X);
    R -= contact_system.rhs;
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      X(index(i, multiplier)) = R(index(i, u1)) / contact_system.coupling()(i);
    X.compress(VectorOperation::insert);

    VI::NewtonReport newton;
    newton.iterations        = report.iterations;
    newton.linear_iterations = report.linear_iterations;
    newton.final_residual    = contact_system.residual(X, R);
    return newton;
  }


  // The peer from the same initial iterate, measured beside our solution;
  // the run then goes on with ours (its fields are restored).
  template <int dim>
  void
  MembraneProblem<dim>::compare_with_petsc_vi(const Vector &initial)
  {
    const Vector ours        = solution;
    const double ours_error  = error_energy;
    const double ours_lambda = error_multiplier;

    Timer            wall;
    std::string      reason;
    VI::NewtonReport report;
    solution = initial;
    try
      {
        report = solve_with_petsc_vi(solution, reason);
      }
    catch (const VI::SolverFailure &failure)
      {
        // The peer's failure is a result of the comparison, not of the run.
        wall.stop();
        pcout << "   " << failure.what() << std::endl;
        PeerRun run;
        run.converged = false;
        run.reason    = failure.what();
        run.seconds   = wall.wall_time();
        petsc_vi_run  = run;
        solution      = ours;
        postprocess();
        return;
      }
    wall.stop();

    // max_i |u_peer - u_ours| over both membranes, relative to max |u_ours|.
    double local[2] = {0., 0.};
    for (const types::global_dof_index i : owned_nodes)
      for (const unsigned int field :
           {VI::NodalFields::u1, VI::NodalFields::u2})
        {
          const auto k = index(i, field);
          local[0]     = std::max(local[0], std::abs(solution(k) - ours(k)));
          local[1]     = std::max(local[1], std::abs(ours(k)));
        }
    const double distance = Utilities::MPI::max(local[0], comm) /
                            std::max(Utilities::MPI::max(local[1], comm),
                                     std::numeric_limits<double>::min());

    PeerRun run;
    run.report   = report;
    run.reason   = reason;
    run.seconds  = wall.wall_time();
    run.distance = distance;
    if (data.has_exact_solution())
      {
        postprocess();
        compute_errors();
        run.error_energy = error_energy;
      }
    pcout << "   PETSc SNES VI (vinewton" << parameters.petsc_vi_type
          << "): " << report.iterations << " iterations, "
          << report.linear_iterations << " linear, " << std::setprecision(3)
          << run.seconds
          << " s, max |u - u_ours| / max |u_ours| = " << std::scientific
          << std::setprecision(2) << distance << std::defaultfloat;
    if (data.has_exact_solution())
      pcout << ", energy error " << std::scientific << std::setprecision(3)
            << run.error_energy << std::defaultfloat;
    pcout << std::endl;
    petsc_vi_run = run;

    solution         = ours;
    error_energy     = ours_error;
    error_multiplier = ours_lambda;
    postprocess();
  }


  // The iterate as the estimators need it: u1h, u2h, s_h (nodal averaging
  // where u1h < u2h), lambda_h and its part from nonnegative coefficients,
  // the algebraic residual r_h of the balance equations (<r_h, psi_i>_h =
  // (F - E X)_i), and the equilibrated fluxes of both membranes.
  template <int dim>
  void
  MembraneProblem<dim>::contact_nodes(const Vector &X, Vector &indicator) const
  {
    Vector owned(owned_nodes, comm);
    contact_system.contact_rows().contact_set(X, owned);
    indicator.reinit(owned_nodes, relevant_nodes, comm);
    indicator = owned;
  }


  template <int dim>
  void
  MembraneProblem<dim>::describe_iterate(const Vector &X,
                                         const Vector &contact,
                                         Iterate      &it,
                                         const bool    fluxes) const
  {
    {
      TimerOutput::Scope t(timer, "estimators: fields");
      describe_fields(X, contact, it);
    }
    it.has_fluxes = false;
    if (fluxes)
      add_fluxes(it);
  }


  template <int dim>
  void
  MembraneProblem<dim>::describe_fields(const Vector &X,
                                        const Vector &contact,
                                        Iterate      &it) const
  {
    it.X = X;

    Vector u1(owned_nodes, comm), u2(owned_nodes, comm), s1(owned_nodes, comm),
      s2(owned_nodes, comm), moments(owned_nodes, comm),
      function(owned_nodes, comm);

    VI::NodalFields::extract(X, VI::NodalFields::u1, u1);
    VI::NodalFields::extract(X, VI::NodalFields::u2, u2);
    // (a GMRES iterate need not satisfy the hanging node constraints; its
    // conforming version has the same residual in the condensed rows)
    hanging_node_constraints.distribute(u1);
    hanging_node_constraints.distribute(u2);
    VI::average_at_violated_nodes(data.mu1, data.mu2, u1, u2, s1, s2);
    // (hanging nodes follow the averaged values of their parents)
    hanging_node_constraints.distribute(s1);
    hanging_node_constraints.distribute(s2);
    ghosted_nodes.copy(u1, it.u1);
    ghosted_nodes.copy(u2, it.u2);
    ghosted_nodes.copy(s1, it.s1);
    ghosted_nodes.copy(s2, it.s2);

    // lambda_h: <lambda_h, psi_i>_h = D_i X3_i = m_i.
    VI::NodalFields::extract(X, multiplier, moments);
    moments.scale(contact_system.coupling());
    if (cell_multiplier)
      {
        // 2 <lambda_h, u1h - u2h>_h = 2 sum_i m_i (u1h - u2h)(x_i).
        Vector gap(u1);
        gap -= u2;
        it.complementarity = 2. * (moments * gap);
        Vector m;
        ghosted_nodes.copy(moments, m);
        cell_multiplier->distribute(m, contact, it.lambda_cells);
        for (double &value : moments)
          value = std::max(value, 0.);
        ghosted_nodes.copy(moments, m);
        cell_multiplier->distribute(m, contact, it.lambda_nonnegative_cells);
      }
    else
      multiplier_function.with_nonnegative_part(moments,
                                                it.lambda,
                                                it.lambda_nonnegative);

    // r_h from the residual F - E X of the rows of u1 and u2.
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
  }


  template <int dim>
  void
  MembraneProblem<dim>::add_fluxes(Iterate &it) const
  {
    TimerOutput::Scope t(timer, "estimators: fluxes");
    Vector            *r[2] = {&it.r1, &it.r2};

    // The fluxes: sigma_alpha ~ -mu_alpha grad u_alpha,h, equilibrated with
    // f_alpha -/+ lambda_h - r_alpha,h; for p = 1 the multiplier and the
    // residual enter each patch as the constants of its vertex (lumping).
    const bool    lumped  = fe.degree == 1;
    const Vector *u[2]    = {&it.u1, &it.u2};
    const double  mu[2]   = {data.mu1, data.mu2};
    const double  sign[2] = {-1., 1.}; // (-1)^alpha

    typename VI::FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = 2;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of the potential and the multiplier's and
      // residual's values
      return [&,
              values_of = std::make_shared<FEValues<dim>>(
                *mapping,
                fe,
                flux_reconstruction->get_quadrature(),
                update_values | update_gradients),
              lambda_values = std::vector<double>(quadrature.size()),
              r_values      = std::vector<double>(quadrature.size()),
              coefficients  = std::vector<double>()](const auto &cell,
                                                    auto       &flux,
                                                    auto &source) mutable {
        typename DoFHandler<dim>::active_cell_iterator dof_cell(&triangulation,
                                                                cell->level(),
                                                                cell->index(),
                                                                &dof_handler);
        FEValues<dim>                                 &values = *values_of;
        values.reinit(dof_cell);
        if (cell_multiplier)
          cell_multiplier->values(it.lambda_cells,
                                  cell->active_cell_index(),
                                  lambda_values);
        else if (!lumped)
          VI::cell_function_values(
            values, dof_cell, it.lambda, coefficients, &lambda_values);
        for (unsigned int a = 0; a < 2; ++a)
          {
            VI::cell_function_values(
              values, dof_cell, *u[a], coefficients, nullptr, &flux[a]);
            for (auto &F : flux[a])
              F *= mu[a];
            std::copy_n(load_values[a].begin() +
                          cell->active_cell_index() * source[a].size(),
                        source[a].size(),
                        source[a].begin());
            if (!lumped)
              {
                VI::cell_function_values(
                  values, dof_cell, *r[a], coefficients, &r_values);
                for (unsigned int q = 0; q < source[a].size(); ++q)
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
    it.has_fluxes = true;
  }


  template <int dim>
  std::optional<double>
  MembraneProblem<dim>::predicted_eta_disc() const
  {
    if (last_eta_disc_dofs == 0 || !(last_eta_disc > 0))
      return std::nullopt;
    // eta_disc ~ N^(-p/d) at the optimal rate
    return last_eta_disc *
           std::pow(double(last_eta_disc_dofs) / double(dof_handler.n_dofs()),
                    double(fe.degree) / dim);
  }


  template <int dim>
  void
  MembraneProblem<dim>::remember_eta_disc(const VI::ContactEstimate &e)
  {
    if (e.complete)
      {
        last_eta_disc      = e.eta_disc;
        last_eta_disc_dofs = dof_handler.n_dofs();
      }
  }


  template <int dim>
  VI::ContactEstimate
  MembraneProblem<dim>::estimate(
    const Iterate                                          &it,
    const Iterate                                          &ahead,
    const bool                                              equilibrated,
    const std::function<bool(const VI::ContactEstimate &)> &sharpen_remainder)
    const
  {
    // (the flux-free evaluations of the deferred checks timed apart)
    TimerOutput::Scope t(timer,
                         it.has_fluxes ?
                           "estimators: evaluation" :
                           "estimators: evaluation without fluxes");
    const bool         undershoots =
      equilibrated || parameters.estimators.dual_norm_undershoots;
    const bool remainder =
      equilibrated || parameters.estimators.dual_norm_remainder;
    VI::ContactEstimatorInput<dim> in;
    in.mapping               = mapping.get();
    in.potential             = &dof_handler;
    in.flux                  = &flux_reconstruction->get_dof_handler();
    in.quadrature            = &flux_reconstruction->get_quadrature();
    in.flux_signs            = &flux_reconstruction->get_piola_signs();
    in.mu1                   = data.mu1;
    in.mu2                   = data.mu2;
    in.f1                    = data.f1.get();
    in.f2                    = data.f2.get();
    in.f1_values             = &load_values[0];
    in.f2_values             = &load_values[1];
    in.g1                    = data.g1.get();
    in.g2                    = data.g2.get();
    in.friedrichs_constant   = VI::friedrichs_constant(geometry);
    in.mass_lumped           = fe.degree == 1;
    in.u1                    = &it.u1;
    in.u2                    = &it.u2;
    in.s1                    = &it.s1;
    in.s2                    = &it.s2;
    in.lambda                = &it.lambda;
    in.lambda_nonnegative    = &it.lambda_nonnegative;
    in.sigma1_disc           = &it.sigma1;
    in.sigma2_disc           = &it.sigma2;
    in.lambda_ahead          = &ahead.lambda;
    in.r1_ahead              = &ahead.r1;
    in.r2_ahead              = &ahead.r2;
    in.sigma1_ahead          = &ahead.sigma1;
    in.sigma2_ahead          = &ahead.sigma2;
    in.dual_norm             = dual_norm.get();
    in.dual_norm_undershoots = undershoots;
    in.dual_norm_remainder   = remainder;
    in.sharpen_remainder     = sharpen_remainder;
    in.without_fluxes        = !it.has_fluxes;
    AssertThrow(it.has_fluxes || &ahead == &it, ExcInternalError());
    if (cell_multiplier)
      {
        in.cell_multiplier          = cell_multiplier.get();
        in.lambda_cells             = &it.lambda_cells;
        in.lambda_nonnegative_cells = &it.lambda_nonnegative_cells;
        in.lambda_ahead_cells       = &ahead.lambda_cells;
        in.complementarity          = it.complementarity;
      }
    return VI::estimate_contact_error(in);
  }


  // The estimate of X with itself as look-ahead: sigma_alg = 0, and the
  // whole algebraic residual goes into the remainder.
  template <int dim>
  VI::ContactEstimate
  MembraneProblem<dim>::estimate(const Vector &X, const bool equilibrated) const
  {
    Iterate it;
    Vector  contact;
    if (cell_multiplier)
      contact_nodes(X, contact);
    describe_iterate(X, contact, it);
    return estimate(it, it, equilibrated);
  }


  // The estimate a solve ends with bounds the dual norms of the multiplier's
  // undershoot means and of the algebraic remainder with Friedrichs'
  // inequality, and for an iterate of the adaptive strategy it is the one
  // the stopping tests saw (often with a look-ahead). Equilibration bounds
  // both dual norms more sharply (doc/estimators.md), at the price of up to
  // three Poisson solves, which are worth paying once per mesh but not at
  // every check. Both bounds are guaranteed for the same iterate, so the
  // smaller one is reported; the stopping decisions are not affected.
  template <int dim>
  void
  MembraneProblem<dim>::sharpen_final_estimate()
  {
    if (!parameters.estimators.sharpen_final || !final_estimate)
      return;
    VI::ContactEstimate sharpened = estimate(solution, true);
    final_estimate_sharpened      = sharpened.eta < final_estimate->eta;
    if (final_estimate_sharpened)
      final_estimate = std::move(sharpened);
  }


  // The inverse map: X3_i = <lambda_h, psi_i>_h / D_i, i.e. lambda_h(x_i)
  // for p = 1 and (lambda_h, psi_i) for p >= 2, on the contact nodes.
  template <int dim>
  void
  MembraneProblem<dim>::compute_dual_coefficients(const Vector &lambda,
                                                  Vector       &X3) const
  {
    Vector values(owned_nodes, comm);
    if (fe.degree == 1)
      values = lambda;
    else
      mass_matrix.vmult(values, lambda);
    X3 = 0;
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      X3(i) = values(i);
    X3.compress(VectorOperation::insert);
  }


  // The discrete solution as finite element functions, the contact set.
  template <int dim>
  void
  MembraneProblem<dim>::postprocess()
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

    // On the cells of all threads (VectorTools::integrate_difference runs on
    // one), with the data's own gradients: for a parsed expression these
    // are fourth-order differences, eight evaluations per point, which make
    // this the longest part of a run after the solve.
    const QGauss<dim>      error_quadrature(fe.degree + 3);
    const unsigned int     n_cells = triangulation.n_active_cells();
    dealii::Vector<double> cell_u1(n_cells), cell_u2(n_cells),
      cell_lambda(n_cells);
    on_owned_cells_in_parallel(
      [&](const auto &cells, const std::size_t begin, const std::size_t end) {
        FEValues<dim>       values(*mapping,
                             fe,
                             error_quadrature,
                             update_values | update_gradients |
                               update_quadrature_points | update_JxW_values);
        const unsigned int  n_q = error_quadrature.size();
        std::vector<double> coefficients, lambda(n_q), exact_lambda(n_q);
        std::vector<Tensor<1, dim>> gradient(n_q), exact_gradient(n_q);
        const Vector               *u[2]      = {&u1_h, &u2_h};
        const Function<dim>        *exact[2]  = {data.exact_u1.get(),
                                                 data.exact_u2.get()};
        dealii::Vector<double>     *cell_u[2] = {&cell_u1, &cell_u2};
        for (std::size_t c = begin; c < end; ++c)
          {
            const auto &cell = cells[c];
            values.reinit(cell);
            const auto &points = values.get_quadrature_points();
            for (unsigned int a = 0; a < 2; ++a)
              {
                VI::cell_function_values(
                  values, cell, *u[a], coefficients, nullptr, &gradient);
                exact[a]->gradient_list(points, exact_gradient);
                double sum = 0;
                for (unsigned int q = 0; q < n_q; ++q)
                  sum += (exact_gradient[q] - gradient[q]).norm_square() *
                         values.JxW(q);
                (*cell_u[a])[cell->active_cell_index()] = std::sqrt(sum);
              }
            if (data.exact_lambda)
              {
                VI::cell_function_values(
                  values, cell, lambda_h, coefficients, &lambda);
                data.exact_lambda->value_list(points, exact_lambda);
                double sum = 0;
                for (unsigned int q = 0; q < n_q; ++q)
                  sum +=
                    std::pow(exact_lambda[q] - lambda[q], 2) * values.JxW(q);
                cell_lambda[cell->active_cell_index()] = std::sqrt(sum);
              }
          }
      });
    const auto global = [&](const dealii::Vector<double> &cellwise) {
      return VectorTools::compute_global_error(triangulation,
                                               cellwise,
                                               VectorTools::L2_norm);
    };
    cell_error.reinit(n_cells);
    for (unsigned int K = 0; K < n_cells; ++K)
      cell_error[K] = std::sqrt(data.mu1 * cell_u1[K] * cell_u1[K] +
                                data.mu2 * cell_u2[K] * cell_u2[K]);
    const double e1 = global(cell_u1), e2 = global(cell_u2);
    error_energy = std::sqrt(data.mu1 * e1 * e1 + data.mu2 * e2 * e2);
    if (data.exact_lambda)
      error_multiplier = global(cell_lambda);
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
    dealii::Vector<float> subdomain(triangulation.n_active_cells());
    subdomain = triangulation.locally_owned_subdomain();
    data_out.add_data_vector(subdomain, "partition");

    // Per-cell estimators.
    std::vector<std::pair<std::string, dealii::Vector<float>>> indicators;
    if (final_estimate)
      indicators = VI::cell_indicators(*final_estimate);
    for (const auto &[name, values] : indicators)
      data_out.add_data_vector(values, name, DataOut<dim>::type_cell_data);
    if (data.has_exact_solution())
      data_out.add_data_vector(cell_error,
                               "error_energy",
                               DataOut<dim>::type_cell_data);

    data_out.build_patches(*mapping,
                           fe.degree,
                           VI::has_curved_cells(geometry) ?
                             DataOut<dim>::curved_inner_cells :
                             DataOut<dim>::curved_boundary);
    data_out.write_vtu_with_pvtu_record(
      parameters.output.directory + "/", "solution", cycle, comm, 2, 8);
  }


  // Global refinement, or the cells marked by the estimate of the last
  // solution; with nested iteration the current solution is carried to the
  // new mesh by SolutionTransfer (as finite element functions: the dual
  // coefficients X3 are recomputed on the new mesh).
  template <int dim>
  void
  MembraneProblem<dim>::refine_mesh()
  {
    TimerOutput::Scope t(timer, "refinement");
    const auto        &mesh = parameters.mesh;
    if (mesh.refinement == "adaptive")
      {
        Assert(final_estimate, ExcInternalError());
        VI::mark_cells_for_refinement(triangulation,
                                      final_estimate->cell_total,
                                      mesh.marking,
                                      mesh.refinement_fraction);
      }
    else
      for (const auto &cell : triangulation.active_cell_iterators())
        if (cell->is_locally_owned())
          cell->set_refine_flag();
    triangulation.prepare_coarsening_and_refinement();

    if (parameters.nonlinear_solver.nested_iteration)
      {
        solution_transfer = std::make_unique<
          parallel::distributed::SolutionTransfer<dim, Vector>>(dof_handler);
        solution_transfer->prepare_for_coarsening_and_refinement(
          std::vector<const Vector *>{&u1_h, &u2_h, &lambda_h});
      }
    triangulation.execute_coarsening_and_refinement();
  }


  namespace
  {
    VI::Json
    to_json(const VI::ContactEstimate &e)
    {
      VI::Json json        = VI::Json::object();
      json["eta"]          = e.eta;
      json["eta_disc"]     = e.eta_disc;
      json["eta_lin"]      = e.eta_lin;
      json["eta_alg"]      = e.eta_alg;
      json["eta_1"]        = e.eta_1;
      json["flux_disc"]    = e.flux_disc;
      json["residual"]     = e.residual;
      json["flux_alg"]     = e.flux_alg;
      json["remainder"]    = e.remainder;
      json["nonc_1"]       = e.nonc_1;
      json["nonc_1_disc"]  = e.nonc_1_disc;
      json["nonc_1_lin"]   = e.nonc_1_lin;
      json["nonc_2"]       = e.nonc_2;
      json["nonc_3"]       = e.nonc_3;
      json["contact_pos"]  = e.contact_pos;
      json["contact_cone"] = e.contact_cone;
      json["dirichlet"]    = e.dirichlet;
      return json;
    }


    VI::Json
    to_json(const VI::ProcessUsage &usage)
    {
      VI::Json json             = VI::Json::object();
      json["user_seconds"]      = usage.user_seconds;
      json["system_seconds"]    = usage.system_seconds;
      json["minor_page_faults"] = usage.minor_faults;
      return json;
    }
  } // namespace


  template <int dim>
  void
  MembraneProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const double wall = run_record.cycle_seconds();

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
    if (final_estimate)
      {
        table.add_value("eta", final_estimate->eta);
        table.set_scientific("eta", true);
        table.set_precision("eta", 4);
        if (data.has_exact_solution())
          {
            table.add_value("effectivity", final_estimate->eta / error_energy);
            table.set_precision("effectivity", 3);
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
    if (final_estimate)
      {
        record["eta"]      = final_estimate->eta;
        record["eta_disc"] = final_estimate->eta_disc;
        record["eta_lin"]  = final_estimate->eta_lin;
        record["eta_alg"]  = final_estimate->eta_alg;
        if (data.has_exact_solution())
          record["effectivity"] = final_estimate->eta / error_energy;
        record["estimate"] = to_json(*final_estimate);
        if (parameters.estimators.sharpen_final)
          // whether the equilibrated estimate was the smaller one
          record["estimate"]["sharpened"] = final_estimate_sharpened;
      }
    record["wall_seconds"]  = wall;
    record["solve_seconds"] = solve_timer.wall_time();
    record["solve_usage"]   = to_json(solve_usage);
    // This cycle's share of every TimerOutput section.
    record["timing"] = run_record.cycle_timing();
    if (parameters.reference_poisson_solve)
      {
        VI::Json reference = VI::Json::array();
        for (unsigned int a = 0; a < 2; ++a)
          {
            const PoissonCost cost =
              reference_poisson_solve(*mapping,
                                      dof_handler,
                                      quadrature,
                                      a == 0 ? data.mu1 : data.mu2,
                                      a == 0 ? *data.f1 : *data.f2,
                                      a == 0 ? *data.g1 : *data.g2,
                                      comm);
            VI::Json membrane      = VI::Json::object();
            membrane["seconds"]    = cost.seconds;
            membrane["iterations"] = cost.iterations;
            membrane["usage"]      = to_json(cost.usage);
            reference.push_back(membrane);
          }
        record["reference_poisson"] = reference;
      }

    // Newton steps, and every estimate (inner checks and accepted iterates).
    record["newton_steps"] = VI::newton_steps(newton_report);
    record["iterations"]   = VI::to_json(stopping.records, true);
    if (petsc_vi_run)
      {
        const PeerRun &peer = *petsc_vi_run;
        VI::Json       p    = VI::Json::object();
        p["solver"]         = "vinewton" + parameters.petsc_vi_type;
        p["converged"]      = peer.converged;
        p["reason"]         = peer.reason;
        p["seconds"]        = peer.seconds;
        if (peer.converged)
          {
            p["newton_iterations"]  = peer.report.iterations;
            p["linear_iterations"]  = peer.report.linear_iterations;
            p["residual_equations"] = peer.report.final_residual.equations;
            p["residual_complementarity"] =
              peer.report.final_residual.complementarity;
            p["relative_distance_to_ours"] = peer.distance;
            if (data.has_exact_solution())
              p["error_energy"] = peer.error_energy;
          }
        record["petsc_vi"] = p;

        // A failed peer shows as "failed" in its columns.
        const auto add = [&](const std::string &column, const auto value) {
          if (peer.converged)
            table.add_value(column, value);
          else
            table.add_value(column, std::string("failed"));
        };
        add("petsc_newton", peer.report.iterations);
        add("petsc_linear", peer.report.linear_iterations);
        add("petsc_distance", peer.distance);
        table.set_scientific("petsc_distance", true);
        table.set_precision("petsc_distance", 1);
        if (data.has_exact_solution())
          {
            add("petsc_error", peer.error_energy);
            table.set_scientific("petsc_error", true);
            table.set_precision("petsc_error", 4);
          }
      }

    run_record.add(record);
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
    if (parameters.estimators.enabled)
      errors.push_back("eta");

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
        if (parameters.estimators.enabled && data.has_exact_solution())
          columns.push_back("effectivity");
        if (parameters.compare_with_petsc_vi)
          {
            columns.insert(columns.end(),
                           {"petsc_newton", "petsc_linear", "petsc_distance"});
            if (data.has_exact_solution())
              columns.push_back("petsc_error");
          }
        ConvergenceTable file_table = with_rates;
        file_table.set_column_order(columns);
        file_table.write_text(file, TableHandler::org_mode_table);
      }
  }


  template <int dim>
  std::string
  MembraneProblem<dim>::description() const
  {
    const auto        &nonlinear = parameters.nonlinear_solver;
    const auto        &linear    = parameters.linear_solver;
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << parameters.mesh.geometry
         << ", Q" << fe.degree << " elements, " << solver_name() << " ("
         << nonlinear.strategy << ")"
         << (nonlinear.nested_iteration ? " with" : " without")
         << " nested iteration, "
         << (linear.solver == "direct" ?
               "direct solver " + linear.direct_package :
               "GMRES + " + linear.preconditioner)
         << (parameters.estimators.enabled ? ", estimators on" : "");
    return line.str();
  }


  template <int dim>
  std::string
  MembraneProblem<dim>::solver_name() const
  {
    return parameters.nonlinear_method == "petsc-vi" ?
             "PETSc SNES VI (vinewton" + parameters.petsc_vi_type + ")" :
             "Newton-" + C.name();
  }


  template <int dim>
  void
  MembraneProblem<dim>::print_cycle_header(const unsigned int cycle) const
  {
    pcout << "Cycle " << cycle << ": " << triangulation.n_global_active_cells()
          << " cells, " << n_fields * dof_handler.n_dofs() << " unknowns ("
          << dof_handler.n_dofs() << " per field)" << std::endl;
  }


  template <int dim>
  VI::CycleLine
  MembraneProblem<dim>::cycle_line() const
  {
    VI::CycleLine line;
    line.solver            = solver_name();
    line.newton_iterations = newton_report.iterations;
    if (parameters.linear_solver.solver == "gmres")
      {
        line.linear_iterations = newton_report.linear_iterations;
        line.linear_solver     = "GMRES";
      }
    line.contact_nodes = n_contact_nodes;
    if (data.has_exact_solution())
      line.error = error_energy;
    if (final_estimate)
      line.estimate = final_estimate->eta;
    line.seconds = run_record.cycle_seconds();
    return line;
  }


  // On each mesh of the sequence: set up and assemble the contact system,
  // solve it by semismooth Newton from the previous mesh's solution (with
  // the adaptive stopping of the estimators), estimate, measure the error,
  // write, refine.
  template <int dim>
  void
  MembraneProblem<dim>::run()
  {
    run_record.start(prm, description());
    make_grid();
    check_data();
    VI::prepare_output_directory(parameters.output.directory, comm);

    for (unsigned int cycle = 0; cycle < parameters.mesh.cycles; ++cycle)
      {
        run_record.start_cycle();
        if (cycle > 0)
          refine_mesh();
        solve_timer.restart();
        usage_at_solve_start = VI::ProcessUsage::now(comm);
        setup_system();
        assemble_system();
        initialize_iterate();
        print_cycle_header(cycle);

        const std::optional<Vector> initial_iterate =
          parameters.compare_with_petsc_vi ? std::optional<Vector>(solution) :
                                             std::nullopt;
        run_record.guard([&] { solve(); });
        solve_timer.stop();
        solve_usage = VI::ProcessUsage::now(comm) - usage_at_solve_start;

        postprocess();
        compute_errors();
        output_results(cycle);
        run_record.stop_cycle();
        pcout << VI::to_string(cycle_line()) << std::endl;

        petsc_vi_run.reset();
        if (initial_iterate)
          compare_with_petsc_vi(*initial_iterate);
        record_cycle(cycle);
      }

    write_tables();
    run_record.finish(
      "solution_*.pvtu (ParaView), convergence.txt, summary.json");
  }


  template class MembraneProblem<2>;
} // namespace StepMembranes
