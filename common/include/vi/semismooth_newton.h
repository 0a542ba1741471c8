#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace VI
{
  /// Nonlinear solver/Continuation method: how Newton follows the central
  /// path x y = mu^2 of the complementarity pairs once the active set stalls.
  enum class ContinuationMethod
  {
    interior_point, ///< primal-dual, Mehrotra's predictor-corrector
    smoothing,      ///< semismooth Newton on the smoothed C-function C_mu
  };

  class ComplementarityFunction;
  struct NonlinearSolverParameters;

  /**
   * Norms of the two parts of the semismooth Newton residual
   * R(X) = [E X - F ; C(X)], each made dimensionless by the problem:
   * `equations` relative to the load |F|, `complementarity` as the C-function
   * of the pairs scaled by the size of their arguments (see ContactRows).
   */
  struct ResidualNorms
  {
    double equations       = 0.;
    double complementarity = 0.;
    /// That of the rows Newton solves: the smoothed C-function's during the
    /// continuation (SemismoothNewton::set_smoothing), else complementarity.
    double smoothed_complementarity = 0.;

    bool
    is_finite() const;

    /// "<equations_name> e, complementarity c, tolerance t": the residuals
    /// against the tolerance in the message of a solver that failed.
    std::string
    describe(const std::string &equations_name, const double tolerance) const;
  };


  /**
   * The active set of one linearisation: the complementarity rows whose
   * element of the generalised Jacobian enforces the constraint (for the
   * min-function, semismooth Newton is the primal-dual active set method,
   * and these sets are its iterates), and how many rows changed branch
   * since the previous linearisation.
   */
  struct ActiveSetChange
  {
    unsigned long long active   = 0;
    unsigned long long switched = 0; ///< 0 at the first linearisation
  };


  /// What one semismooth Newton step did.
  struct NewtonStep
  {
    unsigned int  iteration = 0;  ///< k = 1, 2, ...
    ResidualNorms residual  = {}; ///< after the step
    /// < 1 when the line search cut it; 0 when the watchdog returned to
    /// its reference iterate (AdditionalData::watchdog_steps)
    double       step_length       = 1.;
    unsigned int linear_iterations = 0;
    /// The smoothing parameter mu of the step's rows (0: the C-function)
    double smoothing = 0.;
    /// of the step's linearisation, if the problem reports it (active_set)
    bool            has_active_set = false;
    ActiveSetChange active_set     = {};
  };


  /**
   * One line of progress output for a step: "residuals <equations>
   * (equations), <complementarity> (complementarity)", then the iterations
   * of the linear solver (named by `linear_solver`, if any), the step length
   * if cut, and the active set if known.
   */
  std::string
  describe(const NewtonStep &step, const std::string &linear_solver = "linear");


  struct NewtonReport
  {
    unsigned int            iterations        = 0;
    unsigned int            linear_iterations = 0;
    ResidualNorms           initial_residual  = {};
    ResidualNorms           final_residual    = {};
    std::vector<NewtonStep> steps;
    /// The step after which the stalled active set started the
    /// continuation (0: plain semismooth Newton converged by itself)
    unsigned int continuation_start = 0;
  };


  /**
   * Semismooth Newton method for a nonsmooth system R(X) = 0 whose rows are
   * the (linear or nonlinear) balance equations E(X) = F and the
   * complementarity rows C(X) = 0. At step k it solves
   *
   *   A^{k-1} dX = -R(X^{k-1}),   A^{k-1} = [E' ; J_C(X^{k-1})],
   *
   * with J_C an element of the generalised Jacobian, which for the linear
   * membrane problems is the paper's A^{k-1} X^k = B^{k-1} written for the
   * update. Optionally, the step is cut back until the merit function
   * theta = 1/2 |R|^2 decreases by the Armijo factor (1 - 2 sigma t): this is
   * the globalisation of Fischer-Burmeister, whose merit function is
   * continuously differentiable, for nonlinear balance equations
   * (AdditionalData::with_merit_line_search).
   *
   * Plain semismooth Newton-min is the primal-dual active set method, and on
   * a fine mesh it (and Newton-Fischer-Burmeister with full steps) can need a
   * number of steps that grows with the mesh: where the load presses the
   * membranes together but the boundary data hold them apart, the active set
   * of a cold start (where the membranes solved without contact penetrate,
   * ContactRows::set_linearisation_point) covers more than the contact set
   * and loses one ring of nodes per step (O(1/h) steps), since
   * each step only sees the multiplier change sign next to the free nodes. No
   * line search can help, the direction itself is too local. A stalled
   * active set (see AdditionalData::stall_ratio) starts a continuation
   * instead, along the central path x_i y_i = mu^2 of the scaled pairs
   * (gap, multiplier), on which every row couples both: a step moves the
   * contact zone by a distance of order one, not a mesh width. Two methods
   * follow it (AdditionalData::continuation_method):
   * - the interior-point method (default; the problem provides
   *   interior_point): x, y > 0 throughout, each step Mehrotra's
   *   predictor-corrector pair of solves with one Jacobian, the centring
   *   chosen by how far the predictor gets (see interior_point_phase()),
   *   and with exact directions a centrality corrector (centre());
   *   it ends when the residuals of C are below the tolerance;
   * - the smoothing (the problem provides set_smoothing()): semismooth
   *   Newton on the smoothed C-function C_mu (ComplementarityFunction::
   *   smoothed_value), mu lowered with the length of each step (see
   *   solve()), a nonmonotone line search on 1/2 |R_mu|^2, and mu stopped at
   *   half the tolerance, where every point of the path solves the
   *   unsmoothed system to the tolerance (|C| <= mu there).
   * doc/reference.md, "Continuation", says why the first is the default.
   * Where plain Newton converges, nothing of this runs.
   *
   * The class knows nothing of meshes or finite elements: a problem plugs in
   * through the three callbacks below, in the manner of deal.II's interfaces
   * to nonlinear solvers (SUNDIALS::KINSOL, NonlinearSolverSelector). It
   * stops when both parts of the residual are below the tolerance, and throws
   * SolverFailure, with the reason, when the iteration limit is reached, a
   * NaN appears or the line search finds no decrease.
   */
  template <typename VectorType>
  class SemismoothNewton
  {
  public:
    struct AdditionalData
    {
      AdditionalData() = default;
      /// What `Nonlinear solver` asks for in a contact problem, whose
      /// balance equations are linear: its iteration limit, tolerance and
      /// `Continuation`, full steps with either C-function, and the name
      /// "semismooth Newton-<C>". A merit line search does not help there:
      /// the stalls are those of the active set, which only the
      /// continuation cures (doc/stress.md, "Cold starts").
      AdditionalData(const NonlinearSolverParameters &parameters,
                     const ComplementarityFunction   &C);
      /// The same, but with the backtracking line search and its watchdog
      /// (`Watchdog steps`) if C has a smooth merit function
      /// (Fischer-Burmeister), and without the continuation: for nonlinear
      /// balance equations (step-twophase), where a full step can leave
      /// the region in which Newton's model holds.
      static AdditionalData
      with_merit_line_search(const NonlinearSolverParameters &parameters,
                             const ComplementarityFunction   &C);

      unsigned int max_iterations        = 50;
      double       tolerance             = 1e-10;
      bool         line_search           = false;
      unsigned int max_line_search_steps = 30;
      double       armijo_parameter      = 1e-4;
      /// Watchdog of the line search: up to this many full steps are taken
      /// without the Armijo test against the reference iterate (the last
      /// one that passed it); if the merit function has not fallen below
      /// the reference's by then, the iteration returns to the reference
      /// and backtracks from there. 0: every step is tested.
      unsigned int watchdog_steps = 0;
      /// Used in failure messages, e.g. "semismooth Newton-min".
      std::string name = "semismooth Newton";
      /// The active set stalls when its steps keep switching rows without
      /// converging. A crawl: in each of the last `crawl_steps` steps it
      /// switched rows, and in each window of `average_steps` steps among
      /// them the complementarity residual fell by less than 1 /
      /// `stall_ratio` in every step (superlinear convergence shrinks it by
      /// far more; a ring crawl moves the contact zone by one mesh width a
      /// step) and the last step switched at least `crawl_pace` times as
      /// many rows as the one before (a ring is about as long as the last,
      /// while a converging iteration switches ever fewer rows even where
      /// its max-norm residual falls slowly). Three steps: six cost
      /// seed-smooth's cold start on 256 x 256 cells eight more
      /// Fischer-Burmeister steps (measured with the residual's scale of
      /// the multiplier on the path). The pace spares the runs that
      /// converge by themselves: from the data on the same mesh, 680, 632,
      /// 424, 200 switched rows, then convergence in 7 steps, where the
      /// continuation took 12. Not all of them: the disk from the data on
      /// 49409 nodes switches 984, 944, 904 rows and would converge in 6
      /// steps, but takes 10. With exact directions also a cycle: over
      /// `cycle_steps` steps the smallest residual stays above
      /// `stall_ratio` times the smallest before them. With inexact ones,
      /// see `inexact_stall`.
      /// Under the adaptive strategy (AdditionalData(parameters, C)) a
      /// crawl must last `adaptive_crawl_steps` steps (four windows): its
      /// estimators often end the crawl first, where its error is below the
      /// discretisation error, while an iteration they stop on the
      /// continuation's path leaves a smoothed contact zone to the next mesh.
      /// On the [DMV20] disk with nested iteration, three steps started the
      /// continuation on the first mesh, and the next mesh inherited it: 8 and
      /// 7 Newton steps instead of 6 and 2, 13 instead of 3 on 591363 unknowns
      /// (measured with the residual's scale of the multiplier on the path).
      static constexpr unsigned int adaptive_crawl_steps = 6;
      double                        stall_ratio          = 0.5;
      unsigned int                  average_steps        = 3;
      unsigned int                  crawl_steps          = 3;
      double                        crawl_pace           = 0.75;
      unsigned int                  cycle_steps          = 6;
      /// Whether a window whose residual has not fallen by 1 / stall_ratio
      /// also crawls, whatever its steps and pace (the inexact and adaptive
      /// strategies). Inexact directions can leave a ring's residual in
      /// place while the switched rows fall (inexact, 1e6 unknowns per
      /// field: 211107, 31060, 4682 rows at a residual of 3.4e-4, 3.2e-4,
      /// 3.1e-4: the continuation starts after step 5 instead of 7), make
      /// the residual jump
      /// within the window (`cold-start-inexact`: 9.9e-3, 2.1e-2, 9.8e-3;
      /// 24 steps instead of 26), or make the active set cycle with
      /// switched rows that vary (`cold-start-adaptive`: 2117, 1870, 2335,
      /// 1123 rows; the cycle test of exact directions waits a step
      /// longer). Exact directions converge so: HHO P4 with nested
      /// iteration on 256 cells, 372, 328, 282 rows at 3.4e-5, 1.2e-5,
      /// 1.9e-5, converges in 11 steps, 20 with the window; HHO P1 on free
      /// edges, 49, 40, 18 rows at 7.8e-7, 3.5e-7, 6.1e-7, in the next
      /// step.
      bool inexact_stall = false;
      /// Whether a stalled active set starts the continuation (if the
      /// problem provides the hooks of continuation_method). From
      /// `Nonlinear solver`: its `Continuation` and `Continuation method`.
      bool               continuation = true;
      ContinuationMethod continuation_method =
        ContinuationMethod::interior_point;
      /// The interior-point method starts at mu^2 = the square of this
      /// factor times the complementarity residual: every pair is put on
      /// x y = mu^2, keeping its larger member. Started at the residual
      /// itself (factor 1), the wrongly active rows sit so close to the
      /// boundary that the first steps are cut to a few percent.
      double interior_point_start = 10.;
      /// Each interior-point step goes at least this fraction of the way to
      /// the boundary x = 0 or y = 0 of the first pair it would cross, and
      /// 1 - mu of it once that is larger (superlinear convergence at the
      /// end).
      double fraction_to_boundary = 0.99;
      /// At most this many centrality correctors per interior-point step
      /// (Gondzio's; see centre()). Each costs a solve with the step's
      /// Jacobian and shortens the path by up to two steps (cold starts on
      /// FEM, SIPG, HHO meshes: 0 - 2 of 17 - 27 steps); with
      /// inexact directions a solve costs as much as the direction's and
      /// the strategies do without (`cold-start-inexact`: 23 steps instead
      /// of 24 for 1.3 times the GMRES iterations).
      unsigned int centrality_correctors = 1;
      /// Factor by which a full step of the continuation reduces mu.
      double smoothing_reduction = 0.1;
      /// mu stays above this factor times the smoothed residual.
      double neighbourhood_factor = 0.1;
      /// The continuation's line search compares with the largest merit
      /// of this many last steps (1: monotone).
      unsigned int nonmonotone_window = 5;
      /// A stagnated iteration: this many full steps of plain Newton in a
      /// row switched no row of the active set and each left the residual
      /// above stagnation_ratio times the one before. With the active set
      /// found, one step solves the linear system of that set, so a residual
      /// that stays above the tolerance is not reduced by further steps
      /// (the accuracy of the linear solves, or a row the steps do not
      /// move): Newton fails at once instead of at the iteration limit.
      unsigned int stagnation_steps = 3;
      double       stagnation_ratio = 0.9;
    };

    explicit SemismoothNewton(const AdditionalData &data);

    /// Compute R = R(X) and return its two dimensionless norms.
    std::function<ResidualNorms(const VectorType &X, VectorType &R)> residual;

    /// Assemble the generalised Jacobian A at X.
    std::function<void(const VectorType &X)> setup_jacobian;

    /**
     * Solve A dX = rhs with the Jacobian of the last setup_jacobian() call;
     * return the number of iterations of the linear solver (0 for a direct
     * solver). Throws SolverFailure if the linear solver fails.
     */
    std::function<unsigned int(const VectorType &rhs, VectorType &dX)>
      solve_with_jacobian;

    /**
     * Optional: the active set of the Jacobian of the last setup_jacobian()
     * call, compared with the previous one unless `first` (see
     * ActiveSetChange); reported with each step.
     */
    std::function<ActiveSetChange(const VectorType &X, bool first)> active_set;

    /**
     * Optional: make residual() and setup_jacobian() use the smoothed
     * C-function C_mu (mu > 0) from now on, with scales taken at X, or C
     * again (mu = 0). A problem that provides it is recovered from a
     * stalled active set by the continuation described above.
     */
    std::function<void(const VectorType &X, double mu)> set_smoothing;

    /**
     * Optional: what the interior-point continuation needs of the
     * complementarity rows, each pair taken in scales U of the gap and B of
     * the multiplier frozen when it starts (x = a / U, y = b / B, as
     * set_smoothing does).
     */
    struct InteriorPointRows
    {
      /// Freeze the scales and put every pair of X on x y = mu2, keeping
      /// its larger member (the smaller becomes mu2 / larger, the larger at
      /// least sqrt(mu2)); from now on residual() and setup_jacobian() use
      /// the rows x y - t_i (with target t_i = 0 until set_targets()),
      /// divided by x + y at the point of evaluation.
      std::function<void(VectorType &X, double mu2)> enter;
      /// t_i = target - dx_i dy_i (Mehrotra's corrector), or t_i = target
      /// if dX is null.
      std::function<void(const VectorType *dX, double target)> set_targets;
      /// Optional (Gondzio's centrality correctors): add to each t_i what
      /// moves the pair's product at X + s dX into [target / 10,
      /// 10 target].
      std::function<void(const VectorType &X,
                         const VectorType &dX,
                         double            s,
                         double            target)>
        centre;
      /// Make each pair's linearised row y dx + x dy = t - x y hold exactly
      /// in dX, by the increment of its smaller member: an inexact solve's
      /// error then stays in the other rows, where it is of the size of
      /// the forcing term, and not in a row of a pair near the boundary,
      /// where it would block the step.
      std::function<void(const VectorType &X, VectorType &dX)> solve_rows;
      /// {the largest t with x + t dx >= 0 and y + t dy >= 0 for all pairs
      /// (+inf if none), the mean of (x + s dx)(y + s dy)}
      std::function<std::array<double, 2>(const VectorType &X,
                                          const VectorType &dX,
                                          double            s)>
        step_to_boundary;
      /// Back to the rows of C.
      std::function<void()> leave;
    };
    InteriorPointRows interior_point;

    /// Optional: called after every accepted step (progress output).
    std::function<void(const NewtonStep &)> monitor;

    /**
     * Optional: a stopping criterion of the problem's own, asked after every
     * step with the new iterate (e.g. the adaptive criterion
     * eta_lin <= gamma_lin eta_disc of a posteriori estimators). Newton stops
     * when it returns true, or when the residuals are below the tolerance.
     */
    std::function<bool(const VectorType &X, const NewtonStep &)>
      stopping_criterion;

    /**
     * Optional, with the line search: whether the full step `trial` = X +
     * dX is taken without the Armijo test. The line search globalises the
     * iteration; an iterate that the problem certifies as final (e.g. one
     * whose a posteriori estimate meets the adaptive stopping criterion)
     * needs no globalisation, and an inexact direction need not decrease
     * the residual's merit function even where it ends the iteration.
     */
    std::function<bool(const VectorType &trial)> accept_full_step;

    /// Iterate from the initial guess X; on return X is the converged iterate.
    NewtonReport
    solve(VectorType &X) const;

  private:
    /// The watchdog's reference iterate and merit, the full steps taken
    /// since it without the test, and whether the iteration has just
    /// returned to it (then the next step backtracks).
    struct Watchdog
    {
      VectorType   X_reference;
      double       theta_reference = 0;
      unsigned int relaxed_steps   = 0;
      bool         returned        = false;

      /// X, with merit theta, is the new reference.
      void
      restart(const VectorType &X, const double theta)
      {
        if (X_reference.size() != X.size())
          X_reference.reinit(X, /*omit_zeroing_entries=*/true);
        X_reference     = X;
        theta_reference = theta;
        relaxed_steps   = 0;
        returned        = false;
      }
    };

    /// X += t dX with the step length t of plain semismooth Newton: 1, or
    /// that of the line search and its watchdog; R and norms at the new X.
    double
    plain_step(VectorType        &X,
               const VectorType  &dX,
               VectorType        &R,
               ResidualNorms     &norms,
               Watchdog          &watchdog,
               const unsigned int k) const;

    /// X += t dX on the smoothed system, with t halved until 1/2 |R|^2
    /// falls below the largest of its last values (`merits`).
    double
    continuation_step(VectorType          &X,
                      const VectorType    &dX,
                      VectorType          &R,
                      ResidualNorms       &norms,
                      std::vector<double> &merits,
                      const unsigned int   k) const;

    /// X = `trial` = X + t dX with t = 1, 1/2, 1/4, ... until 1/2 |R|^2
    /// <= (1 - 2 armijo_parameter t) theta_reference, or t = 1 if
    /// `certified`; R and norms at the new X. `search` names the search in
    /// the failure message.
    double
    backtrack(VectorType        &X,
              const VectorType  &dX,
              VectorType        &trial,
              VectorType        &R,
              ResidualNorms     &norms,
              const double       theta_reference,
              const bool         certified,
              const std::string &search,
              const unsigned int k) const;

    /// Whether the last steps switched rows of the active set and crawled
    /// or cycled (AdditionalData::stall_ratio).
    bool
    stalled(const NewtonReport &report) const;

    /// Whether the last stagnation_steps steps stagnated
    /// (AdditionalData::stagnation_steps).
    bool
    stagnated(const NewtonReport &report) const;

    bool
    converged(const ResidualNorms &norms) const;

    /// Fails if step k would exceed the iteration limit.
    void
    check_iteration_limit(const unsigned int   k,
                          const ResidualNorms &norms) const;

    /// setup_jacobian(X), and the record of the step from X with the
    /// active set of the new Jacobian (compared with the last unless
    /// `first`).
    NewtonStep
    linearise(const VectorType &X, const bool first) const;

    /// Whether a stalled active set can start the continuation: the
    /// problem provides the rows of the chosen method.
    bool
    can_continue() const;

    /// The interior-point continuation from the stalled iterate X, with
    /// R and norms at X: its steps are k + 1, k + 2, ... until the residuals
    /// of C are below the tolerance or the problem's criterion is met;
    /// X, R and norms are then those of its last iterate, with the rows of
    /// C again.
    void
    interior_point_phase(VectorType    &X,
                         VectorType    &R,
                         ResidualNorms &norms,
                         NewtonReport  &report,
                         unsigned int   k) const;

    /// Up to AdditionalData::centrality_correctors correctors of the
    /// interior-point direction dX at X, whose pairs aim at x y = target:
    /// each is computed in dX_trial by `direction` (a solve with the step's
    /// Jacobian for -R, R being re-evaluated here with the new targets) and
    /// replaces dX if it goes further. Returns the linear iterations.
    unsigned int
    centre(const VectorType                                &X,
           VectorType                                      &R,
           VectorType                                      &dX,
           VectorType                                      &dX_trial,
           double                                           target,
           const std::function<unsigned int(VectorType &)> &direction) const;

    [[noreturn]] void
    fail(const std::string &reason) const;

    AdditionalData data;
  };
} // namespace VI
