#include "twophase_problem.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/sundials/kinsol.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>
#include <vi/memory_budget.h>
#include <vi/program.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>

namespace StepTwoPhase
{
  namespace
  {
    /// Gas counts as present where S_g exceeds this.
    constexpr double gas_threshold = 1e-6;

    /// The hydrogen injection rate averaged over (t0, t1): the injected mass
    /// over the step is exact even if the step straddles the end of the
    /// injection.
    double
    average_injection_rate(const BoundaryParameters &b,
                           const double              t0,
                           const double              t1)
    {
      const double injecting =
        std::max(0., std::min(t1, b.injection_duration) - t0);
      return b.injection_rate * injecting / (t1 - t0);
    }
  } // namespace


  TwoPhaseProblem::TwoPhaseProblem(const Parameters &parameters,
                                   ParameterHandler &prm,
                                   const MPI_Comm    comm)
      : parameters(parameters)
      , prm(prm)
      , comm(comm)
      // No communicator: nothing collective in the destructor, which also
      // runs when a failure unwinds the stack.
      , timer(std::cout, TimerOutput::never, TimerOutput::wall_times)
      , model(parameters.physics)
      , C(VI::ComplementarityFunction(parameters.nonlinear_solver.c_function))
      , reconstruction_fe(2)
      , reconstruction_dof_handler(triangulation)
      , run_record("step-twophase", parameters.output.directory, timer, comm)
  {
    run_record.complete_summary = [this](VI::Json &summary) {
      add_results(summary);
    };
  }


  // Before anything is allocated: the run's memory against what the machine
  // gives. Measured as the peak resident memory (/usr/bin/time -f %M) of
  // parameters/twophase-benchmark.prm with "Time stepping/Final time" and
  // "Time step" = 100 (one step) on 2e5 and 4e5 cells: 2860 bytes per
  // cell between the two, made 25 % larger, and three unknowns per cell.
  void
  TwoPhaseProblem::check_memory_budget() const
  {
    constexpr double bytes_per_unknown = 1.25 * 2860. / 3;
    const double     cells             = parameters.mesh.n_cells;
    VI::MemoryBudget(cells,
                     FiniteVolumeScheme::n_components * cells,
                     bytes_per_unknown,
                     "Mesh/Number of cells",
                     comm)
      .check();
  }


  // Omega = (0, L) in N equal cells. The scheme numbers the cells from
  // left to right; cell_of maps that numbering to deal.II's.
  void
  TwoPhaseProblem::make_grid()
  {
    GridGenerator::subdivided_hyper_cube(triangulation,
                                         parameters.mesh.n_cells,
                                         0.,
                                         parameters.mesh.length);
    std::vector<std::pair<double, Triangulation<1>::active_cell_iterator>>
      cells;
    for (const auto &cell : triangulation.active_cell_iterators())
      cells.emplace_back(cell->center()[0], cell);
    std::sort(cells.begin(), cells.end(), [](const auto &a, const auto &b) {
      return a.first < b.first;
    });
    cell_of.clear();
    std::vector<double> vertices = {cells.front().second->vertex(0)[0]};
    for (const auto &[center, cell] : cells)
      {
        cell_of.push_back(cell->active_cell_index());
        vertices.push_back(cell->vertex(1)[0]);
      }

    const CellState right{parameters.boundary.right_saturation,
                          parameters.boundary.right_pressure,
                          parameters.boundary.right_molar_fraction};
    scheme = std::make_unique<FiniteVolumeScheme>(
      model,
      vertices,
      right,
      parameters.ordering == "cell-wise" ?
        FiniteVolumeScheme::Ordering::cell_wise :
        FiniteVolumeScheme::Ordering::field_wise);
  }


  // The Jacobian's sparsity (3 x 3 blocks between neighbouring cells), the
  // vectors, the estimators, and the P2 space of the reconstructions (for
  // output only).
  void
  TwoPhaseProblem::setup_system()
  {
    scheme->make_sparsity_pattern(sparsity_pattern);
    jacobian.reinit(sparsity_pattern);
    solution.reinit(scheme->n_unknowns());
    old_solution.reinit(scheme->n_unknowns());
    linearization_point.reinit(scheme->n_unknowns());
    estimators = std::make_unique<Estimators>(*scheme);
    reconstruction_dof_handler.distribute_dofs(reconstruction_fe);
    time_step = parameters.time.time_step;
  }


  // Initially the state of the right boundary everywhere (for the
  // benchmark: saturated with liquid, no hydrogen).
  void
  TwoPhaseProblem::set_initial_state()
  {
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      scheme->set_state(K, scheme->dirichlet_state(), solution);
    time = 0.;
    step = 0;
    // The estimators' reconstructions of the initial state, for output.
    scheme->set_time_step(solution, parameters.time.time_step, 0.);
    estimators->set_previous_state(solution);
    estimators->set_linearization_point(solution);
    estimators->estimate(solution);
    while (next_output < parameters.time.output_times.size() &&
           parameters.time.output_times[next_output] <= 0.)
      output_results();
  }


  // The end of the next step is at most the next output time, the end of
  // the injection or the final time: data change or output is due there.
  double
  TwoPhaseProblem::next_stop() const
  {
    const double T    = parameters.time.final_time;
    double       stop = T;
    if (next_output < parameters.time.output_times.size())
      stop = std::min(stop, parameters.time.output_times[next_output]);
    if (time < parameters.boundary.injection_duration)
      stop = std::min(stop, parameters.boundary.injection_duration);
    return stop;
  }


  /**
   * One accepted time step. An attempt that fails (Newton or GMRES without
   * convergence, NaN, saturation outside [0, 1]) is retried from the same
   * state with the step shortened by the reduction factor, down to the
   * minimal step; after a cut, dt grows back by the growth factor per
   * successful step.
   */
  void
  TwoPhaseProblem::advance_one_step()
  {
    Timer      step_timer;
    StepRecord record;
    double     dt = std::min(time_step, next_stop() - time);
    old_solution  = solution;
    for (;;)
      {
        StepRecord attempt;
        try
          {
            solve_time_step(dt, attempt);
            check_solution();
            attempt.cuts            = record.cuts;
            attempt.rejected_newton = record.rejected_newton;
            attempt.rejected_linear = record.rejected_linear;
            record                  = attempt;
            break;
          }
        catch (const VI::SolverFailure &failure)
          {
            solution = old_solution;
            cuts.push_back({time, dt, failure.what()});
            ++record.cuts;
            record.rejected_newton += attempt.newton;
            record.rejected_linear += attempt.linear;
            const double shorter = dt * parameters.time.reduction_factor;
            std::cout << "   step from t = " << years(time)
                      << " yr with dt = " << years(dt)
                      << " yr failed: " << failure.what() << std::endl;
            if (shorter < parameters.time.minimal_time_step)
              {
                std::ostringstream message;
                message << "the time step from t = " << years(time)
                        << " years failed with dt = " << years(dt)
                        << " years, and a shorter one would be below "
                           "Time stepping/Minimal time step = "
                        << years(parameters.time.minimal_time_step)
                        << " years (last failure: " << failure.what() << ")";
                throw VI::SolverFailure(message.str());
              }
            std::cout << "   retrying with dt = " << years(shorter) << " yr"
                      << std::endl;
            dt = shorter;
          }
      }

    const double nominal = parameters.time.time_step;
    if (record.cuts > 0)
      time_step = dt;
    else if (time_step < nominal)
      time_step = std::min(nominal, time_step * parameters.time.growth_factor);

    time += dt;
    // Land exactly on the stops (no drift from rounding).
    if (std::abs(time - next_stop()) < 1e-9 * dt)
      time = next_stop();
    ++step;
    record.step         = step;
    record.time         = time;
    record.dt           = dt;
    record.wall_seconds = step_timer.wall_time();
    record_step(record);
  }


  // Newton's initial guess is the previous state; the linearisation point of
  // the estimators is set there too, in case the state needs no iteration.
  void
  TwoPhaseProblem::solve_time_step(const double dt, StepRecord &record)
  {
    scheme->set_time_step(old_solution,
                          dt,
                          average_injection_rate(parameters.boundary,
                                                 time,
                                                 time + dt));
    solution = old_solution;
    estimators->set_previous_state(old_solution);
    estimators->set_linearization_point(solution);
    linearization_point = solution;

    if (parameters.nonlinear_solver_package == "kinsol")
      solve_with_kinsol(record);
    else
      solve_with_semismooth_newton(record);

    TimerOutput::Scope t(timer, "estimators");
    record.eta = estimators->estimate(solution);
  }


  /**
   * Semismooth Newton with the three strategies:
   * - exact: GMRES to Linear solver/Tolerance, Newton to Nonlinear
   *   solver/Tolerance;
   * - inexact: GMRES to the relative residual Forcing term;
   * - adaptive: GMRES stops when eta_alg <= gamma_alg max(eta_disc,
   *   eta_lin) (checked every Check interval iterations), Newton when
   *   eta_lin <= gamma_lin eta_disc, the algebraic criterion holds at its
   *   iterate and the saturation is in [0, 1].
   */
  void
  TwoPhaseProblem::solve_with_semismooth_newton(StepRecord &record)
  {
    const auto  &p        = parameters.nonlinear_solver;
    const bool   adaptive = (p.strategy == VI::Strategy::adaptive);
    const double relative_tolerance =
      VI::linear_tolerance(p, parameters.linear_solver);

    const auto settings = VI::SemismoothNewton<
      Vector<double>>::AdditionalData::with_merit_line_search(p, C);
    VI::SemismoothNewton<Vector<double>> newton(settings);

    newton.residual = [&](const Vector<double> &X, Vector<double> &R) {
      TimerOutput::Scope t(timer, "residual");
      return scheme->residual(X, C, R);
    };
    newton.setup_jacobian = [&](const Vector<double> &X) {
      prepare_linear_solver(X);
    };
    newton.solve_with_jacobian = [&](const Vector<double> &rhs,
                                     Vector<double>       &dX) {
      return solve_linear_system(rhs, dX, relative_tolerance, adaptive);
    };
    newton.monitor = [&](const VI::NewtonStep &step) {
      record.newton = step.iteration;
      record.linear += step.linear_iterations;
      IterationRecord it;
      it.k           = step.iteration;
      it.i           = step.linear_iterations;
      it.residual    = step.residual;
      it.step_length = step.step_length;
      record.iterations.push_back(it);
      if (parameters.output.verbose)
        std::cout << "      k = " << std::setw(2) << step.iteration
                  << ": residuals " << std::scientific << std::setprecision(2)
                  << step.residual.equations << " (balance), "
                  << step.residual.complementarity << " (complementarity), "
                  << step.linear_iterations << " GMRES" << std::defaultfloat
                  << std::endl;
    };
    // Without the estimators' criterion, Newton also stops where its
    // balance residual is at the rounding level (a fine mesh's floor, above
    // the tolerance).
    if (!adaptive)
      newton.stopping_criterion = [&](const Vector<double> &,
                                      const VI::NewtonStep &step) {
        return step.residual.equations <= 2 * balance_rounding_level &&
               step.residual.complementarity <= p.tolerance;
      };
    if (adaptive)
      newton.stopping_criterion = [&](const Vector<double> &X,
                                      const VI::NewtonStep &) {
        TimerOutput::Scope    t(timer, "estimators");
        const EstimatorValues eta    = estimators->estimate(X);
        record.iterations.back().eta = eta;
        // The algebraic criterion is repeated because a step shortened by
        // the line search is not the iterate at which GMRES stopped: its
        // linearised residual contains (1 - t) R(X^{k-1}).
        return p.linearisation_error_small(eta.disc, eta.lin) &&
               p.algebraic_error_small(eta.disc, eta.lin, eta.alg) &&
               is_admissible(X);
      };

    newton.solve(solution);
  }


  /**
   * The comparison solver: SUNDIALS KINSOL, Newton with its line search on
   * the Fischer-Burmeister form (a smooth merit function), the same
   * residual, Jacobian and GMRES. KINSOL decides the linear tolerances with
   * the inexact strategy (its forcing terms); with the exact one GMRES
   * solves to Linear solver/Tolerance. The Jacobian is rebuilt in every
   * iteration, as in semismooth Newton.
   */
  void
  TwoPhaseProblem::solve_with_kinsol(StepRecord &record)
  {
    const auto &p = parameters.nonlinear_solver;
    SUNDIALS::KINSOL<Vector<double>>::AdditionalData settings(
      SUNDIALS::KINSOL<Vector<double>>::AdditionalData::linesearch,
      p.max_iterations,
      /*function_tolerance=*/p.tolerance,
      /*step_tolerance=*/0.,
      /*no_init_setup=*/false,
      /*maximum_setup_calls=*/1);
    SUNDIALS::KINSOL<Vector<double>> kinsol(settings);

    // The callbacks run inside SUNDIALS' C code: they report failures by
    // their return value (> 0: recoverable) and never throw.
    kinsol.reinit_vector = [&](Vector<double> &v) {
      v.reinit(scheme->n_unknowns());
    };
    kinsol.residual = [&](const Vector<double> &X, Vector<double> &R) {
      TimerOutput::Scope      t(timer, "residual");
      const VI::ResidualNorms norms = scheme->residual(X, C, R);
      return norms.is_finite() ? 0 : 1;
    };
    std::string linear_failure;
    kinsol.setup_jacobian = [&](const Vector<double> &X,
                                const Vector<double> &) {
      ++record.newton;
      try
        {
          prepare_linear_solver(X);
          return 0;
        }
      catch (const VI::SolverFailure &failure)
        {
          linear_failure = failure.what();
          return 1;
        }
    };
    kinsol.solve_with_jacobian = [&](const Vector<double> &rhs,
                                     Vector<double>       &dX,
                                     const double          tolerance) {
      try
        {
          const double relative =
            p.strategy == VI::Strategy::inexact && rhs.l2_norm() > 0 ?
              std::max(tolerance / rhs.l2_norm(),
                       parameters.linear_solver.tolerance) :
              parameters.linear_solver.tolerance;
          record.linear += solve_linear_system(rhs, dX, relative, false);
          return 0;
        }
      catch (const VI::SolverFailure &failure)
        {
          linear_failure = failure.what();
          return 1;
        }
    };

    try
      {
#ifdef DEBUG
        // deal.II checks KINSOL's return codes with Assert, which aborts in
        // debug mode; a failed step is an ordinary event here (the step is
        // retried), so let the check throw instead.
        deal_II_exceptions::disable_abort_on_exception();
#endif
        kinsol.solve(solution);
      }
    catch (const ExceptionBase &)
      {
        // Debug mode only; the residual check below says what failed.
      }

    Vector<double>          R(scheme->n_unknowns());
    const VI::ResidualNorms norms = scheme->residual(solution, C, R);
    if (!norms.is_finite() || norms.equations > p.tolerance ||
        norms.complementarity > p.tolerance)
      {
        std::ostringstream message;
        message << "KINSOL: no convergence after " << record.newton
                << " Jacobian evaluations (residuals: balance "
                << norms.equations << ", complementarity "
                << norms.complementarity << ", tolerance " << p.tolerance
                << ")";
        if (!linear_failure.empty())
          message << "; " << linear_failure;
        throw VI::SolverFailure(message.str());
      }
    IterationRecord it;
    it.k        = record.newton;
    it.i        = record.linear;
    it.residual = norms;
    record.iterations.push_back(it);
  }


  // How far rounding alone moves the balance rows: eps sum_j |A_Kj X_j|, the
  // first-order change of R_K when every unknown moves by one unit in the
  // last place, at worst, at its largest over K. Newton cannot bring the
  // residual below this; it grows like N^2 (the fluxes divide by h^2) and
  // meets the default tolerance 1e-8 at about 1e5 cells.
  double
  TwoPhaseProblem::rounding_level(const Vector<double> &X) const
  {
    double largest = 0;
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      for (const auto c :
           {FiniteVolumeScheme::pressure, FiniteVolumeScheme::molar_fraction})
        {
          const unsigned int row = scheme->index(K, c);
          double             sum = 0;
          for (auto entry = jacobian.begin(row); entry != jacobian.end(row);
               ++entry)
            sum += std::abs(entry->value() * X[entry->column()]);
          largest = std::max(largest, sum);
        }
    return std::numeric_limits<double>::epsilon() * largest;
  }


  // The generalised Jacobian at X, its ILU(0) (the sparsity never changes,
  // so the factorisation reuses its storage) or LU, and X as the estimators'
  // linearisation point.
  void
  TwoPhaseProblem::prepare_linear_solver(const Vector<double> &X)
  {
    {
      TimerOutput::Scope t(timer, "jacobian");
      scheme->assemble_jacobian(X, C, jacobian);
      balance_rounding_level = rounding_level(X);
    }
    {
      TimerOutput::Scope t(timer, "estimators");
      estimators->set_linearization_point(X);
      linearization_point = X;
    }
    TimerOutput::Scope t(timer, "preconditioner");
    if (parameters.linear_solver.solver == VI::LinearSolverType::direct)
      try
        {
          direct_solver.factorize(jacobian);
        }
      catch (const ExceptionBase &)
        {
          throw VI::SolverFailure("UMFPACK could not factorise the "
                                  "generalised Jacobian (singular?)");
        }
    else
      {
        ilu.initialize(jacobian,
                       SparseILU<double>::AdditionalData(
                         0., 0., /*use_previous_sparsity=*/ilu_initialized));
        ilu_initialized = true;
      }
  }


  /**
   * Solve A dX = rhs (A the last Jacobian) by GMRES with ILU(0), from zero,
   * to the given relative residual; with `adaptive`, GMRES also stops as
   * soon as the estimators of the iterate X^{k-1} + dX^i say that the
   * algebraic error no longer matters. The constraint rows of the result
   * are then made exact (enforce_constraint_rows), so that the algebraic
   * error sits in the balance rows only, where Theta_alg lifts it.
   */
  unsigned int
  TwoPhaseProblem::solve_linear_system(const Vector<double> &rhs,
                                       Vector<double>       &dX,
                                       const double          relative_tolerance,
                                       const bool            adaptive)
  {
    TimerOutput::Scope t(timer, "linear solver");
    if (parameters.linear_solver.solver == VI::LinearSolverType::direct)
      {
        direct_solver.vmult(dX, rhs);
        return 0;
      }

    const auto &ls = parameters.linear_solver;
    typename VI::Gmres<Vector<double>>::AdditionalData settings;
    settings.max_iterations     = ls.max_iterations;
    settings.krylov_dimension   = ls.krylov_dimension;
    settings.relative_tolerance = relative_tolerance;
    settings.check_interval     = ls.check_interval;
    const VI::Gmres<Vector<double>> gmres(settings);

    typename VI::Gmres<Vector<double>>::Monitor monitor;
    Vector<double>                              trial, residual;
    if (adaptive)
      monitor = [&](const Vector<double> &x, unsigned int) {
        TimerOutput::Scope t(timer, "estimators");
        trial = x;
        enforce_constraint_rows(rhs, trial);
        // With Fischer-Burmeister's line search the update must also be a
        // descent direction of the merit function 1/2 |R|^2: with A dX =
        // -R + r, its slope is -|R|^2 + (R, r) <= -|R|^2 / 2 if |r| <=
        // |R| / 2.
        if (C.has_smooth_merit_function())
          {
            residual.reinit(rhs.size());
            jacobian.vmult(residual, trial);
            residual -= rhs;
            if (residual.l2_norm() > 0.5 * rhs.l2_norm())
              return false;
          }
        trial += linearization_point;
        const EstimatorValues eta = estimators->estimate(trial);
        return parameters.nonlinear_solver.algebraic_error_small(eta.disc,
                                                                 eta.lin,
                                                                 eta.alg);
      };

    dX = 0.;
    const VI::LinearSolveReport report =
      gmres.solve([&](Vector<double>       &dst,
                      const Vector<double> &src) { jacobian.vmult(dst, src); },
                  [&](Vector<double> &dst, const Vector<double> &src) {
                    ilu.vmult(dst, src);
                  },
                  dX,
                  rhs,
                  monitor);
    enforce_constraint_rows(rhs, dX);
    return report.iterations;
  }


  // Each constraint row of A dX = rhs involves the three unknowns of its
  // cell only. Its residual is removed by correcting the unknown with the
  // largest coefficient (the smallest correction): S on the branch 1 - S of
  // min, chi or S on the branch of Henry's law.
  void
  TwoPhaseProblem::enforce_constraint_rows(const Vector<double> &rhs,
                                           Vector<double>       &dX) const
  {
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      {
        const unsigned int row =
          scheme->index(K, FiniteVolumeScheme::saturation);
        double       residual = rhs[row], largest = 0.;
        unsigned int column = row;
        for (auto entry = jacobian.begin(row); entry != jacobian.end(row);
             ++entry)
          {
            residual -= entry->value() * dX[entry->column()];
            if (std::abs(entry->value()) > std::abs(largest))
              {
                largest = entry->value();
                column  = entry->column();
              }
          }
        if (largest != 0.)
          dX[column] += residual / largest;
      }
  }


  // A result must be physical: S in [0, 1] up to the tolerance.
  bool
  TwoPhaseProblem::is_admissible(const Vector<double> &X) const
  {
    const double tolerance = parameters.time.saturation_tolerance;
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      {
        const double S = X[scheme->index(K, FiniteVolumeScheme::saturation)];
        if (!(S >= -tolerance && S <= 1. + tolerance))
          return false;
      }
    return true;
  }


  void
  TwoPhaseProblem::check_solution() const
  {
    const double tolerance = parameters.time.saturation_tolerance;
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      {
        const double S =
          solution[scheme->index(K, FiniteVolumeScheme::saturation)];
        if (!(S >= -tolerance && S <= 1. + tolerance))
          {
            std::ostringstream message;
            message << "the saturation " << std::setprecision(10) << S
                    << std::setprecision(6)
                    << " at x = " << scheme->cell_center(K)
                    << " m leaves [0, 1] by more than Time "
                       "stepping/Saturation tolerance = "
                    << tolerance;
            throw VI::SolverFailure(message.str());
          }
      }
  }


  // The values at x = 0 (the leftmost cell), the gas front, the progress
  // line, and the output due at this time.
  void
  TwoPhaseProblem::record_step(StepRecord &record)
  {
    const CellState U0        = scheme->state(solution, 0);
    record.gas_saturation_x0  = 1. - U0.S;
    record.liquid_pressure_x0 = U0.P;
    record.gas_pressure_x0    = U0.P + model.capillary_pressure(U0.S).value;
    record.molar_fraction_x0  = U0.chi;
    record.gas_front          = 0.;
    for (unsigned int K = 0; K < scheme->n_cells(); ++K)
      if (1. - solution[scheme->index(K, FiniteVolumeScheme::saturation)] >
          gas_threshold)
        record.gas_front = scheme->mesh_vertices()[K + 1];
    records.push_back(record);

    if (step % parameters.progress_interval == 0 ||
        time >= parameters.time.final_time)
      std::cout << "step " << std::setw(4) << step << "  t = " << std::setw(9)
                << years(time) << " yr  dt = " << std::setw(6)
                << years(record.dt) << " yr  Newton " << std::setw(2)
                << record.newton << "  GMRES " << std::setw(4) << record.linear
                << std::scientific << std::setprecision(3)
                << "  S_g(0) = " << record.gas_saturation_x0
                << "  P_g(0) = " << record.gas_pressure_x0 << "  front "
                << std::defaultfloat << std::setprecision(4) << record.gas_front
                << " m" << std::setprecision(6) << std::endl;

    while (next_output < parameters.time.output_times.size() &&
           parameters.time.output_times[next_output] <= time)
      output_results();
    if (parameters.time.checkpoint_interval > 0 &&
        step % parameters.time.checkpoint_interval == 0)
      write_checkpoint();
  }


  // The line that says what this run solves, and how.
  std::string
  TwoPhaseProblem::description() const
  {
    const auto        &nl = parameters.nonlinear_solver;
    std::ostringstream line;
    line << "Couplex-Gas benchmark: " << scheme->n_cells()
         << " cells, dt = " << years(parameters.time.time_step)
         << " yr, T = " << years(parameters.time.final_time) << " yr; "
         << (parameters.nonlinear_solver_package == "kinsol" ?
               "KINSOL (Newton with line search, FB)" :
               "semismooth Newton-" + C.name())
         << ", " << VI::to_string(nl.strategy) << " strategy, "
         << VI::to_string(parameters.linear_solver.solver)
         << (parameters.linear_solver.solver == VI::LinearSolverType::gmres ?
               " + ILU(0), " + parameters.ordering + " ordering" :
               " (UMFPACK)");
    return line.str();
  }


  // The work of the whole run, rejected attempts included.
  void
  TwoPhaseProblem::print_totals() const
  {
    unsigned int newton = 0, linear = 0;
    for (const StepRecord &r : records)
      {
        newton += r.newton + r.rejected_newton;
        linear += r.linear + r.rejected_linear;
      }
    std::cout << "\n"
              << records.size() << " time steps (" << cuts.size() << " cuts), "
              << newton << " Newton iterations, " << linear
              << " GMRES iterations, " << std::setprecision(3)
              << run_timer.wall_time() << " s" << std::setprecision(6)
              << std::endl;
  }


  // The benchmark's quantities at x = 0, on the time grid of the run.
  void
  TwoPhaseProblem::print_gas_at_x0() const
  {
    const auto with_gas = [](const StepRecord &r) {
      return r.gas_saturation_x0 > gas_threshold;
    };
    const auto first_gas =
      std::find_if(records.begin(), records.end(), with_gas);
    if (first_gas != records.end())
      {
        const auto peak =
          std::max_element(records.begin(),
                           records.end(),
                           [](const auto &a, const auto &b) {
                             return a.gas_saturation_x0 < b.gas_saturation_x0;
                           });
        const auto gone = std::find_if_not(peak, records.end(), with_gas);
        std::cout << "At x = 0: gas from t = " << years(first_gas->time)
                  << " yr, max S_g = " << peak->gas_saturation_x0
                  << " at t = " << years(peak->time) << " yr, ";
        if (gone != records.end())
          std::cout << "gone at t = " << years(gone->time) << " yr";
        else
          std::cout << "still present at the end";
        std::cout << std::endl;
      }
  }


  // Set up (or resume from the checkpoint), then advance step by step to the
  // final time, retrying failed steps with shorter ones; write the tables
  // and the summary (also when the run fails).
  void
  TwoPhaseProblem::run()
  {
    AssertThrow(Utilities::MPI::n_mpi_processes(comm) == 1,
                ExcMessage("step-twophase is serial"));
    check_memory_budget();
    make_grid();
    setup_system();
    if (parameters.time.resume)
      read_checkpoint();
    run_record.start(prm, description(), "steps");

    if (!parameters.time.resume)
      set_initial_state();
    else
      std::cout << "Resuming at t = " << years(time) << " yr (step " << step
                << ")" << std::endl;

    run_record.guard([&] {
      while (time < parameters.time.final_time)
        advance_one_step();
    });

    write_checkpoint();
    write_tables();
    print_totals();
    print_gas_at_x0();
    run_record.finish("convergence.txt, x0.csv, profile-*.csv, solution.pvd, "
                      "summary.json, checkpoint.txt");
  }
} // namespace StepTwoPhase
