// step-membranes, interior penalty dG: the problem, the discrete system
// (interior penalty forms, coupling) and semismooth Newton.

#include "dg_membrane_problem.h"

#include <deal.II/base/utilities.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/estimators.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>
#include <vi/reduced_tension.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace StepMembranes
{
  void
  DGParameters::declare(ParameterHandler &prm)
  {
    prm.enter_subsection("Discretization");
    {
      std::ostringstream default_value;
      default_value << VI::InteriorPenalty::default_penalty_constant;
      prm.declare_entry(
        "Penalty",
        default_value.str(),
        Patterns::Double(),
        "Interior penalty methods (sipg|nipg|iipg) only: the constant C > 0 "
        "of the penalty gamma_F / h_F = C p (p + 1) / h_F on every face "
        "(h_F = min(|K|, |K'|) / |F|). The default 2 keeps SIPG coercive "
        "for every p on rectangles (C (p + 1) / p > 3/2 suffices); NIPG is "
        "stable for every C > 0.");
    }
    prm.leave_subsection();
  }


  void
  DGParameters::parse(ParameterHandler &prm)
  {
    prm.enter_subsection("Discretization");
    penalty = prm.get_double("Penalty");
    prm.leave_subsection();
    if (!(penalty > 0.))
      {
        std::ostringstream message;
        message << "Discretization/Penalty = " << penalty
                << " must be positive";
        throw VI::InputError(message.str());
      }
  }


  template <int dim>
  DGMembraneProblem<dim>::DGMembraneProblem(const Parameters   &parameters,
                                            const DGParameters &dg_parameters,
                                            ParameterHandler   &prm,
                                            const MPI_Comm      comm)
      : StationaryProblem("step-membranes", parameters, prm, comm)
      , parameters(parameters)
      , comm(comm)
      , domain(parameters.mesh, parameters.problem.boundary)
      , data(
          VI::make_membrane_data<dim>(parameters.problem, domain.center<dim>()))
      , C(VI::ComplementarityFunction(parameters.nonlinear_solver.c_function))
      , penalty(VI::InteriorPenalty::from_name(
          VI::to_string(parameters.discretization.method),
          dg_parameters.penalty,
          parameters.discretization.degree))
      , triangulation(comm)
      , geometry_mapping(
          domain.make_mapping<dim>(parameters.discretization.degree))
      , mapping(std::make_unique<MappingQCache<dim>>(
          dynamic_cast<const MappingQ<dim> &>(*geometry_mapping).get_degree()))
      , fe(QGaussLobatto<1>(parameters.discretization.degree + 1))
      , dof_handler(triangulation)
      , quadrature(VI::FluxReconstruction<dim>::quadrature_points(
          parameters.discretization.degree))
      , face_quadrature(VI::FluxReconstruction<dim>::quadrature_points(
          parameters.discretization.degree))
      , contact_system(C, parameters, timer)
      , fe_continuous(parameters.discretization.degree)
      , continuous_dof_handler(triangulation)
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
  {
    check_parameters();
  }


  // What the dG discretisation does not (yet) offer ends as bad input
  // before anything is computed.
  template <int dim>
  void
  DGMembraneProblem<dim>::check_parameters() const
  {
    const std::string method = " is implemented for Method = fem only";
    if (parameters.reference_poisson_solve)
      throw VI::InputError("Benchmark/Reference Poisson solve" + method +
                           "; set it to false with Method = " + penalty.name());
    if (parameters.nonlinear_method !=
        Parameters::NonlinearMethod::semismooth_newton)
      throw VI::InputError(
        "Nonlinear solver/Solver = petsc-vi" + method +
        "; use semismooth-newton with Method = " + penalty.name());
    if (parameters.compare_with_petsc_vi)
      throw VI::InputError("Benchmark/Compare with PETSc VI" + method +
                           "; set it to false with Method = " + penalty.name());
    if (parameters.problem.model == VI::Model::obstacle)
      throw VI::InputError(
        "Problem/Model = obstacle" + method +
        "; use two-membranes with Method = " + penalty.name());
  }


  template <int dim>
  bool
  DGMembraneProblem<dim>::uses_contact_amg() const
  {
    return parameters.linear_solver.solver == VI::LinearSolverType::gmres &&
           parameters.linear_solver.preconditioner ==
             VI::PreconditionerType::amg;
  }


  // The data must be finite and admit a solution: g1 >= g2 on the boundary.
  // Checked on the first mesh (forces at the quadrature points, boundary data
  // at the boundary nodes) before anything is written.
  template <int dim>
  void
  DGMembraneProblem<dim>::check_data() const
  {
    VI::check_membrane_data(
      data, triangulation, domain, *mapping, fe, quadrature);
  }


  template <int dim>
  void
  DGMembraneProblem<dim>::make_grid()
  {
    domain.make_coarse_mesh(triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
    mapping->initialize(*geometry_mapping, triangulation);
  }


  // Every node of every cell is an unknown (no strong Dirichlet data; a
  // hanging node constrains nothing in the broken space) and carries a
  // contact pair.
  // The matrix couples the nodes of neighbouring cells (flux sparsity).
  template <int dim>
  void
  DGMembraneProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");
    mapping->initialize(*geometry_mapping, triangulation);

    dof_handler.distribute_dofs(fe);
    owned_nodes = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_nodes);
    owned_system    = VI::NodalFields::system_index_set(owned_nodes);
    relevant_system = VI::NodalFields::system_index_set(relevant_nodes);

    AffineConstraints<double> no_constraints;
    no_constraints.close();
    contact_system.reinit(owned_nodes, no_constraints, comm);

    DynamicSparsityPattern scalar_pattern(relevant_nodes);
    DoFTools::make_flux_sparsity_pattern(dof_handler, scalar_pattern);
    contact_system.reinit_matrix(scalar_pattern, relevant_nodes);
    if (uses_contact_amg())
      stiffness_matrix.reinit(owned_nodes, owned_nodes, scalar_pattern, comm);
    solution.reinit(owned_system, comm);
    for (auto *field : {&u1_h, &u2_h, &gap_h, &lambda_h, &contact_set})
      field->reinit(owned_nodes, relevant_nodes, comm);
    ghosted_nodes.reinit(owned_nodes, relevant_nodes, comm);

    if (parameters.estimators.enabled)
      {
        continuous_dof_handler.distribute_dofs(fe_continuous);
        owned_continuous = continuous_dof_handler.locally_owned_dofs();
        DoFTools::extract_locally_relevant_dofs(continuous_dof_handler,
                                                relevant_continuous);
        continuous_hanging_nodes.clear();
        continuous_hanging_nodes.reinit(relevant_continuous);
        DoFTools::make_hanging_node_constraints(continuous_dof_handler,
                                                continuous_hanging_nodes);
        continuous_hanging_nodes.close();
        // (on the rule of the dG problem, which keeps p + 3 points with
        // either flux degree: its face and lifting terms are not in the
        // count of FluxReconstruction::quadrature_points for k = p - 1)
        flux_reconstruction = std::make_unique<VI::FluxReconstruction<dim>>(
          *mapping,
          parameters.estimators.flux_degree_for(fe.degree),
          fe.degree,
          VI::FluxReconstruction<dim>::quadrature_points(fe.degree));
        flux_reconstruction->reinit(continuous_dof_handler,
                                    domain.free_boundary_ids());
        lifting = std::make_unique<VI::JumpLifting<dim>>(*mapping,
                                                         fe.degree,
                                                         quadrature,
                                                         face_quadrature);
        lifting->reinit(triangulation);
      }
  }


  namespace
  {
    // One cell's contribution (with its boundary faces) and those of its
    // interior faces: the dG stiffness without the tensions, and the load
    // (f_alpha, v) + mu_alpha G_h,alpha(v) of both membranes.
    struct FaceCopyData
    {
      FullMatrix<double>                   matrix;
      std::vector<types::global_dof_index> dofs;
    };

    struct CellCopyData
    {
      FullMatrix<double>                   matrix;
      dealii::Vector<double>               rhs[2];
      dealii::Vector<double>               lumped_mass; ///< (psi_I, 1)_K
      std::vector<types::global_dof_index> dofs;
      std::vector<FaceCopyData>            faces;
    };
  } // namespace


  // The interior penalty forms of VI::InteriorPenalty, assembled by
  // mesh_loop: cells, boundary faces (weak Dirichlet data) and interior
  // faces, on the subfaces at refinement edges (the faces of the finer
  // cells). Faces between two owned cells are visited once; faces with a
  // ghost neighbour by both processes, each adding the rows it owns (the
  // rows of its own cell's nodes). Then the coupling D = I and the scales
  // of the residuals and of the constraint rows.
  template <int dim>
  void
  DGMembraneProblem<dim>::assemble_system()
  {
    TimerOutput::Scope t(timer, "assembly");
    contact_system.matrix = 0;
    contact_system.rhs    = 0;
    const bool with_amg   = uses_contact_amg();
    if (with_amg)
      stiffness_matrix = 0;

    const double         mu[2]    = {data.mu1, data.mu2};
    const Function<dim> *g[2]     = {data.g1.get(), data.g2.get()};
    const Function<dim> *force[2] = {data.f1.get(), data.f2.get()};
    using Iterator = typename DoFHandler<dim>::active_cell_iterator;

    const UpdateFlags flags = update_values | update_gradients |
                              update_quadrature_points | update_JxW_values;
    MeshWorker::ScratchData<dim> scratch(*mapping,
                                         fe,
                                         quadrature,
                                         flags,
                                         face_quadrature,
                                         flags | update_normal_vectors);
    CellCopyData                 copy;
    const unsigned int           n = fe.n_dofs_per_cell();

    const auto cell_worker =
      [&](const Iterator &cell, MeshWorker::ScratchData<dim> &s, auto &c) {
        const FEValues<dim> &values = s.reinit(cell);
        c.matrix.reinit(n, n);
        for (auto &v : c.rhs)
          v.reinit(n);
        c.lumped_mass.reinit(n);
        for (const unsigned int q : values.quadrature_point_indices())
          for (unsigned int i = 0; i < n; ++i)
            c.lumped_mass(i) += values.shape_value(i, q) * values.JxW(q);
        c.dofs.resize(n);
        c.faces.clear();
        cell->get_dof_indices(c.dofs);
        std::vector<double> f(values.n_quadrature_points);
        for (unsigned int a = 0; a < 2; ++a)
          {
            force[a]->value_list(values.get_quadrature_points(), f);
            for (const unsigned int q : values.quadrature_point_indices())
              for (unsigned int i = 0; i < n; ++i)
                c.rhs[a](i) += f[q] * values.shape_value(i, q) * values.JxW(q);
          }
        VI::InteriorPenalty::add_cell_matrix(values, c.matrix);
      };

    // - (grad u.n, v) + epsilon (grad v.n, u) + gamma / h (u, v) on the
    // clamped boundary, and the data epsilon (grad v.n, g) + gamma / h (g,
    // v); nothing where the membranes are free (zero normal derivative).
    const auto boundary_worker = [&](const Iterator               &cell,
                                     const unsigned int            face,
                                     MeshWorker::ScratchData<dim> &s,
                                     auto                         &c) {
      if (!domain.is_clamped(cell->face(face)->boundary_id()))
        return;
      const FEFaceValuesBase<dim> &values = s.reinit(cell, face);
      const double h_F = VI::InteriorPenalty::normal_extent<dim>(cell, face);
      penalty.add_boundary_matrix(values, h_F, c.matrix);
      std::vector<double> data_values(values.n_quadrature_points);
      for (unsigned int a = 0; a < 2; ++a)
        {
          g[a]->value_list(values.get_quadrature_points(), data_values);
          for (double &value : data_values)
            value *= mu[a];
          penalty.add_boundary_rhs(values, h_F, data_values, c.rhs[a]);
        }
    };

    // - ({grad u}.n, [v]) + epsilon ({grad v}.n, [u]) + gamma / h ([u], [v]).
    const auto face_worker = [&](const Iterator               &cell,
                                 const unsigned int            face,
                                 const unsigned int            subface,
                                 const Iterator               &neighbor,
                                 const unsigned int            neighbor_face,
                                 const unsigned int            neighbor_subface,
                                 MeshWorker::ScratchData<dim> &s,
                                 auto                         &c) {
      const FEInterfaceValues<dim> &values = s.reinit(
        cell, face, subface, neighbor, neighbor_face, neighbor_subface);
      c.faces.emplace_back();
      FaceCopyData &face_data = c.faces.back();
      face_data.dofs          = values.get_interface_dof_indices();
      face_data.matrix.reinit(face_data.dofs.size(), face_data.dofs.size());
      penalty.add_face_matrix(values,
                              VI::InteriorPenalty::normal_extent<dim>(cell,
                                                                      face,
                                                                      subface),
                              face_data.matrix);
    };

    Vector coupling(owned_nodes, comm);
    lumped_mass.reinit(owned_nodes, comm);
    const auto copier = [&](const CellCopyData &c) {
      add_local_matrix(c.matrix, c.dofs);
      for (unsigned int i = 0; i < c.dofs.size(); ++i)
        {
          lumped_mass(c.dofs[i]) = c.lumped_mass(i);
          coupling(c.dofs[i])    = mass_lumped() ? c.lumped_mass(i) : 1.;
        }
      for (unsigned int a = 0; a < 2; ++a)
        for (unsigned int i = 0; i < c.dofs.size(); ++i)
          contact_system.rhs(index(c.dofs[i], a)) += c.rhs[a](i);
      for (const FaceCopyData &face : c.faces)
        add_local_matrix(face.matrix, face.dofs);
    };

    // (over the ghost cells too: a face between an owned cell and the
    // finer ghost cells beside it is only visited from the fine side)
    MeshWorker::mesh_loop(dof_handler.active_cell_iterators(),
                          cell_worker,
                          copier,
                          scratch,
                          copy,
                          MeshWorker::assemble_own_cells |
                            MeshWorker::assemble_boundary_faces |
                            MeshWorker::assemble_own_interior_faces_once |
                            MeshWorker::assemble_ghost_faces_both,
                          boundary_worker,
                          face_worker);
    contact_system.matrix.compress(VectorOperation::add);
    contact_system.rhs.compress(VectorOperation::add);
    if (with_amg)
      stiffness_matrix.compress(VectorOperation::add);
    coupling.compress(VectorOperation::insert);
    lumped_mass.compress(VectorOperation::insert);

    set_coupling_and_preconditioner(coupling);
  }


  // The local matrix of a_h on a cell or a face into the rows of the
  // locally owned nodes: mu_alpha a_h into the block of membrane alpha, and
  // a_h itself into the matrix of the contact AMG if it is used.
  template <int dim>
  void
  DGMembraneProblem<dim>::add_local_matrix(
    const FullMatrix<double>                   &local,
    const std::vector<types::global_dof_index> &dofs)
  {
    const double                         mu[2] = {data.mu1, data.mu2};
    const unsigned int                   n     = dofs.size();
    std::vector<types::global_dof_index> columns(n);
    std::vector<double>                  row(n), scaled(n);
    for (unsigned int i = 0; i < n; ++i)
      if (owned_nodes.is_element(dofs[i]))
        {
          for (unsigned int j = 0; j < n; ++j)
            row[j] = local(i, j);
          if (uses_contact_amg())
            stiffness_matrix.add(dofs[i], n, dofs.data(), row.data());
          for (const unsigned int field :
               {VI::NodalFields::u1, VI::NodalFields::u2})
            {
              for (unsigned int j = 0; j < n; ++j)
                {
                  columns[j] = index(dofs[j], field);
                  scaled[j]  = mu[field] * row[j];
                }
              contact_system.matrix.add(index(dofs[i], field),
                                        n,
                                        columns.data(),
                                        scaled.data());
            }
        }
  }


  // The coupling D, the weights of the constraint rows and, with GMRES +
  // AMG, the contact preconditioner, once A, F and `coupling` (D per node)
  // are assembled.
  template <int dim>
  void
  DGMembraneProblem<dim>::set_coupling_and_preconditioner(
    const Vector &coupling)
  {
    // The coupling: -<lambda_h, v1>_h + <lambda_h, v2>_h with the dual basis
    // is -D_I X3_I, +D_I X3_I in the rows of node I: D = I for the L2
    // bracket, the lumped masses (psi_I, 1)_K for p = 1.
    contact_system.set_coupling(
      [&](const types::global_dof_index i) { return coupling(i); }, {});

    // The continuation's gap stiffness; the multiplier of the L2 bracket
    // is a force, (psi_I, 1)_K per unit density.
    const double mu_r = VI::reduced_tension(data.mu1, data.mu2);
    contact_system.set_gap_stiffness(VI::ContactRows::gap_stiffness(
      mu_r,
      domain.friedrichs_constant(),
      mass_lumped() ? 1. : lumped_mass.linfty_norm()));

    // Row weights in force units: mu_r S_ii for rows that enforce u1 = u2.
    std::vector<double> stiffness_weight(owned_nodes.n_elements());
    for (std::size_t k = 0; k < owned_nodes.n_elements(); ++k)
      {
        const auto i = owned_nodes.nth_index_in_set(k);
        stiffness_weight[k] =
          mu_r *
          contact_system.matrix.diag_element(index(i, VI::NodalFields::u1)) /
          data.mu1;
      }
    contact_system.set_stiffness_weights(std::move(stiffness_weight));

    // The contact AMG of step-membranes on a_h: the same decoupling into
    // the mean and the gap holds, since both blocks are multiples of a_h.
    if (uses_contact_amg())
      contact_system.use_contact_preconditioner(stiffness_matrix,
                                                data.mu1,
                                                data.mu2,
                                                fe.degree > 1);
  }


  // The iterate on a new mesh: the previous solution carried over as broken
  // functions (nested iteration; the dual coefficients X3 are recomputed as
  // moments on the new cells), or zero (or the data g) with zero multiplier.
  template <int dim>
  void
  DGMembraneProblem<dim>::initialize_iterate()
  {
    const bool from_data =
      parameters.nonlinear_solver.initial_guess == VI::InitialGuess::data;
    // X3: the nodal values of lambda_h (p = 1), its moments (p >= 2).
    const auto dual_coefficients = [this](const Vector &lambda, Vector &X3) {
      if (mass_lumped())
        X3 = lambda;
      else
        {
          Vector ghosted;
          ghosted_nodes.copy(lambda, ghosted);
          moments_of_function(ghosted, X3);
        }
    };
    VI::initial_nodal_iterate(solution_transfer,
                              dual_coefficients,
                              *mapping,
                              dof_handler,
                              from_data ? data.g1.get() : nullptr,
                              from_data ? data.g2.get() : nullptr,
                              solution);
  }


  // Semismooth Newton on E X = F, C(X) = 0: the solver of the conforming
  // method, with the dG matrix; then the estimate of the solution.
  template <int dim>
  void
  DGMembraneProblem<dim>::solve()
  {
    stopping.start_solve({double(dof_handler.n_dofs()), dim, fe.degree});
    final_estimate.reset();
    VI::SemismoothNewton<Vector> newton =
      contact_system.make_newton(parameters.output.verbose ? &pcout : nullptr);
    const auto &estimators = parameters.estimators;
    // The adaptive strategy (and Estimators/At every check) estimates the
    // GMRES iterates every nu iterations and the Newton iterates, as the
    // conforming program does (see VI::AdaptiveStopping).
    if (estimators.enabled && (stopping.adaptive() || estimators.every_check))
      {
        newton.setup_jacobian = [&](const Vector &X) {
          stopping.start_step(X);
          contact_system.setup_jacobian(X);
        };
        newton.solve_with_jacobian = [&](const Vector &rhs, Vector &dX) {
          return stopping.solve_watched(contact_system, rhs, dX);
        };
        stopping.attach_criteria(newton);
      }
    newton_report  = newton.solve(solution);
    final_estimate = std::move(stopping.final_estimate);
    if (estimators.enabled && !final_estimate)
      final_estimate = estimate(solution);
  }


  template <int dim>
  typename VI::AdaptiveStopping<typename DGMembraneProblem<dim>::Iterate,
                                VI::DGContactEstimate>::Hooks
  DGMembraneProblem<dim>::stopping_hooks()
  {
    typename VI::AdaptiveStopping<Iterate, VI::DGContactEstimate>::Hooks hooks;
    hooks.describe = [](const Vector &X, Iterate &it) { it.X = X; };
    hooks.estimate = [this](const Iterate &it, const Iterate &) {
      return estimate(it.X);
    };
    hooks.estimate_iterate = [this](const Vector &X) { return estimate(X); };
    hooks.components       = [](const VI::DGContactEstimate &e) {
      return VI::StoppingComponents{
        true, e.eta, e.eta_disc, e.eta_lin, e.eta_alg, e.eta_lin};
    };
    hooks.look_ahead = false;
    return hooks;
  }


  template <int dim>
  std::string
  DGMembraneProblem<dim>::description() const
  {
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << domain.name() << ", "
         << penalty.label() << " Q" << fe.degree << " (penalty "
         << penalty.penalty_constant() << " p (p + 1) / h_F), Newton-"
         << C.name() << " "
         << VI::describe_solvers(parameters.nonlinear_solver,
                                 parameters.linear_solver)
         << (parameters.estimators.enabled ? ", estimators on" : "");
    return line.str();
  }


  template <int dim>
  VI::CycleNumbers
  DGMembraneProblem<dim>::cycle_numbers(const unsigned int cycle) const
  {
    VI::CycleNumbers numbers =
      measured(cycle,
               triangulation.n_global_active_cells(),
               dof_handler.n_dofs(),
               "Newton-" + C.name(),
               VI::counted_linear_solver(parameters.linear_solver));
    if (final_estimate)
      numbers.estimate = final_estimate->eta;
    return numbers;
  }


  // The members defined in this file (the others are instantiated where
  // they are defined).
  template class DGMembraneProblem<2>;
} // namespace StepMembranes
