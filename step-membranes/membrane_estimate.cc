// step-membranes, conforming Q_p: an iterate as the estimators see it (fields,
// residual, equilibrated fluxes) and its guaranteed estimate.

#include "membrane_problem.h"

#include <cmath>

namespace StepMembranes
{
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
    Vector owned[4];
    potentials(
      X, data.mu1, data.mu2, owned, {{&it.u1, &it.u2, &it.s1, &it.s2}});
    describe_multiplier(contact_system,
                        multiplier_function,
                        X,
                        owned,
                        contact,
                        load_values,
                        data.mu1,
                        data.mu2,
                        it);
    // r_h from the residual F - E X of the rows of u1 and u2.
    residual_functions(contact_system, multiplier_function, X, it.r1, it.r2);
  }


  // The fluxes sigma_alpha ~ -mu_alpha grad u_alpha,h, equilibrated with
  // f_alpha -/+ lambda~ - r_alpha,h.
  template <int dim>
  void
  MembraneProblem<dim>::add_fluxes(Iterate &it) const
  {
    TimerOutput::Scope t(timer, "estimators: fluxes");
    equilibrate_fluxes(
      *flux_reconstruction, data.mu1, data.mu2, {nullptr, nullptr}, it);
    it.has_fluxes = true;
  }


  template <int dim>
  std::optional<double>
  MembraneProblem<dim>::predicted_eta_disc() const
  {
    return eta_disc_prediction.predict(dof_handler.n_dofs(), fe.degree, dim);
  }


  template <int dim>
  void
  MembraneProblem<dim>::remember_eta_disc(const VI::ContactEstimate &e)
  {
    if (e.complete)
      eta_disc_prediction.remember(e.eta_disc, dof_handler.n_dofs());
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
    VI::ContactEstimatorInput<dim> in =
      estimator_input(*flux_reconstruction, it, ahead);
    in.set_problem(data, domain);
    in.dual_norm             = dual_norm.get();
    in.dual_norm_undershoots = undershoots;
    in.dual_norm_remainder   = remainder;
    in.sharpen_remainder     = sharpen_remainder;
    in.without_fluxes        = !it.has_fluxes;
    AssertThrow(it.has_fluxes || &ahead == &it, ExcInternalError());
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
    if (multiplier_needs_contact_set())
      contact_nodes(contact_system, X, contact);
    describe_iterate(X, contact, it);
    return estimate(it, it, equilibrated);
  }


  // The estimate a solve ends with bounds the dual norms of the multiplier's
  // undershoot means and of the algebraic remainder with Friedrichs'
  // inequality, and for an iterate of the adaptive strategy it is the one
  // the stopping tests saw (often with a look-ahead). Equilibration bounds
  // both dual norms more sharply (doc/estimators.md), at the price of up to
  // three Poisson solves, which are worth paying once per mesh but not at
  // every check. With `Transmitted load = auto`, the multiplier of the
  // estimate is chosen by the tension ratio, and the other choice is also
  // tried here: with the transmitted load or without, the estimate is a
  // guaranteed bound of the same error (doc/reference.md, "A bound robust in
  // the tensions"). All these bounds hold for the same iterate, so the
  // smallest is reported; the stopping decisions are not affected.
  template <int dim>
  void
  MembraneProblem<dim>::sharpen_final_estimate()
  {
    if (!parameters.estimators.sharpen_final || !final_estimate)
      return;
    const bool transmits       = transmitted_load != nullptr;
    final_estimate_transmits   = transmits;
    const auto keep_if_smaller = [&](VI::ContactEstimate &&e,
                                     const bool            with_load) {
      if (e.eta >= final_estimate->eta)
        return;
      final_estimate           = std::move(e);
      final_estimate_sharpened = true;
      final_estimate_transmits = with_load;
    };
    keep_if_smaller(estimate(solution, true), transmits);

    using Choice = VI::EstimatorParameters::TransmittedLoad;
    if (parameters.estimators.transmitted_load != Choice::automatic)
      return;
    VI::EstimatorParameters other = parameters.estimators;
    other.transmitted_load        = transmits ? Choice::never : Choice::always;
    const auto &points            = flux_reconstruction->get_quadrature();
    setup_estimate_multiplier(other, data.mu1, data.mu2, points);
    // (over an obstacle, or for p >= 2 with the nodal multiplier, there is
    // no other choice)
    if ((transmitted_load != nullptr) != transmits)
      keep_if_smaller(estimate(solution, true), !transmits);
    setup_estimate_multiplier(parameters.estimators,
                              data.mu1,
                              data.mu2,
                              points);
  }


  // Explicit instantiations of this file's members.
  template void
  MembraneProblem<2>::describe_iterate(const Vector &X,
                                       const Vector &contact,
                                       Iterate      &it,
                                       const bool    fluxes) const;
  template void
  MembraneProblem<2>::describe_fields(const Vector &X,
                                      const Vector &contact,
                                      Iterate      &it) const;
  template void
  MembraneProblem<2>::add_fluxes(Iterate &it) const;
  template std::optional<double>
  MembraneProblem<2>::predicted_eta_disc() const;
  template void
  MembraneProblem<2>::remember_eta_disc(const VI::ContactEstimate &e);
  template VI::ContactEstimate
  MembraneProblem<2>::estimate(
    const Iterate                                          &it,
    const Iterate                                          &ahead,
    const bool                                              equilibrated,
    const std::function<bool(const VI::ContactEstimate &)> &sharpen_remainder)
    const;
  template VI::ContactEstimate
  MembraneProblem<2>::estimate(const Vector &X, const bool equilibrated) const;
  template void
  MembraneProblem<2>::sharpen_final_estimate();
} // namespace StepMembranes
