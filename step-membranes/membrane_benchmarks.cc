// step-membranes, conforming Q_p: the benchmarks beside a solve, the PETSc
// SNES VI peer and the reference Poisson solves.

#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/trilinos_index_access.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>
#include <vi/petsc_vi.h>

#include "membrane_problem.h"
#include "reference_poisson.h"

#include <algorithm>
#include <cmath>

namespace StepMembranes
{
  namespace
  {
    // PETSc's SNES VI on K y = b, y >= 0 on `bounded`, with our settings (the
    // type, the linear solver and the tolerances of the parameter file) and,
    // when verbose, a line per step. b and y are given by their `owned`
    // entries `indices`; y_values gets the solution there.
    VI::PetscVIReport
    run_petsc_vi(const Parameters                           &parameters,
                 const ConditionalOStream                   &pcout,
                 const PETScWrappers::MPI::SparseMatrix     &K,
                 const IndexSet                             &owned,
                 const std::vector<types::global_dof_index> &indices,
                 const std::vector<double>                  &b_values,
                 std::vector<double>                        &y_values,
                 const IndexSet                             &bounded)
    {
      const MPI_Comm             comm = K.get_mpi_communicator();
      PETScWrappers::MPI::Vector b(owned, comm), y(owned, comm);
      b.set(indices, b_values);
      y.set(indices, y_values);
      b.compress(VectorOperation::insert);
      y.compress(VectorOperation::insert);
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
      y.extract_subvector_to(indices, y_values);
      return report;
    }
  } // namespace


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
    if (this->obstacle)
      return solve_obstacle_with_petsc_vi(X, reason);
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
    IndexSet bounded(owned_pairs.size());
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      bounded.add_index(pair(i, 1));

    const VI::PetscVIReport report = run_petsc_vi(
      parameters, pcout, K, owned_pairs, indices, b_values, y_values, bounded);
    reason = report.reason;

    // Back to X = (v + w, v, X3), then the multiplier.
    for (std::size_t k = 0; k < indices.size() / 2; ++k)
      {
        const types::global_dof_index i = indices[2 * k] / 2;
        X(index(i, u1)) = U * (y_values[2 * k] + theta2 * y_values[2 * k + 1]);
        X(index(i, u2)) = U * (y_values[2 * k] - theta1 * y_values[2 * k + 1]);
        X(index(i, multiplier)) = 0.;
      }
    X.compress(VectorOperation::insert);
    return recover_multiplier(X, report.iterations, report.linear_iterations);
  }


  // The peer over an obstacle: the one variable y = u1 - u2 of each node
  // (u2 = I_h psi is fixed), y >= 0 at the contact nodes, with K = the rows
  // and columns of u1 in E (mu1 S) and b = F1 - K u2: the reduced systems
  // are mu1 S on the inactive nodes. The multiplier comes back as for two
  // membranes.
  template <int dim>
  VI::NewtonReport
  MembraneProblem<dim>::solve_obstacle_with_petsc_vi(Vector      &X,
                                                     std::string &reason) const
  {
    using VI::NodalFields::u1;
    using VI::NodalFields::u2;
    const Epetra_CrsMatrix &E = contact_system.matrix.trilinos_matrix();
    DynamicSparsityPattern  pattern(dof_handler.n_dofs(),
                                   dof_handler.n_dofs(),
                                   owned_nodes);
    std::vector<std::vector<std::pair<types::global_dof_index, double>>> rows;
    for (const types::global_dof_index i : owned_nodes)
      {
        const int row =
          E.LRID(static_cast<TrilinosWrappers::types::int_type>(index(i, u1)));
        int     n_entries = 0;
        double *values    = nullptr;
        int    *columns   = nullptr;
        E.ExtractMyRowView(row, n_entries, values, columns);
        rows.emplace_back();
        for (int k = 0; k < n_entries; ++k)
          {
            const auto column =
              TrilinosWrappers::global_column_index(E, columns[k]);
            if (column % n_fields == u1)
              {
                rows.back().emplace_back(column / n_fields, values[k]);
                pattern.add(i, column / n_fields);
              }
          }
      }
    PETScWrappers::MPI::SparseMatrix K;
    K.reinit(owned_nodes, owned_nodes, pattern, comm);
    // b = F1 - K u2, with u2 from the ghosted iterate; scaled by U as above.
    Vector ghosted;
    ghosted.reinit(owned_system, relevant_system, comm);
    ghosted  = X;
    double U = 0;
    for (const types::global_dof_index i : owned_nodes)
      U = std::max(U, std::abs(X(index(i, u1))));
    U = Utilities::MPI::max(U, comm);
    if (!(U > 0) || !std::isfinite(U))
      U = 1.;
    std::vector<types::global_dof_index> indices(owned_nodes.begin(),
                                                 owned_nodes.end());
    std::vector<double>                  b_values, y_values;
    for (std::size_t n = 0; n < indices.size(); ++n)
      {
        const types::global_dof_index i   = indices[n];
        double                        Ku2 = 0;
        for (const auto &[j, value] : rows[n])
          {
            K.set(i, j, value);
            Ku2 += value * ghosted(index(j, u2));
          }
        b_values.push_back((contact_system.rhs(index(i, u1)) - Ku2) / U);
        y_values.push_back((X(index(i, u1)) - X(index(i, u2))) / U);
      }
    K.compress(VectorOperation::insert);
    IndexSet bounded(dof_handler.n_dofs());
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      bounded.add_index(i);

    const VI::PetscVIReport report = run_petsc_vi(
      parameters, pcout, K, owned_nodes, indices, b_values, y_values, bounded);
    reason = report.reason;

    for (std::size_t n = 0; n < indices.size(); ++n)
      {
        const types::global_dof_index i = indices[n];
        X(index(i, u1))                 = U * y_values[n] + X(index(i, u2));
        X(index(i, multiplier))         = 0.;
      }
    X.compress(VectorOperation::insert);
    return recover_multiplier(X, report.iterations, report.linear_iterations);
  }


  // After the peer: X conforming at hanging nodes, the multiplier from the
  // balance rows of u1 (E's multiplier column is -D), and the residuals.
  template <int dim>
  VI::NewtonReport
  MembraneProblem<dim>::recover_multiplier(
    Vector            &X,
    const unsigned int iterations,
    const unsigned int linear_iterations) const
  {
    using VI::NodalFields::u1;
    system_hanging_constraints.distribute(X);
    Vector R(owned_system, comm);
    contact_system.matrix.vmult(R, X);
    R -= contact_system.rhs;
    for (const types::global_dof_index i :
         contact_system.contact_rows().nodes())
      X(index(i, multiplier)) = R(index(i, u1)) / contact_system.coupling()(i);
    X.compress(VectorOperation::insert);

    VI::NewtonReport newton;
    newton.iterations        = iterations;
    newton.linear_iterations = linear_iterations;
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
    const auto   ours_error  = error_energy;
    const auto   ours_lambda = error_multiplier;

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
        run.error_energy = *error_energy;
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


  // The benchmarks of the cycle, beside its record: the reference Poisson
  // solves (Benchmark/Reference Poisson solve, the cost unit of
  // bench/membranes_cost.py) and the PETSc SNES VI peer (Benchmark/Compare
  // with PETSc VI), also as columns of the convergence table.
  template <int dim>
  void
  MembraneProblem<dim>::record_benchmarks(VI::Json &record)
  {
    if (parameters.reference_poisson_solve)
      {
        // (with the Gauss rule a Poisson code takes for Q_p, p + 1 points
        // per direction, exact for its stiffness on parallelograms; not
        // the estimators' rule of the contact problem, which for RT_p has
        // p + 3)
        const QGauss<dim> poisson_quadrature(fe.degree + 1);
        VI::Json          reference = VI::Json::array();
        for (unsigned int a = 0; a < 2; ++a)
          {
            const PoissonCost cost =
              reference_poisson_solve(*mapping,
                                      dof_handler,
                                      poisson_quadrature,
                                      a == 0 ? data.mu1 : data.mu2,
                                      a == 0 ? *data.f1 : *data.f2,
                                      a == 0 ? *data.g1 : *data.g2,
                                      comm);
            VI::Json membrane      = VI::Json::object();
            membrane["seconds"]    = cost.seconds;
            membrane["iterations"] = cost.iterations;
            membrane["usage"]      = VI::to_json(cost.usage);
            reference.push_back(membrane);
          }
        record["reference_poisson"] = reference;
      }

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
  }


  // Explicit instantiations of this file's members.
  template VI::NewtonReport
  MembraneProblem<2>::solve_with_petsc_vi(Vector &X, std::string &reason) const;
  template void
  MembraneProblem<2>::compare_with_petsc_vi(const Vector &initial);
  template void
  MembraneProblem<2>::record_benchmarks(VI::Json &record);
} // namespace StepMembranes
