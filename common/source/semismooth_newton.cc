#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>

#include <vi/complementarity.h>
#include <vi/errors.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <vector>

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
      , name("semismooth Newton-" + C.name())
      , continuation(parameters.continuation)
      , continuation_method(parameters.continuation_method)
  {
    // The adaptive strategy's estimators often end a crawl first (see
    // crawl_steps).
    if (parameters.strategy == Strategy::adaptive)
      crawl_steps = adaptive_crawl_steps;
    inexact_stall = parameters.strategy != Strategy::exact;
    if (parameters.strategy != Strategy::exact)
      centrality_correctors = 0;
  }


  template <typename VectorType>
  typename SemismoothNewton<VectorType>::AdditionalData
  SemismoothNewton<VectorType>::AdditionalData::with_merit_line_search(
    const NonlinearSolverParameters &parameters,
    const ComplementarityFunction   &C)
  {
    AdditionalData data(parameters, C);
    data.line_search    = C.has_smooth_merit_function();
    data.watchdog_steps = parameters.watchdog_steps;
    data.continuation   = false;
    return data;
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
  bool
  SemismoothNewton<VectorType>::stalled(const NewtonReport &report) const
  {
    const auto &steps = report.steps;
    // Whether each of the last `count` steps switched rows (and there was a
    // step before them).
    const auto switching = [&steps](const std::size_t count) {
      if (steps.size() < count + 1)
        return false;
      for (std::size_t n = steps.size() - count; n < steps.size(); ++n)
        if (!steps[n].has_active_set || steps[n].active_set.switched == 0)
          return false;
      return true;
    };
    const auto r = [&steps](const std::size_t n) {
      return steps[n].residual.complementarity;
    };
    // The window of `average_steps` steps that ends at step `last` crawls:
    // the residual fell by less than 1 / stall_ratio in each of its steps,
    // while the fronts keep their pace (a ring crawl switches about as many
    // rows each step, converging steps ever fewer; the last two steps
    // only: the first after the penetration set frees a wider band, and
    // rings on unstructured faces vary in length). With inexact directions
    // also where the residual did not fall by that factor over the whole
    // window, whatever its steps and pace (AdditionalData::inexact_stall).
    const auto crawls = [&](const std::size_t last) {
      const std::size_t first     = last - data.average_steps;
      bool              slow_each = true;
      for (std::size_t n = first + 1; n <= last; ++n)
        slow_each = slow_each && r(n) >= data.stall_ratio * r(n - 1);
      const bool keeps_pace =
        double(steps[last].active_set.switched) >=
        data.crawl_pace * double(steps[last - 1].active_set.switched);
      return (slow_each && keeps_pace) ||
             (data.inexact_stall && r(last) >= data.stall_ratio * r(first));
    };
    // A crawl lasts crawl_steps steps: every window in them crawls.
    if (switching(data.crawl_steps))
      {
        bool crawl = true;
        for (std::size_t last =
               steps.size() - 1 - (data.crawl_steps - data.average_steps);
             last < steps.size();
             ++last)
          crawl = crawl && crawls(last);
        if (crawl)
          return true;
      }
    // With exact directions, a cycle: over `cycle_steps` steps the smallest
    // residual stays above `stall_ratio` times the smallest before them.
    // (With inexact ones the unhalved window above catches it.)
    if (data.inexact_stall || !switching(data.cycle_steps))
      return false;
    const std::size_t first       = steps.size() - data.cycle_steps;
    double            best_before = std::numeric_limits<double>::infinity(),
           best_since             = best_before;
    for (std::size_t n = 0; n < steps.size(); ++n)
      if (n < first)
        best_before = std::min(best_before, r(n));
      else
        best_since = std::min(best_since, r(n));
    return best_since >= data.stall_ratio * best_before;
  }


  template <typename VectorType>
  bool
  SemismoothNewton<VectorType>::stagnated(const NewtonReport &report) const
  {
    const auto &steps = report.steps;
    if (data.stagnation_steps == 0 || steps.size() < data.stagnation_steps + 1)
      return false;
    const auto size = [](const ResidualNorms &r) {
      return std::max(r.equations, r.complementarity);
    };
    for (std::size_t n = steps.size() - data.stagnation_steps; n < steps.size();
         ++n)
      if (!steps[n].has_active_set || steps[n].active_set.switched != 0 ||
          steps[n].smoothing != 0 || steps[n].step_length != 1 ||
          size(steps[n].residual) <
            data.stagnation_ratio * size(steps[n - 1].residual))
        return false;
    return true;
  }


  template <typename VectorType>
  NewtonReport
  SemismoothNewton<VectorType>::solve(VectorType &X) const
  {
    if (!residual || !setup_jacobian || !solve_with_jacobian)
      fail("the problem did not provide residual, setup_jacobian and "
           "solve_with_jacobian");

    NewtonReport report;
    // The rows are those of C: a continuation of an earlier solve that
    // converged on its path (below) must not carry over.
    if (set_smoothing)
      set_smoothing(X, 0.);

    VectorType R, rhs, dX;
    R.reinit(X);
    rhs.reinit(X);
    dX.reinit(X);

    ResidualNorms norms     = residual(X, R);
    report.initial_residual = norms;

    Watchdog watchdog;
    watchdog.restart(X, 0.5 * R.norm_sqr());

    bool                criterion_met = false;
    double              mu = 0.; // the continuation's smoothing parameter
    std::vector<double> merits;  // its last values of 1/2 |R_mu|^2
    for (unsigned int k = 1;; ++k)
      {
        if (!norms.is_finite())
          fail("the residual is not a number at iteration " +
               std::to_string(k - 1) + " (NaN or Inf in the data or the " +
               "iterate)");
        if (converged(norms) || criterion_met)
          break;
        check_iteration_limit(k, norms);
        NewtonStep step = linearise(X, k == 1);
        rhs             = R;
        rhs *= -1.;
        const unsigned int linear_iterations = solve_with_jacobian(rhs, dX);
        if (!std::isfinite(dX.l2_norm()))
          fail("the Newton update is not a number at iteration " +
               std::to_string(k) + " (singular generalised Jacobian?)");

        step.smoothing         = mu;
        step.step_length       = mu > 0 ?
                                   continuation_step(X, dX, R, norms, merits, k) :
                                   plain_step(X, dX, R, norms, watchdog, k);
        step.iteration         = k;
        step.residual          = norms;
        step.linear_iterations = linear_iterations;
        report.steps.push_back(step);
        report.iterations = k;
        report.linear_iterations += linear_iterations;
        if (monitor)
          monitor(step);
        if (stopping_criterion)
          criterion_met = stopping_criterion(X, step);
        if (mu == 0 && !converged(norms) && !criterion_met && stagnated(report))
          fail("stagnated: the active set has not changed in the last " +
               std::to_string(data.stagnation_steps) +
               " steps and the residual stays above the tolerance (" +
               norms.describe("equations", data.tolerance) + ")");
        if (!can_continue() || converged(norms) || criterion_met)
          continue;

        // The continuation: it starts once, when the active set stalls,
        // with mu of the size of the complementarity residual. A step of
        // length t reduces mu by the factor 1 - t (1 - smoothing_reduction)
        // (a full step by smoothing_reduction, a short one little), but not
        // below neighbourhood_factor times the smoothed residual, so that
        // the iterate stays near the central path (after the update of Qi,
        // Sun and Zhou's smoothing Newton method). mu stops at half the
        // tolerance: on the path there every pair has |C| <= mu, so the path
        // itself ends the iteration. Returning to C instead would leave a
        // band of nodes where gap and multiplier are both below the
        // tolerance, whose branches the active set would sort out a ring per
        // step (doc/reference.md, "Continuation").
        double next_mu = mu;
        if (mu == 0 && report.continuation_start == 0 && stalled(report))
          {
            report.continuation_start = k;
            if (data.continuation_method == ContinuationMethod::interior_point)
              {
                // It ends converged or stopped by the criterion, or fails.
                interior_point_phase(X, R, norms, report, k);
                break;
              }
            next_mu = std::clamp(norms.complementarity, data.tolerance, 1.);
          }
        else if (mu > 0)
          {
            const double t = step.step_length;
            next_mu =
              std::max(mu * (1. - t * (1. - data.smoothing_reduction)),
                       std::min(mu,
                                data.neighbourhood_factor *
                                  std::max(norms.equations,
                                           norms.smoothed_complementarity)));
            next_mu = std::max(next_mu, 0.5 * data.tolerance);
          }
        if (next_mu != mu)
          {
            mu = next_mu;
            set_smoothing(X, mu);
            norms = residual(X, R);
            if (mu == 0)
              watchdog.restart(X, 0.5 * R.norm_sqr());
          }
      }

    // Newton may stop on the continuation's path (the residuals of C are
    // below the tolerance there too): the problem's rows return to C, so
    // that what is evaluated after the solve (the active set, the contact
    // set, the next solve's residual) sees C and not C_mu.
    if (mu > 0)
      {
        set_smoothing(X, 0.);
        norms = residual(X, R);
      }
    report.final_residual = norms;
    return report;
  }


  template <typename VectorType>
  void
  SemismoothNewton<VectorType>::check_iteration_limit(
    const unsigned int   k,
    const ResidualNorms &norms) const
  {
    if (k > data.max_iterations)
      fail("no convergence in " + std::to_string(data.max_iterations) +
           " iterations (relative residuals: " +
           norms.describe("equations", data.tolerance) + ")");
  }


  template <typename VectorType>
  NewtonStep
  SemismoothNewton<VectorType>::linearise(const VectorType &X,
                                          const bool        first) const
  {
    setup_jacobian(X);
    NewtonStep step;
    if (active_set)
      {
        step.has_active_set = true;
        step.active_set     = active_set(X, first);
      }
    return step;
  }


  template <typename VectorType>
  bool
  SemismoothNewton<VectorType>::can_continue() const
  {
    if (!data.continuation)
      return false;
    if (data.continuation_method == ContinuationMethod::smoothing)
      return bool(set_smoothing);
    const InteriorPointRows &rows = interior_point;
    return rows.enter && rows.set_targets && rows.solve_rows &&
           rows.step_to_boundary && rows.leave;
  }


  template <typename VectorType>
  void
  SemismoothNewton<VectorType>::interior_point_phase(VectorType    &X,
                                                     VectorType    &R,
                                                     ResidualNorms &norms,
                                                     NewtonReport  &report,
                                                     unsigned int   k) const
  {
    const InteriorPointRows &rows = interior_point;
    // Every pair on x y = mu2 (= mu^2 of the central path): a mu ten times
    // the complementarity residual keeps the rows of the crawl's over-large
    // active set off the boundary (AdditionalData::interior_point_start).
    const double mu_start =
      data.interior_point_start *
      std::clamp(norms.complementarity, data.tolerance, 1.);
    double mu2 = mu_start * mu_start;
    rows.enter(X, mu2);
    rows.set_targets(nullptr, 0.);
    norms = residual(X, R);

    VectorType rhs, dX_predictor, dX;
    rhs.reinit(X);
    dX_predictor.reinit(X);
    dX.reinit(X);
    // Solve the Jacobian of the last setup_jacobian() for -R.
    const auto newton_direction = [&](VectorType &direction) {
      rhs = R;
      rhs *= -1.;
      const unsigned int iterations = solve_with_jacobian(rhs, direction);
      rows.solve_rows(X, direction);
      if (!std::isfinite(direction.l2_norm()))
        fail("the interior-point direction is not a number at iteration " +
             std::to_string(k) + " (singular Jacobian?)");
      return iterations;
    };

    for (bool criterion_met = false; !converged(norms) && !criterion_met;)
      {
        if (!norms.is_finite() || !(mu2 > 0))
          fail("the interior-point iterate is not a number at iteration " +
               std::to_string(k));
        check_iteration_limit(++k, norms);
        NewtonStep step = linearise(X, false);
        // The predictor aims at x y = 0. How far it gets before a pair
        // leaves the positive quadrant says how much centring the corrector
        // needs: sigma = (its mean product / mu2)^3 (Mehrotra), small where
        // the predictor goes far. The corrector aims at x y = sigma mu2 with
        // the predictor's second-order term dx dy, with the same Jacobian.
        step.linear_iterations = newton_direction(dX_predictor);
        const double t_predictor =
          std::min(1., rows.step_to_boundary(X, dX_predictor, 0.)[0]);
        const double sigma =
          std::pow(rows.step_to_boundary(X, dX_predictor, t_predictor)[1] / mu2,
                   3);
        rows.set_targets(&dX_predictor, sigma * mu2);
        residual(X, R);
        step.linear_iterations += newton_direction(dX);
        step.linear_iterations +=
          centre(X, R, dX, dX_predictor, sigma * mu2, newton_direction);

        // The fraction of the way to the boundary tends to 1 with mu2, so
        // that the last steps converge superlinearly.
        step.step_length =
          std::min(1.,
                   std::max(data.fraction_to_boundary, 1. - std::sqrt(mu2)) *
                     rows.step_to_boundary(X, dX, 0.)[0]);
        X.add(step.step_length, dX);
        mu2 = rows.step_to_boundary(X, dX, 0.)[1];
        rows.set_targets(nullptr, 0.);
        norms = residual(X, R);

        step.iteration = k;
        step.residual  = norms;
        step.smoothing = std::sqrt(mu2);
        report.steps.push_back(step);
        report.iterations = k;
        report.linear_iterations += step.linear_iterations;
        if (monitor)
          monitor(step);
        if (stopping_criterion)
          criterion_met = stopping_criterion(X, step);
      }
    rows.leave();
    norms = residual(X, R);
  }


  template <typename VectorType>
  unsigned int
  SemismoothNewton<VectorType>::centre(
    const VectorType                                &X,
    VectorType                                      &R,
    VectorType                                      &dX,
    VectorType                                      &dX_trial,
    const double                                     target,
    const std::function<unsigned int(VectorType &)> &direction) const
  {
    // Gondzio's multiple centrality correctors: the corrector's step is cut
    // by a few pairs whose products fall far below the others'. Aiming at
    // a step longer by `increase`, the pairs whose products there leave
    // [target / 10, 10 target] get targets that bring them back, and the
    // same Jacobian is solved again; the new direction is kept if its step
    // is longer by a tenth of the increase. (A step ends at a pair's
    // boundary, so the longer step reduces mu2 by more at no cost in
    // Jacobians; on HHO P3 and P4 cold starts the increases 0.1 and 0.3 gave
    // the same counts.)
    const InteriorPointRows &rows       = interior_point;
    constexpr double         increase   = 0.2;
    unsigned int             iterations = 0;
    for (unsigned int j = 0; rows.centre && j < data.centrality_correctors; ++j)
      {
        const double t = std::min(1., rows.step_to_boundary(X, dX, 0.)[0]);
        if (t >= 1.)
          break;
        rows.centre(X, dX, std::min(1., t + increase), target);
        residual(X, R);
        iterations += direction(dX_trial);
        if (rows.step_to_boundary(X, dX_trial, 0.)[0] < t + 0.1 * increase)
          break;
        dX = dX_trial;
      }
    return iterations;
  }


  template <typename VectorType>
  double
  SemismoothNewton<VectorType>::plain_step(VectorType        &X,
                                           const VectorType  &dX,
                                           VectorType        &R,
                                           ResidualNorms     &norms,
                                           Watchdog          &watchdog,
                                           const unsigned int k) const
  {
    if (!data.line_search)
      {
        X.add(1., dX);
        norms = residual(X, R);
        return 1.;
      }

    // Backtracking on theta(X) = 1/2 |R(X)|^2. For the exact Newton
    // direction, theta'(X; dX) = -2 theta(X), hence the Armijo test.
    const double theta_0 = 0.5 * R.norm_sqr();
    VectorType   trial;
    trial.reinit(X, /*omit_zeroing_entries=*/true);
    trial = X;
    trial.add(1., dX);
    const bool certified = accept_full_step && accept_full_step(trial);
    if (!certified && !watchdog.returned && data.watchdog_steps > 0)
      {
        // Full steps may raise the merit function before they converge
        // (Fischer-Burmeister from a transferred iterate): the watchdog
        // takes them, and checks the sufficient decrease against the
        // reference instead of every step.
        X                  = trial;
        norms              = residual(X, R);
        const double theta = 0.5 * R.norm_sqr();
        if (std::isfinite(theta) && theta <= (1. - 2. * data.armijo_parameter) *
                                               watchdog.theta_reference)
          watchdog.restart(X, theta);
        else if (++watchdog.relaxed_steps == data.watchdog_steps ||
                 !std::isfinite(theta))
          {
            X                 = watchdog.X_reference;
            norms             = residual(X, R);
            watchdog.returned = true;
            return 0.;
          }
        return 1.;
      }

    const double step_length =
      backtrack(X,
                dX,
                trial,
                R,
                norms,
                theta_0,
                certified,
                "the line search on the merit function",
                k);
    watchdog.restart(X, 0.5 * R.norm_sqr());
    return step_length;
  }


  template <typename VectorType>
  double
  SemismoothNewton<VectorType>::continuation_step(VectorType          &X,
                                                  const VectorType    &dX,
                                                  VectorType          &R,
                                                  ResidualNorms       &norms,
                                                  std::vector<double> &merits,
                                                  const unsigned int   k) const
  {
    // Nonmonotone backtracking (Grippo, Lampariello and Lucidi) on
    // theta = 1/2 |R_mu|^2, which is smooth for mu > 0: the step must
    // decrease theta sufficiently below the largest of its last values, so
    // that the full steps that cross the bend of the central path (where
    // a node changes from gap to contact) are not cut to a crawl.
    merits.push_back(0.5 * R.norm_sqr());
    if (merits.size() > data.nonmonotone_window)
      merits.erase(merits.begin());
    const double theta_max = *std::max_element(merits.begin(), merits.end());

    VectorType trial;
    trial.reinit(X, /*omit_zeroing_entries=*/true);
    trial = X;
    trial.add(1., dX);
    return backtrack(
      X,
      dX,
      trial,
      R,
      norms,
      theta_max,
      /*certified=*/false,
      "the continuation's line search on the smoothed merit function",
      k);
  }


  template <typename VectorType>
  double
  SemismoothNewton<VectorType>::backtrack(VectorType        &X,
                                          const VectorType  &dX,
                                          VectorType        &trial,
                                          VectorType        &R,
                                          ResidualNorms     &norms,
                                          const double       theta_reference,
                                          const bool         certified,
                                          const std::string &search,
                                          const unsigned int k) const
  {
    double step_length = 1.;
    for (unsigned int cuts = 0;; ++cuts)
      {
        norms = residual(trial, R);
        if (certified)
          break;
        const double theta_t = 0.5 * R.norm_sqr();
        if (std::isfinite(theta_t) &&
            theta_t <=
              (1. - 2. * data.armijo_parameter * step_length) * theta_reference)
          break;
        if (cuts == data.max_line_search_steps)
          fail(search + " found no decrease after " + std::to_string(cuts) +
               " step halvings at iteration " + std::to_string(k));
        step_length *= 0.5;
        trial = X;
        trial.add(step_length, dX);
      }
    X = trial;
    return step_length;
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
    if (step.smoothing > 0)
      line << ", smoothing " << std::scientific << std::setprecision(1)
           << step.smoothing << std::defaultfloat;
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
