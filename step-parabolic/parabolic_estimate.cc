// step-parabolic: an iterate as the estimators see it and its guaranteed
// space-time estimate on I_n.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/nodal_fields.h>

#include "parabolic_problem.h"

#include <cmath>

namespace StepParabolic
{
  // The iterate as the estimators need it (see step-membranes): u_h, s_h,
  // lambda~ (lambda_h, its part from nonnegative coefficients, with the
  // transmitted load of the loads f(t_n) - d_t u_h), the residual r_h
  // (<r_h, psi_i>_h = (F - E X)_i), d_t u_h = (u_h - u_h^(n-1)) / dt_n, and
  // the fluxes equilibrated with f(t_n) - d_t u_h -/+ lambda~ - r_h.
  template <int dim>
  void
  ParabolicProblem<dim>::describe_iterate(const Vector &X,
                                          const Vector &contact,
                                          Iterate      &it) const
  {
    TimerOutput::Scope t(timer, "estimators: fluxes");
    it.X = X;

    potentials(
      X, data.mu1, data.mu2, it.owned, {{&it.u1, &it.u2, &it.s1, &it.s2}});

    // d_t u_h, from the owned values of u_h^(n-1).
    Vector function(owned_nodes, comm);
    for (const auto &[u, old, target] :
         {std::tuple<const Vector *, const Vector *, Vector *>{&it.owned[0],
                                                               &previous_u1,
                                                               &it.dt_u1},
          {&it.owned[1], &previous_u2, &it.dt_u2}})
      {
        for (const types::global_dof_index i : owned_nodes)
          function(i) = ((*u)(i) - (*old)(i)) / time_step;
        function.compress(VectorOperation::insert);
        ghosted_nodes.copy(function, *target);
      }

    const Vector       *dt_u[2] = {&it.dt_u1, &it.dt_u2};
    std::vector<double> step_loads[2];
    if (transmitted_load)
      loads_of_step(dt_u, step_loads);
    describe_multiplier(contact_system,
                        multiplier_function,
                        X,
                        it.owned,
                        contact,
                        transmitted_load ? step_loads : load_values,
                        data.mu1,
                        data.mu2,
                        it);
    if (cell_multiplier)
      {
        // 2 <lambda_h^n, u1h^(n-1) - u2h^(n-1)>_h = 2 sum_i m_i (gap at x_i)
        Vector moments(owned_nodes, comm), gap(previous_owned[0]);
        VI::NodalFields::extract(X, multiplier, moments);
        moments.scale(contact_system.coupling());
        gap -= previous_owned[1];
        it.previous_complementarity = 2. * (moments * gap);
      }

    residual_functions(contact_system, multiplier_function, X, it.r1, it.r2);
    equilibrate_fluxes(*flux_reconstruction, data.mu1, data.mu2, dt_u, it);
  }


  template <int dim>
  std::vector<std::pair<double, double>>
  ParabolicProblem<dim>::time_points() const
  {
    // The trapezoidal rule. The integrand is convex in t when s~_ht is
    // linear in t, which holds at the end points (where the cone
    // reconstruction is computed), so the rule bounds the integral from
    // above; for the temporal part |||u_h^n - u_h^(n-1)|||^2 it gives 1/2
    // where the exact integral has 1/3.
    return {{0., 0.5}, {1., 0.5}};
  }


  template <int dim>
  void
  ParabolicProblem<dim>::interpolate_in_time(const Vector &a,
                                             const Vector &b,
                                             const double  theta,
                                             Vector       &result) const
  {
    Assert(!a.has_ghost_elements() && !b.has_ghost_elements(),
           ExcMessage("Interpolate vectors without ghosts."));
    if (interpolation_buffer.size() != a.size())
      interpolation_buffer.reinit(owned_nodes, comm);
    interpolation_buffer.equ(1. - theta, a);
    interpolation_buffer.add(theta, b);
    if (!result.has_ghost_elements() || result.size() != a.size())
      result.reinit(u1_h, true);
    result = interpolation_buffer;
  }


  // The terms of the step estimate that are not those of the steady
  // problem, from one loop over the cells: with the cone correction
  // d = s~_h - u_h (d_lin = s_h - u_h at the nodes, d_disc = s~_h - s_h the
  // pointwise correction (theta w, -(1 - theta) w), w = (s2 - s1)^+, zero
  // for p = 1),
  // - eta_dt = C_F (sum_alpha mu_alpha^-1 |d_t d_alpha|^2)^(1/2), which
  //   bounds (d_t d, v) by |||v|||, split into disc and lin parts, and the
  //   part of this step alone, C_F |d_lin^n| / dt (stopping criterion);
  // - |d^n - d^(n-1)| (L2) and its parts, for the second bound, which
  //   takes (d_t d, e~) in L2 and sums this change over the steps;
  // - |d^n| (L2) and its parts, for the final-time term;
  // - |||u_h^n - u_h^(n-1)|||, for the temporal estimator.
  template <int dim>
  typename ParabolicProblem<dim>::ParabolicTerms
  ParabolicProblem<dim>::parabolic_terms(const Iterate &it) const
  {
    TimerOutput::Scope t(timer, "estimators: evaluation");
    FEValues<dim>      values(*mapping,
                         fe,
                         quadrature,
                         update_values | update_gradients |
                           update_quadrature_points | update_JxW_values);
    const unsigned int n_q   = quadrature.size();
    const double       mu[2] = {data.mu1, data.mu2};
    // Over an obstacle: theta = 1, psi itself in place of s2 (at t_n and
    // t_(n-1)), and no membrane 2 (psi_now, psi_old).
    const double theta = data.obstacle ? 1. : data.mu2 / (data.mu1 + data.mu2);
    const unsigned int          n_membranes = data.obstacle ? 1 : 2;
    std::vector<double>         u[2], s[2], u_old[2], s_old[2];
    std::vector<double>         psi_now(n_q), psi_old(n_q);
    std::vector<Tensor<1, dim>> grad_u[2], grad_u_old[2];
    for (unsigned int a = 0; a < 2; ++a)
      for (auto *v : {&u[a], &s[a], &u_old[a], &s_old[a]})
        v->resize(n_q);
    for (unsigned int a = 0; a < 2; ++a)
      {
        grad_u[a].resize(n_q);
        grad_u_old[a].resize(n_q);
      }
    const Vector *now_u[2] = {&it.u1, &it.u2}, *now_s[2] = {&it.s1, &it.s2},
                 *old_u[2] = {&previous_u1, &previous_u2},
                 *old_s[2] = {&previous_s1, &previous_s2};

    // Squared norms: dt-change of d (disc, lin) weighted by 1/mu, d^n
    // (lin, weighted by 1/mu), the change of d (total, disc, lin),
    // |d^n|^2 (total, disc, lin), |||du|||^2.
    enum
    {
      change_disc,
      change_lin,
      now_lin_weighted,
      l2_change_total,
      l2_change_disc,
      l2_change_lin,
      final_total,
      final_disc,
      final_lin,
      time_energy,
      n_sums
    };
    double sums[n_sums] = {};
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              values.get_function_values(*now_u[a], u[a]);
              values.get_function_values(*now_s[a], s[a]);
              values.get_function_values(*old_u[a], u_old[a]);
              values.get_function_values(*old_s[a], s_old[a]);
              values.get_function_gradients(*now_u[a], grad_u[a]);
              values.get_function_gradients(*old_u[a], grad_u_old[a]);
            }
          if (data.obstacle)
            {
              const auto &points = values.get_quadrature_points();
              data.obstacle->set_time(time);
              data.obstacle->value_list(points, psi_old);
              data.obstacle->set_time(time + time_step);
              data.obstacle->value_list(points, psi_now);
              s[1]     = psi_now;
              s_old[1] = psi_old;
            }
          for (unsigned int q = 0; q < n_q; ++q)
            {
              const double dx      = values.JxW(q);
              const double w       = std::max(s[1][q] - s[0][q], 0.);
              const double w_old   = std::max(s_old[1][q] - s_old[0][q], 0.);
              const double disc[2] = {theta * w, -(1. - theta) * w};
              const double disc_old[2] = {theta * w_old, -(1. - theta) * w_old};
              for (unsigned int a = 0; a < n_membranes; ++a)
                {
                  const double lin     = s[a][q] - u[a][q];
                  const double lin_old = s_old[a][q] - u_old[a][q];
                  sums[change_disc] +=
                    std::pow(disc[a] - disc_old[a], 2) / mu[a] * dx;
                  sums[change_lin] += std::pow(lin - lin_old, 2) / mu[a] * dx;
                  sums[now_lin_weighted] += lin * lin / mu[a] * dx;
                  sums[l2_change_total] +=
                    std::pow(lin + disc[a] - lin_old - disc_old[a], 2) * dx;
                  sums[l2_change_disc] +=
                    std::pow(disc[a] - disc_old[a], 2) * dx;
                  sums[l2_change_lin] += std::pow(lin - lin_old, 2) * dx;
                  sums[final_total] += std::pow(lin + disc[a], 2) * dx;
                  sums[final_disc] += disc[a] * disc[a] * dx;
                  sums[final_lin] += lin * lin * dx;
                  sums[time_energy] +=
                    mu[a] * (grad_u[a][q] - grad_u_old[a][q]).norm_square() *
                    dx;
                }
            }
        }
    double total[n_sums];
    Utilities::MPI::sum(ArrayView<const double>(sums, n_sums),
                        comm,
                        ArrayView<double>(total, n_sums));
    std::copy(total, total + n_sums, sums);

    ParabolicTerms terms;
    const double   factor = friedrichs_constant / time_step;
    terms.eta_dt_disc     = factor * std::sqrt(sums[change_disc]);
    terms.eta_dt_lin      = factor * std::sqrt(sums[change_lin]);
    // |d_t d| <= |d_t d_disc| + |d_t d_lin|: the bound and its split.
    terms.eta_dt                = terms.eta_dt_disc + terms.eta_dt_lin;
    terms.eta_dt_lin_controlled = factor * std::sqrt(sums[now_lin_weighted]);
    terms.change                = std::sqrt(sums[l2_change_total]);
    terms.change_disc           = std::sqrt(sums[l2_change_disc]);
    terms.change_lin            = std::sqrt(sums[l2_change_lin]);
    terms.final_nonc            = std::sqrt(sums[final_total]);
    terms.final_nonc_disc       = std::sqrt(sums[final_disc]);
    terms.final_nonc_lin        = std::sqrt(sums[final_lin]);
    terms.time_energy           = std::sqrt(sums[time_energy]);
    return terms;
  }


  namespace
  {
    // The second bound's variants v = 2 (alpha - 1) + k (StepEstimate::
    // eta_variant). With membrane alpha's flux zero, its part of the
    // residual is (f - d_t u_h -/+ lambda~, v_alpha) - (mu grad u_h, grad
    // v_alpha): the first term goes to the L2 sum, the second is its flux
    // term; the other membrane, beta, keeps its flux, residual and
    // remainder (the latter by Friedrichs). With k = 1 the part lambda~ -
    // c_K lambda~^pos of the multiplier, which eta_nonc2 bounds in H^-1, goes
    // to the L2 sum as well: (delta, e1 - e2) <= 2^(1/2) |delta| |e|.
    std::array<double, 4>
    variant_terms(const VI::ContactEstimate &c,
                  const double               mu[2],
                  const double               friedrichs_constant)
    {
      std::array<double, 4> A{};
      for (const unsigned int a : {0u, 1u})
        {
          const unsigned int b = 1 - a;
          const double       eta_1 =
            std::sqrt(c.flux_residual_squared[b] + c.energy_squared[a]) +
            friedrichs_constant * std::sqrt(c.remainder_squared[b] / mu[b]);
          A[2 * a]     = eta_1 + c.nonc_1 + c.nonc_2;
          A[2 * a + 1] = eta_1 + c.nonc_1;
        }
      return A;
    }


    // What the variants add to the L2 sum on a step of length dt (their
    // terms are constant on it).
    std::array<double, 4>
    variant_l2_terms(const VI::ContactEstimate &c, const double dt)
    {
      std::array<double, 4> G{};
      for (const unsigned int a : {0u, 1u})
        {
          G[2 * a] = dt * std::sqrt(c.load_squared[a]);
          G[2 * a + 1] =
            G[2 * a] + dt * std::sqrt(2. * c.multiplier_l2_squared);
        }
      return G;
    }
  } // namespace


  // The estimate of the step for an iterate (with a look-ahead iterate for
  // the algebraic part, see step-membranes): the steady estimators of
  // VI::estimate_contact_error at the points of time_points() for u_ht(t),
  // s_ht(t) (linear in t), lambda_h^n, sigma^n, combined as in StepEstimate.
  // With A(t) = eta_1 + eta_nonc1 + eta_nonc2 + eta_dt and its split
  // A + (eta_C)^(1/2) <= D + L + G,
  //   D = eta_1,disc + eta_nonc1,disc + eta_nonc2,disc + eta_dt,disc
  //       + (eta_C,disc^+)^(1/2),
  //   L = eta_nonc1,lin + eta_nonc2,lin + eta_dt,lin + (eta_C,lin^+)^(1/2),
  //   G = |mu^-1/2 sigma_alg| + remainder,
  // eta_n <= |D|_In + |L|_In + |G|_In + |eta_osc|_In.
  template <int dim>
  StepEstimate
  ParabolicProblem<dim>::estimate(const Iterate &it, const Iterate &ahead) const
  {
    const ParabolicTerms terms = parabolic_terms(it);

    TimerOutput::Scope t(timer, "estimators: evaluation");
    // u_h and s_h are set at every point of time_points() below.
    VI::ContactEstimatorInput<dim> in =
      estimator_input(*flux_reconstruction, it, ahead);
    in.friedrichs_constant = friedrichs_constant;
    in.domain              = &domain;
    in.mu1                 = data.mu1;
    in.mu2                 = data.mu2;
    in.f1                  = data.f1.get();
    in.f2                  = data.f2.get();
    in.dt_u1               = &it.dt_u1;
    in.dt_u2               = &it.dt_u2;
    in.dt_u1_ahead         = &ahead.dt_u1;
    in.dt_u2_ahead         = &ahead.dt_u2;

    StepEstimate e;
    // of A^2 + eta_C, D^2, L^2, G^2, and of the same without eta_dt (the
    // second bound, in which d_t d is not measured in H^-1)
    double integral[7] = {};
    // of A_v^2 + eta_C for the second bound's variants (two membranes only)
    double       integral_variant[4] = {};
    const double mu[2]               = {data.mu1, data.mu2};
    Vector       u1, u2, s1, s2;
    double       D_end = 0;
    for (const auto &[theta, weight] : time_points())
      {
        if (theta == 1.)
          {
            in.u1 = &it.u1;
            in.u2 = &it.u2;
            in.s1 = &it.s1;
            in.s2 = &it.s2;
          }
        else if (theta == 0.)
          {
            in.u1 = &previous_u1;
            in.u2 = &previous_u2;
            in.s1 = &previous_s1;
            in.s2 = &previous_s2;
          }
        else
          {
            interpolate_in_time(previous_owned[0], it.owned[0], theta, u1);
            interpolate_in_time(previous_owned[1], it.owned[1], theta, u2);
            interpolate_in_time(previous_owned[2], it.owned[2], theta, s1);
            interpolate_in_time(previous_owned[3], it.owned[3], theta, s2);
            in.u1 = &u1;
            in.u2 = &u2;
            in.s1 = &s1;
            in.s2 = &s2;
          }
        // (the linearisation part of the contact term, linear in t as u_ht;
        // with mass lumping only that of the step's end, previous_
        // complementarity being computed for the cellwise multiplier only)
        in.complementarity = (1. - theta) * it.previous_complementarity +
                             theta * it.complementarity;
        // (over an obstacle the estimate reads psi at the point's time)
        if (data.obstacle)
          data.obstacle->set_time(time + theta * time_step);
        VI::ContactEstimate c = VI::estimate_contact_error(in);
        if (data.obstacle)
          data.obstacle->set_time(time + time_step);

        // Over an obstacle the equation of e~ = u - s~ is tested with grad
        // s~ in the flux term (eta_1_cone): then a(d, v) does not appear,
        // and eta_nonc1 enters the bound once, in its second term.
        // (A_l2, D_l2: the same without eta_dt, for the second bound)
        const double A_l2 =
          (data.obstacle ? c.eta_1_cone : c.eta_1 + c.nonc_1) + c.nonc_2;
        const double A    = A_l2 + terms.eta_dt;
        const double D_l2 = c.eta_1_disc + c.nonc_1_disc + c.nonc_2_disc +
                            std::sqrt(std::max(c.contact_disc, 0.));
        const double D = D_l2 + terms.eta_dt_disc;
        const double L_other =
          c.nonc_1_lin + c.nonc_2_lin + std::sqrt(std::max(c.contact_lin, 0.));
        const double L = L_other + terms.eta_dt_lin;
        const double G = c.flux_alg + c.remainder;
        integral[0] += weight * (A * A + c.contact_cone);
        integral[1] += weight * D * D;
        integral[2] += weight * L * L;
        integral[3] += weight * G * G;
        integral[4] += weight * (A_l2 * A_l2 + c.contact_cone);
        integral[5] += weight * D_l2 * D_l2;
        integral[6] += weight * L_other * L_other;
        if (!data.obstacle)
          {
            const auto A_variant = variant_terms(c, mu, friedrichs_constant);
            for (unsigned int v = 0; v < 4; ++v)
              integral_variant[v] +=
                weight * (A_variant[v] * A_variant[v] + c.contact_cone);
            if (theta == 1.)
              e.l2_variant = variant_l2_terms(c, time_step);
          }
        e.nonc_squared += weight * c.nonc_1 * c.nonc_1;
        e.nonc_squared_disc += weight * c.nonc_1_disc * c.nonc_1_disc;
        e.nonc_squared_lin += weight * c.nonc_1_lin * c.nonc_1_lin;
        if (theta == 1.)
          {
            D_end = D;
            // What this Newton iteration controls: the iterate at t_n (at
            // earlier times u_ht mixes in u_h^(n-1)).
            e.eta_lin_controlled =
              std::sqrt(time_step) * (L_other + terms.eta_dt_lin_controlled);
            e.at_end = std::move(c);
          }
      }

    const double dt = time_step;
    e.oscillation   = step_oscillation;
    e.eta           = std::sqrt(dt * integral[0]) + e.oscillation;
    e.eta_disc      = std::sqrt(dt * integral[1]) + e.oscillation;
    e.eta_lin       = std::sqrt(dt * integral[2]);
    e.eta_alg       = std::sqrt(dt * integral[3]);
    e.eta_dt        = terms.eta_dt;
    e.eta_l2        = std::sqrt(dt * integral[4]) + e.oscillation;
    e.eta_l2_disc   = std::sqrt(dt * integral[5]) + e.oscillation;
    e.eta_l2_lin    = std::sqrt(dt * integral[6]);
    // (over an obstacle there are none: they stay zero, and Accumulated
    // skips them)
    if (!data.obstacle)
      for (unsigned int v = 0; v < 4; ++v)
        e.eta_variant[v] = std::sqrt(dt * integral_variant[v]) + e.oscillation;
    e.change      = terms.change;
    e.change_disc = terms.change_disc;
    e.change_lin  = terms.change_lin;
    e.nonc_squared *= dt;
    e.nonc_squared_disc *= dt;
    e.nonc_squared_lin *= dt;
    e.final_nonc      = terms.final_nonc;
    e.final_nonc_disc = terms.final_nonc_disc;
    e.final_nonc_lin  = terms.final_nonc_lin;
    e.eta_time        = std::sqrt(dt / 3.) * terms.time_energy;
    e.eta_space       = std::sqrt(dt) * D_end;
    return e;
  }


  // The estimate of X with itself as look-ahead (sigma_alg = 0, the whole
  // algebraic residual in the remainder).
  template <int dim>
  StepEstimate
  ParabolicProblem<dim>::estimate(const Vector &X) const
  {
    Iterate it;
    Vector  contact;
    if (multiplier_needs_contact_set())
      contact_nodes(contact_system, X, contact);
    describe_iterate(X, contact, it);
    return estimate(it, it);
  }


  // eta_init = |u^0 - s~_h^0| (L2, both membranes): the initial error of the
  // cone function the bound is built on (s~_h^0 = u_h^0 for p = 1).
  template <int dim>
  double
  ParabolicProblem<dim>::initial_error_estimate() const
  {
    const QGauss<dim>  error_quadrature(fe.degree + 3);
    FEValues<dim>      values(*mapping,
                         fe,
                         error_quadrature,
                         update_values | update_quadrature_points |
                           update_JxW_values);
    const unsigned int n_q = error_quadrature.size();
    // (over an obstacle: s~1^0 = max(s1^0, psi(0)), membrane 1 alone)
    const double theta = data.obstacle ? 1. : data.mu2 / (data.mu1 + data.mu2);
    const unsigned int  n_membranes = data.obstacle ? 1 : 2;
    std::vector<double> uh[2], sh[2], exact[2];
    for (unsigned int a = 0; a < 2; ++a)
      for (auto *v : {&uh[a], &sh[a], &exact[a]})
        v->resize(n_q);
    double local = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          values.get_function_values(previous_u1, uh[0]);
          values.get_function_values(previous_u2, uh[1]);
          values.get_function_values(previous_s1, sh[0]);
          values.get_function_values(previous_s2, sh[1]);
          data.initial_u1->value_list(values.get_quadrature_points(), exact[0]);
          data.initial_u2->value_list(values.get_quadrature_points(), exact[1]);
          if (data.obstacle)
            sh[1] = exact[1];
          for (unsigned int q = 0; q < n_q; ++q)
            {
              const double w             = std::max(sh[1][q] - sh[0][q], 0.);
              const double correction[2] = {theta * w, -(1. - theta) * w};
              for (unsigned int a = 0; a < n_membranes; ++a)
                local += std::pow(exact[a][q] - sh[a][q] - correction[a], 2) *
                         values.JxW(q);
            }
        }
    return std::sqrt(Utilities::MPI::sum(local, comm));
  }


  // |eta_osc|_L2(In) = C_F (int_In sum_alpha mu_alpha^-1
  // |f_alpha(t) - f_alpha(t_n)|^2 dt)^(1/2): the load of the scheme is
  // f(t_n), the equation holds with f(t). Three Gauss points in time; zero
  // for forces independent of t.
  template <int dim>
  double
  ParabolicProblem<dim>::force_oscillation() const
  {
    if (!data.forces_depend_on_time)
      return 0.;
    const double        t_n = time + time_step;
    const QGauss<1>     in_time(3);
    FEValues<dim>       values(*mapping,
                         fe,
                         quadrature,
                         update_quadrature_points | update_JxW_values);
    const unsigned int  n_q   = quadrature.size();
    const double        mu[2] = {data.mu1, data.mu2};
    Function<dim>      *f[2]  = {data.f1.get(), data.f2.get()};
    std::vector<double> now(n_q), then(n_q);
    double              local = 0;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              f[a]->set_time(t_n);
              f[a]->value_list(values.get_quadrature_points(), now);
              for (unsigned int k = 0; k < in_time.size(); ++k)
                {
                  f[a]->set_time(time + time_step * in_time.point(k)[0]);
                  f[a]->value_list(values.get_quadrature_points(), then);
                  for (unsigned int q = 0; q < n_q; ++q)
                    local += in_time.weight(k) * time_step *
                             std::pow(then[q] - now[q], 2) / mu[a] *
                             values.JxW(q);
                }
            }
        }
    data.set_time(t_n);
    return friedrichs_constant * std::sqrt(Utilities::MPI::sum(local, comm));
  }


  // Explicit instantiations of this file's members.
  template void
  ParabolicProblem<2>::describe_iterate(const Vector &X,
                                        const Vector &contact,
                                        Iterate      &it) const;
  template std::vector<std::pair<double, double>>
  ParabolicProblem<2>::time_points() const;
  template void
  ParabolicProblem<2>::interpolate_in_time(const Vector &a,
                                           const Vector &b,
                                           const double  theta,
                                           Vector       &result) const;
  template typename ParabolicProblem<2>::ParabolicTerms
  ParabolicProblem<2>::parabolic_terms(const Iterate &it) const;
  template StepEstimate
  ParabolicProblem<2>::estimate(const Iterate &it, const Iterate &ahead) const;
  template StepEstimate
  ParabolicProblem<2>::estimate(const Vector &X) const;
  template double
  ParabolicProblem<2>::initial_error_estimate() const;
  template double
  ParabolicProblem<2>::force_oscillation() const;
} // namespace StepParabolic
