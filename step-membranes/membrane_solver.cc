// step-membranes, conforming Q_p: semismooth Newton on the contact system,
// with the adaptive stopping of the estimators.

#include <vi/nodal_fields.h>

#include "membrane_problem.h"

namespace StepMembranes
{
  // Semismooth Newton with the chosen strategy. Every Newton iterate gets an
  // a posteriori estimate (when the estimators are on): the one computed by
  // the linear solver's checks if the iterate is the one it accepted,
  // otherwise one computed for it. The adaptive strategy stops Newton when
  // eta_lin <= gamma_lin eta_disc.
  // The solve of a cycle, which ends the span of solve_timer and
  // solve_usage (set-up, assembly and solve). With Benchmark/Compare with
  // PETSc VI the peer starts from the same iterate (record_cycle()).
  template <int dim>
  void
  MembraneProblem<dim>::solve()
  {
    if (parameters.compare_with_petsc_vi)
      peer_initial_iterate = solution;
    solve_contact_problem();
    solve_timer.stop();
    solve_usage = VI::ProcessUsage::now(comm) - usage_at_solve_start;
  }


  template <int dim>
  void
  MembraneProblem<dim>::solve_contact_problem()
  {
    stopping.start_solve({double(dof_handler.n_dofs()), dim, fe.degree});
    final_estimate.reset();
    final_estimate_sharpened = false;
    if (parameters.nonlinear_method == Parameters::NonlinearMethod::petsc_vi)
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

    VI::SemismoothNewton<Vector> newton =
      contact_system.make_newton(parameters.output.verbose ? &pcout : nullptr);
    newton.setup_jacobian = [&](const Vector &X) {
      stopping.start_step(X);
      if (multiplier_needs_contact_set())
        contact_nodes(contact_system, X, step_contact_nodes);
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
    // With the line search (Fischer-Burmeister), the full step is taken
    // when GMRES accepted it with an estimate that meets the adaptive
    // stopping criterion (on the nested disk meshes the Armijo test cut such
    // steps to 1/32 and 1/4, three Newton steps and five estimates instead
    // of one).
    if (parameters.estimators.enabled)
      stopping.attach_criteria(newton);

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
    return stopping.solve_watched(contact_system, rhs, dX);
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


  // Explicit instantiations of this file's members.
  template void
  MembraneProblem<2>::solve();
  template void
  MembraneProblem<2>::solve_contact_problem();
  template unsigned int
  MembraneProblem<2>::solve_linearized(const Vector &rhs, Vector &dX);
  template typename VI::AdaptiveStopping<typename MembraneProblem<2>::Iterate,
                                         VI::ContactEstimate>::Hooks
  MembraneProblem<2>::stopping_hooks();
} // namespace StepMembranes
