#include <deal.II/base/utilities.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/reduced_tension.h>

#include "hho_problem.h"
#include "jacobian_solver.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

namespace StepHHO
{
  namespace
  {
    // What the cell workers of the residual, the condensed right-hand side
    // and the recovery fill: one vector on a cell's unknowns.
    using CellVectorCopy = MeshWorker::CopyData<0, 1, 1>;

    // Runs `cell_worker` on the locally owned cells and puts each cell's
    // vector into `target` at the cell's unknowns: added through the
    // constraints of the face unknowns (a residual, a condensed right-hand
    // side: the rows of the clamped faces are dropped, those of a coarse
    // face between refinement levels go to the rows of its halves), or
    // inserted (unknowns recovered cell by cell, each owned by one cell).
    template <int dim, typename CellWorker, typename Scratch>
    void
    gather_cell_vectors(const DoFHandler<dim>           &cells,
                        const CellWorker                &cell_worker,
                        const Scratch                   &scratch,
                        const AffineConstraints<double> *constraints,
                        TrilinosWrappers::MPI::Vector   &target)
    {
      const auto copier = [&](const CellVectorCopy &copy) {
        if (constraints)
          constraints->distribute_local_to_global(copy.vectors[0],
                                                  copy.local_dof_indices[0],
                                                  target);
        else
          target.set(copy.local_dof_indices[0], copy.vectors[0]);
      };
      MeshWorker::mesh_loop(cells.active_cell_iterators() |
                              IteratorFilters::LocallyOwnedCell(),
                            cell_worker,
                            copier,
                            scratch,
                            CellVectorCopy(0),
                            MeshWorker::assemble_own_cells);
      target.compress(constraints ? VectorOperation::add :
                                    VectorOperation::insert);
    }
  } // namespace

  void
  JacobianSolver::initialize(const TrilinosWrappers::SparseMatrix &A)
  {
    if (parameters.solver == VI::LinearSolverType::direct)
      direct.initialize(A);
    else if (parameters.preconditioner == VI::PreconditionerType::amg)
      {
        TrilinosWrappers::PreconditionAMG::AdditionalData settings;
        settings.elliptic              = true;
        settings.higher_order_elements = higher_order;
        settings.constant_modes        = constant_modes;
        auto amg = std::make_unique<TrilinosWrappers::PreconditionAMG>();
        amg->initialize(A, settings);
        preconditioner = std::move(amg);
      }
    else
      {
        TrilinosWrappers::PreconditionILU::AdditionalData settings(
          parameters.ilu_fill);
        auto ilu = std::make_unique<TrilinosWrappers::PreconditionILU>();
        ilu->initialize(A, settings);
        preconditioner = std::move(ilu);
      }
  }


  unsigned int
  JacobianSolver::solve(const TrilinosWrappers::SparseMatrix &A,
                        TrilinosWrappers::MPI::Vector        &x,
                        const TrilinosWrappers::MPI::Vector  &b,
                        const double                          tolerance,
                        const CGWatch                        &watch)
  {
    if (parameters.solver == VI::LinearSolverType::direct)
      return direct.solve(b, x);

    SolverControl                           control(parameters.max_iterations,
                          tolerance,
                          /*log_history=*/false,
                          /*log_result=*/false);
    SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
    // deal.II's CG stops with success only when every slot says so; the
    // watch stops it by a failure that is then not one.
    std::optional<unsigned int> stopped_at;
    if (watch.stop)
      cg.connect([&](const unsigned int i,
                     const double,
                     const TrilinosWrappers::MPI::Vector &iterate) {
        if (i % watch.interval != 0 || !watch.stop(iterate))
          return SolverControl::success;
        stopped_at = i;
        return SolverControl::failure;
      });
    x = 0;
    try
      {
        cg.solve(A, x, b, *preconditioner);
      }
    catch (const SolverControl::NoConvergence &failure)
      {
        if (stopped_at)
          return *stopped_at;
        std::ostringstream message;
        message << "CG on the condensed system: no convergence in "
                << failure.last_step << " iterations (residual "
                << failure.last_residual << ", tolerance " << tolerance << ")";
        throw VI::SolverFailure(message.str());
      }
    return control.last_step();
  }


  namespace
  {
    /// The local vectors of the cell loops that only do dense linear
    /// algebra: one set per thread, reused from cell to cell.
    struct CellVectors
    {
      Vector<double> x, y, b, v, Av, Ga, Gb, r_L, dy;
    };
  } // namespace


  // ------------------------------------------------------------------------
  // Semismooth Newton.

  // The rows of the balance equations, E X - F: cell rows of u1 and u2,
  // and the face rows of the interior faces (the rows of the boundary faces
  // and of the complementarity are left 0). Cell by cell with the local HHO
  // matrices; the face rows collect the contributions of both neighbours.
  template <int dim>
  void
  HHOProblem<dim>::equation_residual(const TrilinosWrappers::MPI::Vector &X,
                                     TrilinosWrappers::MPI::Vector &R) const
  {
    ghosted_system.copy(X, ghosted_iterate);
    R                        = 0;
    const unsigned int n_c   = cell_fe.n_dofs_per_cell();
    const unsigned int n_f   = face_fe.n_dofs_per_cell();
    const double       mu[2] = {data.mu1, data.mu2};

    using CopyData = CellVectorCopy;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const StaticCondensation::CellOperators &operators =
          local_matrices_of(cell).operators;
        const auto      unknowns      = local_unknowns(cell);
        const auto      face_unknowns = unknowns.begin() + n_fields * n_c;
        Vector<double> &x = scratch.x, &y = scratch.y, &b = scratch.b;
        x.reinit(n_fields * n_c, true);
        y.reinit(2 * n_f, true);
        b.reinit(2 * n_c, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          x(i) = ghosted_iterate(unknowns[i]);
        for (unsigned int k = 0; k < 2 * n_f; ++k)
          y(k) = ghosted_iterate(face_unknowns[k]);
        for (unsigned int i = 0; i < 2 * n_c; ++i)
          b(i) = load(unknowns[i]);

        // Rows: cells of u1, u2 (2 n_c), faces of y1, y2 (2 n_f).
        copy.vectors[0].reinit(2 * n_c + 2 * n_f);
        copy.local_dof_indices[0].assign(unknowns.begin(),
                                         unknowns.begin() + 2 * n_c);
        copy.local_dof_indices[0].insert(copy.local_dof_indices[0].end(),
                                         face_unknowns,
                                         unknowns.end());
        Vector<double> &v = scratch.v, &Av = scratch.Av;
        v.reinit(n_c + n_f, true);
        Av.reinit(n_c + n_f, true);
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          {
            for (unsigned int I = 0; I < n_c; ++I)
              v(I) = x(alpha * n_c + I);
            for (unsigned int k = 0; k < n_f; ++k)
              v(n_c + k) = y(alpha * n_f + k);
            operators.A.vmult(Av, v);
            const double sign = alpha == 0 ? -1. : 1.;
            for (unsigned int I = 0; I < n_c; ++I)
              copy.vectors[0](alpha * n_c + I) =
                mu[alpha] * Av(I) + sign * x(2 * n_c + I) - b(alpha * n_c + I);
            for (unsigned int k = 0; k < n_f; ++k)
              copy.vectors[0](2 * n_c + alpha * n_f + k) =
                mu[alpha] * Av(n_c + k);
          }
      };
    // (no equation in the rows of the fixed boundary face values)
    gather_cell_vectors(
      cell_dof_handler, cell_worker, CellVectors(), &system_constraints, R);
  }


  // R(X) = [E X - F ; C(X)] and its two dimensionless norms.
  template <int dim>
  VI::ResidualNorms
  HHOProblem<dim>::residual(const TrilinosWrappers::MPI::Vector &X,
                            TrilinosWrappers::MPI::Vector       &R) const
  {
    TimerOutput::Scope t(timer, "residual");
    equation_residual(X, R);
    VI::ResidualNorms norms;
    norms.equations =
      R.l2_norm() / std::max(load_norm, std::numeric_limits<double>::min());
    contact_rows.evaluate(C, X, multiplier_scale, R, norms);
    return norms;
  }


  template <int dim>
  void
  HHOProblem<dim>::setup_jacobian(const TrilinosWrappers::MPI::Vector &X)
  {
    contact_rows.set_linearisation_point(X);
    if (parameters.static_condensation)
      assemble_difference_matrix(X);
    else
      {
        TimerOutput::Scope t(timer, "assembly: jacobian rows");
        contact_rows.set_jacobian_rows(C, X, system_matrix);
        system_matrix.compress(VectorOperation::insert);
      }
    // The factorisation (LU) or the preconditioner (CG) of this Jacobian.
    TimerOutput::Scope t(timer, "solve: setup");
    jacobian_solver->initialize(
      parameters.static_condensation ? difference_matrix : system_matrix);
  }


  // Static condensation of the generalised Jacobian at X: on every cell,
  // eliminate (x1, x2, x3) (static_condensation.h) and add the cell's
  // contribution to the face matrix of the difference of the membranes
  // (that of the mean does not depend on X).
  template <int dim>
  void
  HHOProblem<dim>::assemble_difference_matrix(
    const TrilinosWrappers::MPI::Vector &X)
  {
    TimerOutput::Scope t(timer, "static condensation");
    difference_matrix      = 0;
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();

    using CopyData = MeshWorker::CopyData<1, 0, 1>;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        // The generalised Jacobian (dC/da, dC/db) at the cell's nodes,
        // a = X1_I - X2_I, b = X3_I (all owned by this process).
        const auto      unknowns = local_unknowns(cell);
        Vector<double> &Ga = scratch.Ga, &Gb = scratch.Gb;
        Ga.reinit(n_c, true);
        Gb.reinit(n_c, true);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            const auto g =
              contact_rows.row_gradient(C,
                                        X(unknowns[I]) - X(unknowns[n_c + I]),
                                        X(unknowns[2 * n_c + I]));
            Ga(I) = g[0];
            Gb(I) = g[1];
          }
        const StaticCondensation::CellOperators &operators =
          local_matrices_of(cell).operators;
        StaticCondensation::CellElimination &elimination =
          eliminations[cell->active_cell_index()];
        elimination.reinit(operators, data.mu1, data.mu2, Ga, Gb);
        elimination.difference_matrix(operators, copy.matrices[0]);
        copy.local_dof_indices[0].resize(n_f);
        for (unsigned int k = 0; k < n_f; ++k)
          copy.local_dof_indices[0][k] = face_dof(unknowns[n_fields * n_c + k]);
      };
    const auto copier = [&](const CopyData &copy) {
      face_constraints.distribute_local_to_global(copy.matrices[0],
                                                  copy.local_dof_indices[0],
                                                  difference_matrix);
    };
    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          CellVectors(),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    difference_matrix.compress(VectorOperation::add);
  }


  template <int dim>
  unsigned int
  HHOProblem<dim>::solve_with_jacobian(const TrilinosWrappers::MPI::Vector &rhs,
                                       TrilinosWrappers::MPI::Vector       &dX)
  {
    if (!parameters.static_condensation)
      {
        TimerOutput::Scope t(timer, "solve");
        const unsigned int iterations =
          jacobian_solver->solve(system_matrix, dX, rhs, 0.);
        // (the coarse faces between refinement levels)
        hanging_unknowns.distribute(dX);
        return iterations;
      }
    condense_rhs(rhs);
    const unsigned int iterations = solve_condensed_system();
    recover_cell_unknowns(rhs, dX);
    return iterations;
  }


  // The right-hand sides of the face systems: the face rows of rhs, minus
  // what the cell rows contribute through the eliminated cell unknowns,
  // (b1, b2); then those of the mean, b1 + b2, and of the difference,
  // (mu2 b1 - mu1 b2) / (mu1 + mu2).
  template <int dim>
  void
  HHOProblem<dim>::condense_rhs(const TrilinosWrappers::MPI::Vector &rhs)
  {
    TimerOutput::Scope            t(timer, "static condensation");
    const unsigned int            n_c = cell_fe.n_dofs_per_cell();
    TrilinosWrappers::MPI::Vector condensed(owned_system, comm);
    std::copy(rhs.begin() + n_fields * owned_nodes.n_elements(),
              rhs.end(),
              condensed.begin() + n_fields * owned_nodes.n_elements());

    using CopyData = CellVectorCopy;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const auto      unknowns = local_unknowns(cell);
        Vector<double> &r_L      = scratch.r_L;
        r_L.reinit(n_fields * n_c, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          r_L(i) = rhs(unknowns[i]);
        eliminations[cell->active_cell_index()].condensed_rhs(
          local_matrices_of(cell).operators, r_L, copy.vectors[0]);
        copy.local_dof_indices[0].assign(unknowns.begin() + n_fields * n_c,
                                         unknowns.end());
      };
    gather_cell_vectors(cell_dof_handler,
                        cell_worker,
                        CellVectors(),
                        &system_constraints,
                        condensed);

    const double  m = data.mu1 + data.mu2;
    const double *faces =
      condensed.begin() + n_fields * owned_nodes.n_elements();
    for (std::size_t k = 0; k < owned_faces.n_elements(); ++k)
      {
        const double b1           = faces[2 * k];
        const double b2           = faces[2 * k + 1];
        mean_rhs.begin()[k]       = b1 + b2;
        difference_rhs.begin()[k] = (data.mu2 * b1 - data.mu1 * b2) / m;
      }
  }


  // The two face systems, each by CG to a residual below Linear
  // solver/Tolerance (the forcing term of the inexact strategy) times the
  // norm of the whole right-hand side (so that the mean's system, whose
  // right-hand side vanishes once its equations are solved, costs no
  // iterations in later Newton steps). The adaptive strategy stops them
  // earlier, once eta_alg of the iterate is below algebraic_threshold: half
  // of it for the mean, whose CG runs first, all of it for both. Then the
  // face updates of both membranes, dy1 = ds + mu2 / m dd, dy2 = ds - mu1 / m
  // dd.
  template <int dim>
  unsigned int
  HHOProblem<dim>::solve_condensed_system()
  {
    TimerOutput::Scope t(timer, "solve");
    const double       tolerance =
      VI::linear_tolerance(parameters.nonlinear_solver,
                           parameters.linear_solver) *
      std::sqrt(mean_rhs.norm_sqr() + difference_rhs.norm_sqr());
    // The residuals of the two face systems at their last checked iterates,
    // and their ghosted copies, allocated once for all checks.
    TrilinosWrappers::MPI::Vector mean_residual, difference_residual,
      ghosted_mean_residual, ghosted_difference_residual;
    const auto watch = [&](const TrilinosWrappers::SparseMatrix &A,
                           TrilinosWrappers::MPI::Vector        &residual,
                           const TrilinosWrappers::MPI::Vector  &rhs,
                           const double                          share) {
      if (algebraic_threshold <= 0)
        return CGWatch{};
      residual.reinit(rhs);
      return CGWatch{[&, A = &A, residual = &residual, rhs = &rhs, share](
                       const TrilinosWrappers::MPI::Vector &x) {
                       A->residual(*residual, x, *rhs);
                       ghosted_faces.copy(mean_residual, ghosted_mean_residual);
                       ghosted_faces.copy(difference_residual,
                                          ghosted_difference_residual);
                       return algebraic_estimate(ghosted_mean_residual,
                                                 ghosted_difference_residual) <=
                              share * algebraic_threshold;
                     },
                     parameters.linear_solver.check_interval};
    };
    const CGWatch mean_watch = watch(mean_matrix, mean_residual, mean_rhs, 0.5);
    const CGWatch difference_watch =
      watch(difference_matrix, difference_residual, difference_rhs, 1.);
    unsigned int iterations = mean_solver->solve(
      mean_matrix, mean_update, mean_rhs, tolerance, mean_watch);
    if (algebraic_threshold > 0)
      mean_matrix.residual(mean_residual, mean_update, mean_rhs);
    iterations += jacobian_solver->solve(difference_matrix,
                                         difference_update,
                                         difference_rhs,
                                         tolerance,
                                         difference_watch);
    face_constraints.distribute(mean_update);
    face_constraints.distribute(difference_update);
    ghosted_faces.copy(mean_update, ghosted_mean_update);
    ghosted_faces.copy(difference_update, ghosted_difference_update);
    return iterations;
  }


  // The Newton update: its face part from the mean and the difference, its
  // cell part recovered cell by cell.
  template <int dim>
  void
  HHOProblem<dim>::recover_cell_unknowns(
    const TrilinosWrappers::MPI::Vector &rhs,
    TrilinosWrappers::MPI::Vector       &dX)
  {
    TimerOutput::Scope t(timer, "recovery");
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();
    const double       m   = data.mu1 + data.mu2;
    const double       w1 = data.mu2 / m, w2 = -data.mu1 / m;

    using CopyData = CellVectorCopy;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const auto unknowns = local_unknowns(cell);
        copy.local_dof_indices[0].assign(unknowns.begin(),
                                         unknowns.begin() + n_fields * n_c);
        Vector<double> &r_L = scratch.r_L, &dy = scratch.dy;
        r_L.reinit(n_fields * n_c, true);
        dy.reinit(2 * n_f, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          r_L(i) = rhs(unknowns[i]);
        for (unsigned int k = 0; k < n_f; ++k)
          {
            const types::global_dof_index j =
              face_dof(unknowns[n_fields * n_c + k]);
            const double ds = ghosted_mean_update(j);
            const double dd = ghosted_difference_update(j);
            dy(k)           = ds + w1 * dd;
            dy(n_f + k)     = ds + w2 * dd;
          }
        eliminations[cell->active_cell_index()].recover(
          local_matrices_of(cell).operators, r_L, dy, copy.vectors[0]);
      };
    gather_cell_vectors(
      cell_dof_handler, cell_worker, CellVectors(), nullptr, dX);

    double *faces = dX.begin() + n_fields * owned_nodes.n_elements();
    for (std::size_t k = 0; k < owned_faces.n_elements(); ++k)
      {
        const double ds  = mean_update.begin()[k];
        const double dd  = difference_update.begin()[k];
        faces[2 * k]     = ds + w1 * dd;
        faces[2 * k + 1] = ds + w2 * dd;
      }
  }


  // eta_alg of the iterate whose face rows leave the residuals rho_s of the
  // mean's system and rho_d of the difference's (with ghosts): the rows of
  // the membranes are rho_1 = mu1 / m rho_s + rho_d and rho_2 = mu2 / m rho_s
  // - rho_d, and each cell keeps half the imbalance of each interior face
  // and all of it of a free boundary face, r_K = sum_j w_j rho_j / |K| over
  // its face DoFs j (the face basis sums to 1, hho_estimate.cc; on a face
  // between refinement levels the fine cell keeps all, imbalance_share()).
  // Then
  // eta_alg = C_F (sum_K |K| (r_1,K^2 / mu1 + r_2,K^2 / mu2))^(1/2), the
  // remainder of the estimate, without its fluxes.
  template <int dim>
  double
  HHOProblem<dim>::algebraic_estimate(
    const TrilinosWrappers::MPI::Vector &rho_s,
    const TrilinosWrappers::MPI::Vector &rho_d) const
  {
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const double       m   = data.mu1 + data.mu2;
    double             sum = 0;
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          const auto unknowns = local_unknowns(cell);
          double     sum_s = 0, sum_d = 0;
          for (const unsigned int face : cell->face_indices())
            {
              const double w = imbalance_share(cell, face);
              for (unsigned int k = 0; k < face_fe.n_dofs_per_face(face); ++k)
                {
                  const types::global_dof_index j =
                    face_dof(unknowns[n_fields * n_c +
                                      face_fe.face_to_cell_index(k, face)]);
                  sum_s += w * rho_s(j);
                  sum_d += w * rho_d(j);
                }
            }
          const double area = cell->measure();
          const double r1   = (data.mu1 / m * sum_s + sum_d) / area;
          const double r2   = (data.mu2 / m * sum_s - sum_d) / area;
          sum += area * (r1 * r1 / data.mu1 + r2 * r2 / data.mu2);
        }
    return domain.friedrichs_constant() *
           std::sqrt(Utilities::MPI::sum(sum, comm));
  }


  namespace
  {
    // What the adaptive stopping reads of HHO's estimate: the bound of
    // |||u - u_T|||_h, the error HHO reports (the jumps of the cell
    // polynomials are not in it).
    VI::StoppingComponents
    stopping_components(const VI::DGContactEstimate &e)
    {
      return {true, e.broken, e.broken_disc, e.eta_lin, e.eta_alg, e.eta_lin};
    }
  } // namespace


  // The adaptive strategy's bound for eta_alg in the Newton step from X:
  // gamma_alg max(eta_disc, eta_lin) of the estimate of X, the last Newton
  // iterate. The first step on a mesh has none (an estimate of the start
  // would cost more than the step): gamma_alg times the eta_disc of the last
  // mesh carried to this one at the optimal rate, eta_disc ~ N^(-p/d) in the
  // number of cells N (0 on the first mesh: CG is not stopped).
  template <int dim>
  double
  HHOProblem<dim>::algebraic_tolerance() const
  {
    if (!stopping.final_estimate)
      return parameters.nonlinear_solver.gamma_alg *
             eta_disc_prediction
               .predict(triangulation.n_global_active_cells(), degree, dim)
               .value_or(0.);
    const VI::StoppingComponents c =
      stopping_components(*stopping.final_estimate);
    return parameters.nonlinear_solver.gamma_alg *
           std::max(c.eta_disc, c.eta_lin);
  }


  template <int dim>
  void
  HHOProblem<dim>::solve()
  {
    const auto &p = parameters.nonlinear_solver;
    const typename VI::SemismoothNewton<
      TrilinosWrappers::MPI::Vector>::AdditionalData settings(p, C);

    jacobian_solver = std::make_unique<JacobianSolver>(parameters.linear_solver,
                                                       constant_modes,
                                                       degree > 1);
    if (parameters.static_condensation)
      {
        // The mean's face matrix is the same in every Newton step.
        TimerOutput::Scope t(timer, "solve: setup");
        mean_solver = std::make_unique<JacobianSolver>(parameters.linear_solver,
                                                       constant_modes,
                                                       degree > 1);
        mean_solver->initialize(mean_matrix);
      }

    VI::SemismoothNewton<TrilinosWrappers::MPI::Vector> newton(settings);
    newton.residual = [&](const auto &X, auto &R) { return residual(X, R); };
    newton.setup_jacobian      = [&](const auto &X) { setup_jacobian(X); };
    newton.solve_with_jacobian = [&](const auto &rhs, auto &dX) {
      return solve_with_jacobian(rhs, dX);
    };
    newton.active_set = [&](const auto &X, const bool first) {
      return contact_rows.linearised_active_set(C, X, active_rows, !first);
    };
    // The continuation's gap stiffness mu_r lambda_1 is a density; the cell
    // unknowns X3_I are forces, of which a cell of measure |K| holds about
    // |K| / n_c each.
    double largest_cell = 0;
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned())
        largest_cell = std::max(largest_cell, cell->measure());
    const double gap_stiffness =
      VI::ContactRows::gap_stiffness(VI::reduced_tension(data.mu1, data.mu2),
                                     domain.friedrichs_constant(),
                                     Utilities::MPI::max(largest_cell, comm) /
                                       cell_fe.n_dofs_per_cell());
    contact_rows.attach_continuation(newton, gap_stiffness);
    if (parameters.output.verbose)
      newton.monitor = [&](const VI::NewtonStep &step) {
        pcout << "      k = " << std::setw(2) << step.iteration << ": "
              << VI::describe(step, "CG") << std::endl;
      };
    // The adaptive strategy [DMV20]: CG stops once eta_alg <= gamma_alg
    // max(eta_disc, eta_lin), Newton once eta_lin <= gamma_lin eta_disc.
    // The estimate of an iterate holds whether its face rows are solved or
    // not (hho_estimate.cc), so each test reads a guaranteed bound. eta_alg
    // is cheap (the face residual) and is evaluated at every check of CG;
    // eta_disc and eta_lin there are those of the iterate the step starts
    // from.
    stopping.start_solve();
    if (stopping.adaptive())
      {
        newton.setup_jacobian = [&](const auto &X) {
          stopping.start_step(X);
          algebraic_threshold = algebraic_tolerance();
          setup_jacobian(X);
        };
        stopping.attach_criteria(newton);
      }

    newton_report       = newton.solve(solution);
    algebraic_threshold = 0;
    if (stopping.final_estimate)
      eta_disc_prediction.remember(
        stopping_components(*stopping.final_estimate).eta_disc,
        triangulation.n_global_active_cells());
    mean_solver.reset();
    jacobian_solver.reset();
  }


  // What the adaptive stopping sees of this program: the estimate of a
  // Newton iterate, which is `solution` (SemismoothNewton works on it).
  // CG's checks are made by solve_condensed_system() with eta_alg alone, so
  // the hooks of the GMRES checks are never called.
  template <int dim>
  typename VI::AdaptiveStopping<typename HHOProblem<dim>::Iterate,
                                VI::DGContactEstimate>::Hooks
  HHOProblem<dim>::stopping_hooks()
  {
    typename VI::AdaptiveStopping<Iterate, VI::DGContactEstimate>::Hooks hooks;
    hooks.estimate_iterate = [this](const TrilinosWrappers::MPI::Vector &) {
      cell_fields();
      return estimate();
    };
    hooks.components = stopping_components;
    hooks.look_ahead = false;
    return hooks;
  }


  template void
  HHOProblem<2>::equation_residual(const TrilinosWrappers::MPI::Vector &,
                                   TrilinosWrappers::MPI::Vector &) const;
  template VI::ResidualNorms
  HHOProblem<2>::residual(const TrilinosWrappers::MPI::Vector &,
                          TrilinosWrappers::MPI::Vector &) const;
  template void
  HHOProblem<2>::setup_jacobian(const TrilinosWrappers::MPI::Vector &);
  template void
  HHOProblem<2>::assemble_difference_matrix(
    const TrilinosWrappers::MPI::Vector &);
  template unsigned int
  HHOProblem<2>::solve_with_jacobian(const TrilinosWrappers::MPI::Vector &,
                                     TrilinosWrappers::MPI::Vector &);
  template void
  HHOProblem<2>::condense_rhs(const TrilinosWrappers::MPI::Vector &);
  template unsigned int
  HHOProblem<2>::solve_condensed_system();
  template void
  HHOProblem<2>::recover_cell_unknowns(const TrilinosWrappers::MPI::Vector &,
                                       TrilinosWrappers::MPI::Vector &);
  template double
  HHOProblem<2>::algebraic_estimate(
    const TrilinosWrappers::MPI::Vector &,
    const TrilinosWrappers::MPI::Vector &) const;
  template double
  HHOProblem<2>::algebraic_tolerance() const;
  template void
  HHOProblem<2>::solve();
  template typename VI::AdaptiveStopping<typename HHOProblem<2>::Iterate,
                                         VI::DGContactEstimate>::Hooks
  HHOProblem<2>::stopping_hooks();
} // namespace StepHHO
