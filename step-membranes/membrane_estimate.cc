// step-membranes, conforming Q_p: an iterate as the estimators see it (fields,
// residual, equilibrated fluxes) and its guaranteed estimate.

#include <deal.II/base/parallel.h>
#include <deal.II/fe/fe_values.h>

#include <vi/cell_function_values.h>
#include <vi/nodal_fields.h>

#include "membrane_problem.h"

#include <algorithm>
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

    // lambda_h: <lambda_h, psi_i>_h = D_i X3_i = m_i.
    Vector moments(owned_nodes, comm);
    VI::NodalFields::extract(X, multiplier, moments);
    moments.scale(contact_system.coupling());

    // The transmitted load g on the joined cells J takes its moments G
    // from lambda_h, and the cone reconstruction joins the membranes on J.
    typename VI::TransmittedLoad<dim>::Split split;
    const Vector                            *offset = nullptr;
    Vector                                   load_nodes;
    if (transmitted_load)
      {
        transmitted_load->split(data.mu1,
                                data.mu2,
                                load_values[0],
                                load_values[1],
                                contact,
                                it.s1,
                                it.s2,
                                split);
        offset           = &split.node_moments;
        it.joined_cells  = std::move(split.joined_cells);
        Vector joined[2] = {owned[2], owned[3]};
        VI::join_at_nodes(
          data.mu1, data.mu2, split.joined_nodes, joined[0], joined[1]);
        for (unsigned int a = 0; a < 2; ++a)
          hanging_node_constraints.distribute(joined[a]);
        ghosted_nodes.copy(joined[0], it.s1_joined);
        ghosted_nodes.copy(joined[1], it.s2_joined);
        // (the moments shared on the cells of J)
        ghosted_nodes.copy(split.load_nodes, load_nodes);
      }

    if (cell_multiplier)
      {
        // 2 <lambda_h, u1h - u2h>_h = 2 sum_i m_i (u1h - u2h)(x_i).
        Vector gap(owned[0]);
        gap -= owned[1];
        it.complementarity = 2. * (moments * gap);
        Vector m, shifted(moments);
        if (offset)
          shifted -= *offset;
        ghosted_nodes.copy(shifted, m);
        // (on the joined cells with the transmitted load)
        const Vector &share_on = transmitted_load ? load_nodes : contact;
        cell_multiplier->distribute(m, share_on, it.lambda_cells);
        for (double &value : moments)
          value = std::max(value, 0.);
        if (offset)
          moments -= *offset;
        ghosted_nodes.copy(moments, m);
        cell_multiplier->distribute(m, share_on, it.lambda_nonnegative_cells);
      }
    else
      multiplier_function.with_nonnegative_part(moments,
                                                it.lambda,
                                                it.lambda_nonnegative,
                                                offset);

    // r_h from the residual F - E X of the rows of u1 and u2.
    residual_functions(contact_system, multiplier_function, X, it.r1, it.r2);
  }


  template <int dim>
  void
  MembraneProblem<dim>::add_fluxes(Iterate &it) const
  {
    TimerOutput::Scope t(timer, "estimators: fluxes");
    Vector            *r[2] = {&it.r1, &it.r2};

    // The fluxes: sigma_alpha ~ -mu_alpha grad u_alpha,h, equilibrated with
    // f_alpha -/+ lambda_h - r_alpha,h; for p = 1 the multiplier and the
    // residual enter each patch as the constants of its vertex (lumping).
    const bool    lumped  = fe.degree == 1;
    const Vector *u[2]    = {&it.u1, &it.u2};
    const double  mu[2]   = {data.mu1, data.mu2};
    const double  sign[2] = {-1., 1.}; // (-1)^alpha

    typename VI::FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = 2;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of the potential and the multiplier's and
      // residual's values
      return [&,
              values_of = std::make_shared<FEValues<dim>>(
                *mapping,
                fe,
                flux_reconstruction->get_quadrature(),
                update_values | update_gradients),
              lambda_values = std::vector<double>(quadrature.size()),
              g_values      = std::vector<double>(quadrature.size()),
              r_values      = std::vector<double>(quadrature.size()),
              coefficients  = std::vector<double>()](const auto &cell,
                                                    auto       &flux,
                                                    auto &source) mutable {
        typename DoFHandler<dim>::active_cell_iterator dof_cell(&triangulation,
                                                                cell->level(),
                                                                cell->index(),
                                                                &dof_handler);
        FEValues<dim>                                 &values = *values_of;
        values.reinit(dof_cell);
        // g on the joined cells, zero elsewhere
        const unsigned int index  = cell->active_cell_index();
        const bool         joined = transmitted_load && it.joined_cells[index];
        if (joined)
          VI::TransmittedLoad<dim>::cell_values(data.mu1,
                                                data.mu2,
                                                load_values[0],
                                                load_values[1],
                                                index,
                                                g_values);
        else
          std::fill(g_values.begin(), g_values.end(), 0.);
        if (cell_multiplier)
          cell_multiplier->values(it.lambda_cells,
                                  cell->active_cell_index(),
                                  lambda_values);
        else if (!lumped)
          VI::cell_function_values(
            values, dof_cell, it.lambda, coefficients, &lambda_values);
        for (unsigned int a = 0; a < 2; ++a)
          {
            VI::cell_function_values(
              values, dof_cell, *u[a], coefficients, nullptr, &flux[a]);
            for (auto &F : flux[a])
              F *= mu[a];
            std::copy_n(load_values[a].begin() +
                          cell->active_cell_index() * source[a].size(),
                        source[a].size(),
                        source[a].begin());
            // (p = 1 lumps the residual, and lambda_h unless the cellwise
            // multiplier takes it)
            const bool multiplier_at_points = cell_multiplier || !lumped;
            for (unsigned int q = 0; q < source[a].size(); ++q)
              source[a][q] -=
                sign[a] *
                (g_values[q] + (multiplier_at_points ? lambda_values[q] : 0.));
            if (!lumped)
              {
                VI::cell_function_values(
                  values, dof_cell, *r[a], coefficients, &r_values);
                for (unsigned int q = 0; q < source[a].size(); ++q)
                  source[a][q] -= r_values[q];
              }
          }
      };
    };
    if (lumped && cell_multiplier)
      // (the multiplier at the points, the residual lumped)
      sources.vertex_source = [&](const unsigned int vertex,
                                  const unsigned int alpha) {
        return -(*r[alpha])(vertex_dofs[vertex]);
      };
    else if (lumped)
      sources.vertex_source = lumped_sources(it.lambda, it.r1, it.r2);
    flux_reconstruction->reconstruct(sources, {&it.sigma1, &it.sigma2});
    it.has_fluxes = true;
  }


  template <int dim>
  std::optional<double>
  MembraneProblem<dim>::predicted_eta_disc() const
  {
    if (last_eta_disc_dofs == 0 || !(last_eta_disc > 0))
      return std::nullopt;
    // eta_disc ~ N^(-p/d) at the optimal rate
    return last_eta_disc *
           std::pow(double(last_eta_disc_dofs) / double(dof_handler.n_dofs()),
                    double(fe.degree) / dim);
  }


  template <int dim>
  void
  MembraneProblem<dim>::remember_eta_disc(const VI::ContactEstimate &e)
  {
    if (e.complete)
      {
        last_eta_disc      = e.eta_disc;
        last_eta_disc_dofs = dof_handler.n_dofs();
      }
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
    in.mu1                   = data.mu1;
    in.mu2                   = data.mu2;
    in.f1                    = data.f1.get();
    in.f2                    = data.f2.get();
    in.f1_values             = &load_values[0];
    in.f2_values             = &load_values[1];
    in.g1                    = data.g1.get();
    in.g2                    = data.g2.get();
    in.friedrichs_constant   = VI::friedrichs_constant(geometry);
    in.dual_norm             = dual_norm.get();
    in.dual_norm_undershoots = undershoots;
    in.dual_norm_remainder   = remainder;
    in.sharpen_remainder     = sharpen_remainder;
    in.without_fluxes        = !it.has_fluxes;
    AssertThrow(it.has_fluxes || &ahead == &it, ExcInternalError());
    if (cell_multiplier)
      {
        in.cell_multiplier          = cell_multiplier.get();
        in.lambda_cells             = &it.lambda_cells;
        in.lambda_nonnegative_cells = &it.lambda_nonnegative_cells;
        in.lambda_ahead_cells       = &ahead.lambda_cells;
        in.complementarity          = it.complementarity;
      }
    if (transmitted_load)
      {
        in.joined_cells       = &it.joined_cells;
        in.joined_cells_ahead = &ahead.joined_cells;
        in.s1_joined          = &it.s1_joined;
        in.s2_joined          = &it.s2_joined;
      }
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
    if (cell_multiplier || transmitted_load)
      contact_nodes(X, contact);
    describe_iterate(X, contact, it);
    return estimate(it, it, equilibrated);
  }


  // The estimate a solve ends with bounds the dual norms of the multiplier's
  // undershoot means and of the algebraic remainder with Friedrichs'
  // inequality, and for an iterate of the adaptive strategy it is the one
  // the stopping tests saw (often with a look-ahead). Equilibration bounds
  // both dual norms more sharply (doc/estimators.md), at the price of up to
  // three Poisson solves, which are worth paying once per mesh but not at
  // every check. Both bounds are guaranteed for the same iterate, so the
  // smaller one is reported; the stopping decisions are not affected.
  template <int dim>
  void
  MembraneProblem<dim>::sharpen_final_estimate()
  {
    if (!parameters.estimators.sharpen_final || !final_estimate)
      return;
    VI::ContactEstimate sharpened = estimate(solution, true);
    final_estimate_sharpened      = sharpened.eta < final_estimate->eta;
    if (final_estimate_sharpened)
      final_estimate = std::move(sharpened);
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
