#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>

#include <vi/complementarity.h>
#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>

#include <cmath>
#include <iomanip>
#include <sstream>

namespace VI
{
  bool
  ResidualNorms::is_finite() const
  {
    return std::isfinite(equations) && std::isfinite(complementarity);
  }


  std::string
  ResidualNorms::describe(const std::string &equations_name,
                          const double       tolerance) const
  {
    std::ostringstream out;
    out << equations_name << ' ' << equations << ", complementarity "
        << complementarity << ", tolerance " << tolerance;
    return out.str();
  }


  template <typename VectorType>
  SemismoothNewton<VectorType>::AdditionalData::AdditionalData(
    const NonlinearSolverParameters &parameters,
    const ComplementarityFunction   &C)
      : max_iterations(parameters.max_iterations)
      , tolerance(parameters.tolerance)
      , line_search(C.has_smooth_merit_function())
      , watchdog_steps(parameters.watchdog_steps)
      , name("semismooth Newton-" + C.name())
  {
  }


  template <typename VectorType>
  SemismoothNewton<VectorType>::SemismoothNewton(const AdditionalData &data)
      : data(data)
  {
  }


  template <typename VectorType>
  bool
  SemismoothNewton<VectorType>::converged(const ResidualNorms &norms) const
  {
    return norms.equations <= data.tolerance &&
           norms.complementarity <= data.tolerance;
  }


  template <typename VectorType>
  void
  SemismoothNewton<VectorType>::fail(const std::string &reason) const
  {
    throw SolverFailure(data.name + ": " + reason);
  }


  template <typename VectorType>
  NewtonReport
  SemismoothNewton<VectorType>::solve(VectorType &X) const
  {
    if (!residual || !setup_jacobian || !solve_with_jacobian)
      fail("the problem did not provide residual, setup_jacobian and "
           "solve_with_jacobian");

    NewtonReport report;

    VectorType R, rhs, dX, trial;
    R.reinit(X);
    rhs.reinit(X);
    dX.reinit(X);

    ResidualNorms norms     = residual(X, R);
    report.initial_residual = norms;

    bool criterion_met = false;
    // The watchdog's reference iterate and merit, the full steps taken
    // since it without the test, and whether the iteration has just
    // returned to it (then the next step backtracks).
    VectorType X_reference;
    X_reference.reinit(X);
    X_reference                  = X;
    double       theta_reference = 0.5 * R.norm_sqr();
    unsigned int relaxed_steps   = 0;
    bool         returned        = false;
    for (unsigned int k = 1;; ++k)
      {
        if (!norms.is_finite())
          fail("the residual is not a number at iteration " +
               std::to_string(k - 1) + " (NaN or Inf in the data or the " +
               "iterate)");
        if (converged(norms) || criterion_met)
          break;
        if (k > data.max_iterations)
          fail("no convergence in " + std::to_string(data.max_iterations) +
               " iterations (relative residuals: " +
               norms.describe("equations", data.tolerance) + ")");

        setup_jacobian(X);
        NewtonStep step;
        if (active_set)
          {
            step.has_active_set = true;
            step.active_set     = active_set(X, k == 1);
          }
        rhs = R;
        rhs *= -1.;
        const unsigned int linear_iterations = solve_with_jacobian(rhs, dX);
        if (!std::isfinite(dX.l2_norm()))
          fail("the Newton update is not a number at iteration " +
               std::to_string(k) + " (singular generalised Jacobian?)");

        double step_length = 1.;
        if (!data.line_search)
          {
            X.add(1., dX);
            norms = residual(X, R);
          }
        else
          {
            // Backtracking on theta(X) = 1/2 |R(X)|^2. For the exact Newton
            // direction, theta'(X; dX) = -2 theta(X), hence the Armijo test.
            const double theta_0 = 0.5 * R.norm_sqr();
            trial.reinit(X, /*omit_zeroing_entries=*/true);
            trial = X;
            trial.add(1., dX);
            const bool certified = accept_full_step && accept_full_step(trial);
            if (!certified && !returned && data.watchdog_steps > 0)
              {
                // Full steps may raise the merit function before they
                // converge (Fischer-Burmeister from a transferred iterate):
                // the watchdog takes them, and checks the sufficient
                // decrease against the reference instead of every step.
                X                  = trial;
                norms              = residual(X, R);
                const double theta = 0.5 * R.norm_sqr();
                if (std::isfinite(theta) &&
                    theta <=
                      (1. - 2. * data.armijo_parameter) * theta_reference)
                  {
                    X_reference     = X;
                    theta_reference = theta;
                    relaxed_steps   = 0;
                  }
                else if (++relaxed_steps == data.watchdog_steps ||
                         !std::isfinite(theta))
                  {
                    X           = X_reference;
                    norms       = residual(X, R);
                    step_length = 0;
                    returned    = true;
                  }
              }
            else
              {
                for (unsigned int cuts = 0;; ++cuts)
                  {
                    norms = residual(trial, R);
                    if (certified)
                      break;
                    const double theta_t = 0.5 * R.norm_sqr();
                    if (std::isfinite(theta_t) &&
                        theta_t <=
                          (1. - 2. * data.armijo_parameter * step_length) *
                            theta_0)
                      break;
                    if (cuts == data.max_line_search_steps)
                      fail("the line search on the merit function found no "
                           "decrease after " +
                           std::to_string(cuts) +
                           " step halvings at iteration " + std::to_string(k));
                    step_length *= 0.5;
                    trial = X;
                    trial.add(step_length, dX);
                  }
                X               = trial;
                X_reference     = X;
                theta_reference = 0.5 * R.norm_sqr();
                relaxed_steps   = 0;
                returned        = false;
              }
          }

        step.iteration         = k;
        step.residual          = norms;
        step.step_length       = step_length;
        step.linear_iterations = linear_iterations;
        report.steps.push_back(step);
        report.iterations = k;
        report.linear_iterations += linear_iterations;
        if (monitor)
          monitor(step);
        if (stopping_criterion)
          criterion_met = stopping_criterion(X, step);
      }

    report.final_residual = norms;
    return report;
  }


  std::string
  describe(const NewtonStep &step, const std::string &linear_solver)
  {
    std::ostringstream line;
    line << "residuals " << std::scientific << std::setprecision(2)
         << step.residual.equations << " (equations), "
         << step.residual.complementarity << " (complementarity)"
         << std::defaultfloat;
    if (step.linear_iterations > 0)
      line << ", " << step.linear_iterations << ' ' << linear_solver
           << " iterations";
    if (step.step_length == 0)
      line << ", back to the watchdog's reference iterate";
    else if (step.step_length < 1)
      line << ", step " << step.step_length;
    if (step.has_active_set)
      {
        line << ", " << step.active_set.active << " active rows";
        if (step.iteration > 1)
          line << " (" << step.active_set.switched << " switched)";
      }
    return line.str();
  }


  template class SemismoothNewton<dealii::Vector<double>>;
  template class SemismoothNewton<dealii::TrilinosWrappers::MPI::Vector>;
} // namespace VI
