#pragma once

#include <deal.II/base/conditional_ostream.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/linear_solvers.h>
#include <vi/parameters.h>
#include <vi/semismooth_newton.h>
#include <vi/summary.h>

#include <cmath>
#include <functional>
#include <iomanip>
#include <optional>
#include <vector>

namespace VI
{
  /// What the stopping tests read from a program's estimate.
  struct StoppingComponents
  {
    /// false: only the flux-free terms are known (Estimators/Defer fluxes):
    /// eta_lin from below, eta_alg from above; eta and eta_disc unknown.
    bool   complete = true;
    double eta = 0, eta_disc = 0, eta_lin = 0, eta_alg = 0;
    /// The part of eta_lin that the current Newton iteration controls (all
    /// of it for a steady problem).
    double eta_lin_controlled = 0;
  };


  /**
   * What a program expects of eta_disc on a new mesh before it has
   * estimated anything there: the eta_disc of the last complete estimate,
   * carried over at the optimal rate eta_disc ~ N^(-p/d) in the size N of
   * the mesh (unknowns or cells, the same measure each time).
   */
  class EtaDiscPrediction
  {
  public:
    void
    remember(const double eta_disc, const double size)
    {
      last_eta_disc = eta_disc;
      last_size     = size;
    }

    /// None before the first remember() or after an eta_disc of 0.
    std::optional<double>
    predict(const double       size,
            const unsigned int degree,
            const unsigned int dim) const
    {
      if (last_size == 0 || !(last_eta_disc > 0))
        return std::nullopt;
      return last_eta_disc *
             std::pow(last_size / size, double(degree) / double(dim));
    }

  private:
    double last_eta_disc = 0, last_size = 0;
  };


  /// One estimate during a solve, for summary.json.
  struct EstimateRecord
  {
    unsigned int       newton_step      = 0;
    unsigned int       linear_iteration = 0;
    bool               accepted         = false;
    StoppingComponents estimate;
  };


  /**
   * The records of a solve as summary.json's "iterations": one object per
   * estimate with the Newton step k, the GMRES iteration i and whether the
   * iterate was accepted; `with_eta`: eta too, or "fluxes": false for an
   * estimate of the flux-free terms only.
   */
  Json
  to_json(const std::vector<EstimateRecord> &records, const bool with_eta);


  /**
   * The adaptive inexact semismooth Newton method of [DMV20]: estimators of
   * the discretisation, linearisation and algebraic errors decide when GMRES
   * and Newton stop,
   *
   *   GMRES:  eta_alg <= gamma_alg max(eta_disc, eta_lin),
   *   Newton: eta_lin <= gamma_lin eta_disc (and the GMRES test).
   *
   * At every GMRES check (every nu iterations) the current iterate is
   * estimated with its own fluxes, and the iterate of the previous check
   * with the current one as look-ahead, which is sharper; the first iterate
   * whose estimate passes the GMRES test is accepted, and its update
   * replaces GMRES's last one. Each Newton iterate keeps the estimate it was
   * accepted with (or gets one) and the last one is the solve's estimate.
   * With the other strategies the same checks only record the estimates
   * (Estimators/At every check).
   *
   * The component knows nothing of meshes: a program plugs in its iterate
   * (what its estimators need: fields, residual, fluxes) and its estimate
   * through the hooks, as SemismoothNewton does for the linear algebra.
   */
  template <typename Iterate, typename Estimate>
  class AdaptiveStopping
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    struct Hooks
    {
      /// Make `it` describe the iterate X (its linear_iteration is set by
      /// the caller).
      std::function<void(const Vector &X, Iterate &it)> describe;
      /// The estimate of `it` with the look-ahead `ahead` (`it` itself for
      /// its own estimate).
      std::function<Estimate(const Iterate &it, const Iterate &ahead)> estimate;
      /// The estimate of a Newton iterate no GMRES check estimated.
      std::function<Estimate(const Vector &X)> estimate_iterate;
      /// What the tests read of an estimate.
      std::function<StoppingComponents(const Estimate &)> components;
      /// Optional, called after describe(): an estimate that decides the
      /// check by itself (e.g. its flux-free terms), accepted as it is.
      std::function<std::optional<Estimate>(Iterate &current)> decide_early;
      /// Optional: called with every complete estimate of a Newton iterate.
      std::function<void(const Estimate &)> on_newton_estimate;
      /// Whether estimate(it, ahead) sharpens the estimate of `it` with a
      /// later iterate; if not, each check estimates its own iterate only.
      bool look_ahead = true;
    };

    AdaptiveStopping(const NonlinearSolverParameters  &parameters,
                     const Hooks                      &hooks,
                     const dealii::ConditionalOStream *verbose = nullptr)
        : parameters(parameters)
        , hooks(hooks)
        , verbose(verbose)
    {
    }

    /**
     * The size of the problem a Newton solve works on, for the prediction
     * of gmres_schedule() across solves: the number of unknowns (or cells)
     * of the mesh, its dimension and the degree of the fields. Without
     * unknowns the prediction starts afresh.
     */
    struct SolveSize
    {
      double       unknowns = 0;
      unsigned int dim      = 0;
      unsigned int degree   = 0;
    };

    /**
     * What gmres_schedule() has learnt, to be carried across solves (and
     * by a checkpoint): eta_alg / |r| of the last check, that check's
     * threshold gamma_alg max(eta_disc, eta_lin), and the size of the
     * problem they were measured on.
     */
    struct Prediction
    {
      double alg_per_residual = 0, alg_threshold = 0, unknowns = 0;
    };

    /**
     * At the start of a Newton solve. With the size of its problem, the
     * last solve's eta_alg / |r| and threshold carry over (scaled to the new
     * mesh, below), so that GMRES's first check on a new mesh or time step
     * comes where its residual predicts a pass, not after nu iterations.
     *
     * eta_alg is a dual norm of the algebraic residual R: for its smooth
     * part, which the preconditioner leaves, it is O(1) times R, while the
     * nodal residual r_i = <R, psi_i> is O(h^d) on each of the N ~ h^(-d)
     * nodes, so |r| (Euclidean) is O(h^(d/2)) and eta_alg / |r| grows like
     * N^(1/2) (doubling per uniform refinement in 2D, as measured on the
     * nested disk meshes: 8.6 - 9.2, 17 - 21, 35, 68 - 84). The threshold
     * follows eta_disc ~ N^(-p/d). A wrong guess is cheap: the check it
     * asks for measures eta_alg / |r| afresh.
     */
    void
    start_solve(const SolveSize &size = {})
    {
      records.clear();
      final_estimate.reset();
      newton_step = 0;
      if (size.unknowns > 0 && size.dim > 0 && prediction.unknowns > 0)
        {
          const double refinement = size.unknowns / prediction.unknowns;
          prediction.alg_per_residual *= std::sqrt(refinement);
          prediction.alg_threshold *=
            std::pow(refinement, -double(size.degree) / size.dim);
          prediction.unknowns = size.unknowns;
        }
      else
        prediction = Prediction{0, 0, size.unknowns};
    }

    /// What the prediction has learnt (for a checkpoint).
    Prediction
    learnt_prediction() const
    {
      return prediction;
    }

    /// Continue with a prediction learnt before (from a checkpoint).
    void
    restore_prediction(const Prediction &learnt)
    {
      prediction = learnt;
    }

    /// At every linearisation: the Newton step k and its point X^(k-1).
    void
    start_step(const Vector &linearization_point)
    {
      ++newton_step;
      point = &linearization_point;
      step_estimate.reset();
      accepted_update.reset();
    }

    /// Whether the strategy is the adaptive one.
    bool
    adaptive() const
    {
      return parameters.strategy == Strategy::adaptive;
    }

    /// The adaptive Newton test on a (complete) estimate.
    bool
    newton_may_stop(const Estimate &e) const
    {
      const StoppingComponents c = hooks.components(e);
      return adaptive() &&
             parameters.linearisation_error_small(c.eta_disc,
                                                  c.eta_lin_controlled) &&
             parameters.algebraic_error_small(c.eta_disc,
                                              c.eta_lin_controlled,
                                              c.eta_alg);
    }

    /// The GMRES monitor of the current step (ContactSystem::solve()).
    typename Gmres<Vector>::Monitor
    gmres_monitor()
    {
      previous.reset();
      current = Iterate();
      return [this](const Vector &update, const unsigned int i) {
        return check(update, i);
      };
    }

    /**
     * Where GMRES checks besides every nu iterations (ContactSystem::solve()
     * with Linear solver/Predict checks). eta_alg measures the algebraic
     * residual of the balance rows, so the ratio eta_alg / |r| of the last
     * check predicts it from the residual |r| that GMRES knows at every
     * iteration; a check is asked where the prediction falls below a
     * hundredth of the last check's threshold gamma_alg max(eta_disc,
     * eta_lin), and GMRES has met the forcing term of the inexact strategy,
     * |r| <= Forcing term |r_0|.
     *
     * Why both: eta_alg does not see the residual of the complementarity
     * rows, which the next iterate's eta_lin holds instead. A GMRES iterate
     * that solves them poorly passes the algebraic test, and Newton then
     * creeps (step-parabolic's rising obstacle: 9 - 11 steps instead of 3
     * when checked after one iteration); the forcing term keeps each step an
     * inexact Newton step. The hundredth keeps the accepted iterates those
     * of a check every 10 iterations to a few digits (a quarter raised
     * effectivities of the test suite by up to 20 %); with a preconditioner
     * that gains a digit per iteration it costs two iterations. A solve
     * started without a size (start_solve()) knows nothing of eta_alg / |r|,
     * and its first check comes after nu iterations.
     */
    typename Gmres<Vector>::Schedule
    gmres_schedule()
    {
      return [this](const unsigned int,
                    const double residual,
                    const double initial_residual) {
        residual_now = residual;
        return adaptive() && prediction.alg_per_residual > 0 &&
               residual <= parameters.forcing_term * initial_residual &&
               prediction.alg_per_residual * residual <=
                 0.01 * prediction.alg_threshold;
      };
    }

    /// After GMRES: the update of the accepted iterate, if one was.
    std::function<bool(Vector &)>
    accepted_update_of_step()
    {
      return [this](Vector &dX) {
        if (!accepted_update)
          return false;
        dX = *accepted_update;
        return true;
      };
    }

    /**
     * Solve the linearised system of the current step, A dX = rhs, with
     * `system` (a ContactSystem) under this stopping's GMRES monitor; dX is
     * the update of the iterate it accepted, if one was.
     */
    template <typename LinearSystem>
    unsigned int
    solve_watched(LinearSystem &system, const Vector &rhs, Vector &dX)
    {
      return system.solve(
        rhs, dX, gmres_monitor(), accepted_update_of_step(), gmres_schedule());
    }

    /**
     * Let `newton` stop by this stopping: its stopping criterion is
     * newton_criterion(), and with a line search a full step that
     * step_is_certified() is taken without the Armijo test (an inexact
     * direction need not pass it, and the iterate ends the iteration with a
     * guaranteed bound).
     */
    void
    attach_criteria(SemismoothNewton<Vector> &newton)
    {
      newton.stopping_criterion = [this](const Vector     &X,
                                         const NewtonStep &step) {
        return newton_criterion(X, step);
      };
      newton.accept_full_step = [this](const Vector &) {
        return step_is_certified();
      };
    }

    /**
     * The Newton stopping criterion (SemismoothNewton::stopping_criterion):
     * record the estimate of the new iterate X (estimated afresh if GMRES
     * accepted none, or if a line search moved the iterate off the one it
     * accepted) and apply the adaptive test to it.
     */
    bool
    newton_criterion(const Vector &X, const NewtonStep &step)
    {
      if (!step_estimate || step.step_length < 1)
        step_estimate = hooks.estimate_iterate(X);
      const StoppingComponents c = hooks.components(*step_estimate);
      records.push_back({newton_step, step.linear_iterations, true, c});
      if (!c.complete)
        {
          // GMRES stopped on the flux-free terms, which say that Newton
          // goes on.
          if (verbose)
            *verbose << "             eta_lin >= " << std::scientific
                     << std::setprecision(2) << c.eta_lin
                     << ", eta_alg <= " << c.eta_alg
                     << " (no fluxes: eta_lin > gamma_lin x predicted "
                        "eta_disc)"
                     << std::defaultfloat << std::endl;
          final_estimate.reset();
          return false;
        }
      if (hooks.on_newton_estimate)
        hooks.on_newton_estimate(*step_estimate);
      final_estimate = step_estimate;
      if (verbose)
        *verbose << "             eta_disc " << std::scientific
                 << std::setprecision(2) << c.eta_disc << ", eta_lin "
                 << c.eta_lin << ", eta_alg " << c.eta_alg << std::defaultfloat
                 << std::endl;
      // The algebraic test is repeated: a step shortened by the line search
      // (Fischer-Burmeister) is not the iterate at which GMRES stopped, and
      // its residual holds (1 - t) R(X^(k-1)); such an iterate may have
      // eta_lin = 0 (feasible, lambda_h = 0) with any algebraic error. For
      // full steps it holds already.
      return newton_may_stop(*step_estimate);
    }

    /**
     * Whether GMRES accepted this step's iterate with a complete estimate
     * that ends the iteration (SemismoothNewton::accept_full_step): such an
     * iterate is certified, and the Armijo test of the line search, which
     * an inexact direction need not pass, is not asked.
     */
    bool
    step_is_certified() const
    {
      return step_estimate && hooks.components(*step_estimate).complete &&
             newton_may_stop(*step_estimate);
    }

    /// The estimate of the last Newton iterate, if it has a complete one.
    std::optional<Estimate> final_estimate;
    /// Every estimate of the solve, in order.
    std::vector<EstimateRecord> records;
    /// The current Newton step k (1, 2, ...; 0 before the first).
    unsigned int newton_step = 0;

  private:
    // One GMRES check at iteration i with the current update.
    bool
    check(const Vector &update, const unsigned int i)
    {
      Vector X(*point);
      X += update;
      hooks.describe(X, current);
      current.linear_iteration = i;
      if (hooks.decide_early)
        if (std::optional<Estimate> e = hooks.decide_early(current))
          {
            record(i, *e);
            learn(hooks.components(*e));
            accept(current, *e);
            return true;
          }

      const Estimate own = hooks.estimate(current, current);
      record(i, own);
      learn(hooks.components(own));
      if (adaptive() && gmres_may_stop(own))
        {
          accept(current, own);
          return true;
        }
      if (previous && hooks.look_ahead)
        {
          const Estimate e = hooks.estimate(*previous, current);
          record(previous->linear_iteration, e);
          if (adaptive() && gmres_may_stop(e))
            {
              accept(*previous, e);
              return true;
            }
        }
      previous = std::move(current);
      return false;
    }

    bool
    gmres_may_stop(const Estimate &e) const
    {
      const StoppingComponents c = hooks.components(e);
      return parameters.algebraic_error_small(c.eta_disc,
                                              c.eta_lin_controlled,
                                              c.eta_alg);
    }

    // What gmres_schedule() predicts from: eta_alg per unit of GMRES's
    // residual at this check, and the threshold of its GMRES test.
    void
    learn(const StoppingComponents &c)
    {
      if (residual_now > 0)
        prediction.alg_per_residual = c.eta_alg / residual_now;
      // A flux-free estimate has no eta_disc (NaN): its test is against
      // eta_lin.
      prediction.alg_threshold =
        parameters.algebraic_threshold(std::isnan(c.eta_disc) ? 0. : c.eta_disc,
                                       c.eta_lin_controlled);
    }

    void
    record(const unsigned int i, const Estimate &e)
    {
      records.push_back({newton_step, i, false, hooks.components(e)});
    }

    void
    accept(const Iterate &it, const Estimate &e)
    {
      accepted_update = it.X;
      *accepted_update -= *point;
      step_estimate = e;
    }

    const NonlinearSolverParameters  &parameters;
    const Hooks                       hooks;
    const dealii::ConditionalOStream *verbose;

    const Vector           *point = nullptr;
    std::optional<Estimate> step_estimate;
    std::optional<Vector>   accepted_update;
    std::optional<Iterate>  previous;
    Iterate                 current;
    double                  residual_now = 0;
    Prediction              prediction;
  };
} // namespace VI
