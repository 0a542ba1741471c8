#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/filtered_iterator.h>

#include <vi/cell_function_values.h>
#include <vi/cell_multiplier.h>
#include <vi/dual_norm.h>
#include <vi/estimators.h>
#include <vi/piola_divergence.h>
#include <vi/same_cell.h>
#include <vi/transmitted_load.h>

#include "contact_estimator_internal.h"

#include <array>
#include <cmath>
#include <memory>

namespace VI
{
  using namespace dealii;

  namespace
  {
    // The global sums of the estimate (EstimateSums).
    enum class ContactSum : unsigned int
    {
      flux_residual_total, // sum (eta_F + eta_R)^2 with the look-ahead flux
      flux_residual_disc,  // sum (eta_F,disc + eta_R)^2
      flux_residual_cone,  // the same with grad s~ in place of grad u_h
      flux_disc_squared,
      residual_squared,
      algebraic_squared,
      remainder_1, // |r1_ahead - (lambda_ahead - lambda) + dt_u1_ahead -
                   // dt_u1|^2
      remainder_2, // |r2_ahead + (lambda_ahead - lambda) + dt_u2_ahead -
                   // dt_u2|^2
      // the multiplier's sums (add_multiplier_sums())
      multiplier_local,
      multiplier_mean,
      multiplier_local_disc,
      multiplier_mean_disc,
      nonc_total,
      nonc_disc,
      nonc_lin,
      positive,           // |lambda^pos|^2
      contact_total,      // 2 (lambda^pos, u1 - u2)
      contact_cone,       // 2 (c_K lambda^pos, (s1 - s2)^+)
      contact_linearised, // 2 (lambda, u1 - u2)
      dirichlet_squared,  // |||G|||^2
      cone_cross,         // over an obstacle: a bound of a(u - s~, w), see
                          // add_obstacle_cross_term()
      // per membrane, for the bounds of parabolic problems that take one
      // membrane's load in L2 (ContactEstimate::flux_residual_squared, ...)
      flux_residual_1, // (eta_F + eta_R)^2 with the look-ahead flux
      flux_residual_2,
      energy_1, // |mu^(1/2) grad u_h|^2
      energy_2,
      load_1, // |f - d_t u_h - (-1)^alpha lambda~|^2
      load_2,
      multiplier_l2, // |lambda~ - c_K lambda~^pos|^2, whose parts nonc_2 takes
      n_sums
    };
    using ContactSums = EstimateSums<ContactSum>;


    // What one thread needs on a cell: FEValues and the values at the
    // quadrature points (WorkStream copies it once per thread).
    template <int dim>
    struct ContactScratch
    {
      ContactScratch(const ContactEstimatorInput<dim> &in, const bool lifting)
          : in(in)
          , lifting(lifting)
          , potential_values(*in.mapping,
                             in.potential->get_fe(),
                             *in.quadrature,
                             update_values | update_gradients |
                               update_quadrature_points |
                               update_inverse_jacobians | update_jacobians |
                               update_JxW_values)
          , lean_values(*in.mapping,
                        in.potential->get_fe(),
                        *in.quadrature,
                        update_values | update_JxW_values)
          , divergence(in.flux->get_fe(), *in.quadrature)
          , sigma_coefficients(in.flux->get_fe().n_dofs_per_cell())
      {
        const unsigned int n_q = in.quadrature->size();
        for (unsigned int a = 0; a < 2; ++a)
          {
            for (auto *v : {&grad_u[a],
                            &grad_s[a],
                            &sigma_disc[a],
                            &sigma_ahead[a],
                            &grad_G[a]})
              v->resize(n_q);
            for (auto *v : {&u[a], &s[a], &r_ahead[a], &div_ahead[a], &G[a]})
              v->resize(n_q);
            // Zero for steady problems.
            dt_u[a].assign(n_q, 0.);
            dt_u_ahead[a].assign(n_q, 0.);
          }
        for (auto *v : {&f, &lambda, &lambda_nonnegative, &lambda_ahead})
          v->resize(n_q);
        if (lifting)
          for (const unsigned int f : GeometryInfo<dim>::face_indices())
            {
              face_values.emplace_back(std::make_unique<FEValues<dim>>(
                *in.mapping,
                in.potential->get_fe(),
                lifting_face_points<dim>(n_q, f),
                update_values | update_gradients | update_jacobians |
                  update_quadrature_points));
            }
      }

      ContactScratch(const ContactScratch &other)
          : ContactScratch(other.in, other.lifting)
      {
      }

      const ContactEstimatorInput<dim> &in;
      const bool                        lifting;
      FEValues<dim>                     potential_values;
      // values and weights only: the flux-free terms of most cells
      FEValues<dim>        lean_values;
      PiolaDivergence<dim> divergence;
      std::vector<double>  sigma_coefficients, potential_coefficients,
        unused_divergences;
      std::vector<Tensor<1, dim>> grad_u[2], grad_s[2], sigma_disc[2],
        sigma_ahead[2], grad_G[2];
      std::vector<double> u[2], s[2], r_ahead[2], div_ahead[2], dt_u[2],
        dt_u_ahead[2], G[2], f, lambda, lambda_nonnegative, lambda_ahead,
        s_coefficients;
      std::vector<std::unique_ptr<FEValues<dim>>> face_values;
    };

    // The sums of one cell, added in the order of the cells (so that the
    // estimate does not depend on the number of threads).
    struct CellShare
    {
      ContactSums cell;
    };

    // The cell terms of the contact estimate, the per-cell quadrature work:
    // on every owned cell the flux, residual and algebraic terms of both
    // membranes, the remainder, the multiplier's sums, the non-conformity and
    // contact terms and the lifting of the boundary data; with the inputs
    // they read and the cell means and remainders they keep for the dual norm
    // bounds.
    template <int dim>
    struct ContactCellTerms : MembraneConstants
    {
      using CellIterator = typename DoFHandler<dim>::active_cell_iterator;

      ContactCellTerms(const ContactEstimatorInput<dim> &in,
                       ContactEstimate                  &estimate)
          : MembraneConstants(in.mu1,
                              in.mu2,
                              in.friedrichs_constant,
                              in.obstacle != nullptr)
          , in(in)
          , estimate(estimate)
          , tria(in.potential->get_triangulation())
          , pairs(in)
          , n_q(in.quadrature->size())
          , n_tau(in.flux->get_fe().n_dofs_per_cell())
          , r_vectors{in.r1_ahead, in.r2_ahead}
          , disc_vectors{in.sigma1_disc, in.sigma2_disc}
          , ahead_vectors{in.sigma1_ahead, in.sigma2_ahead}
          , load_values{in.f1_values, in.f2_values}
          , dt_vectors{in.dt_u1, in.dt_u2}
          , dt_ahead_vectors{in.dt_u1_ahead, in.dt_u2_ahead}
          , lifting(in.g1 && in.g2)
          , own_look_ahead(in.sigma1_ahead == in.sigma1_disc &&
                           in.sigma2_ahead == in.sigma2_disc &&
                           (in.cell_multiplier ?
                              in.lambda_ahead_cells == in.lambda_cells :
                              in.lambda_ahead == in.lambda))
          , with_fluxes(!in.without_fluxes)
          , undershoots(in.dual_norm && in.dual_norm_undershoots)
          , remainder(in.dual_norm && in.dual_norm_remainder)
          , contact_linearised_needed(!in.mass_lumped && !in.cell_multiplier)
      {
        // The fluxes from their reference values, signs and the Jacobians of
        // the potential's FEValues.
        Assert(in.flux_signs,
               ExcMessage("The Piola signs of the fluxes are needed."));
        Assert((in.dt_u1 && in.dt_u2 && in.dt_u1_ahead && in.dt_u2_ahead) ||
                 !(in.dt_u1 || in.dt_u2 || in.dt_u1_ahead || in.dt_u2_ahead),
               ExcMessage("Give all four time derivatives, or none."));
        AssertThrow(!in.transmitted_load == !in.transmitted_load_ahead,
                    ExcMessage("Give the transmitted load of the iterate "
                               "and of the look-ahead, or neither."));
        AssertThrow(with_fluxes ||
                      (own_look_ahead &&
                       !(in.dual_norm && in.dual_norm_undershoots)),
                    ExcMessage("The estimate without fluxes is that of an "
                               "iterate with itself as look-ahead and "
                               "Friedrichs' bound of the undershoots."));
        if (undershoots)
          {
            means.assign(tria.n_active_cells(), 0.);
            means_disc.assign(tria.n_active_cells(), 0.);
          }
        if (remainder)
          for (auto &values : remainders)
            values.assign(std::size_t(tria.n_active_cells()) * n_q, 0.);
      }

      // Every cell writes its indicators (and means, remainders) at its own
      // index, and hands its sums to the copier.
      void
      cell_terms(const CellIterator  &potential_cell,
                 ContactScratch<dim> &scratch,
                 CellShare           &share)
      {
        if (lean_cell(potential_cell, scratch))
          {
            add_lean_terms(potential_cell, scratch, share.cell);
            return;
          }
        read_values(potential_cell, scratch);
        add_lifting(potential_cell, scratch);
        if (in.obstacle)
          set_obstacle_values(scratch);

        const double h_K   = potential_cell->diameter();
        const auto   index = potential_cell->active_cell_index();
        auto        &cell  = share.cell;
        cell.clear();
        double flux_total[2] = {};
        add_flux_residual_terms(index, h_K, scratch, flux_total, cell);

        const MultiplierSplit split = add_multiplier_terms(
          scratch.potential_values.get_JxW_values(), h_K, index, scratch, cell);
        add_nonconformity_contact_terms(scratch, split, cell);

        estimate.cell_flux(index) =
          std::pow(flux_total[0], 2) + std::pow(flux_total[1], 2);
        estimate.cell_residual(index)  = cell[ContactSum::residual_squared];
        estimate.cell_algebraic(index) = cell[ContactSum::algebraic_squared];
        estimate.cell_nonconformity(index) = cell[ContactSum::nonc_total];
        estimate.cell_contact(index)       = cell[ContactSum::contact_cone];
        estimate.cell_total(index) =
          cell[ContactSum::flux_residual_total] + cell[ContactSum::nonc_total] +
          c_mu * c_mu * cell[ContactSum::multiplier_local] +
          C * C * cell[ContactSum::multiplier_mean] +
          cell[ContactSum::contact_cone] + cell[ContactSum::dirichlet_squared];
      }

      // The multiplier's sums of a cell (add_multiplier_sums()), and for the
      // dual norm bound the cell means of its undershoots.
      MultiplierSplit
      add_multiplier_terms(const std::vector<double> &JxW,
                           const double               h_K,
                           const unsigned int         index,
                           ContactScratch<dim>       &scratch,
                           ContactSums               &cell)
      {
        const auto [split, split_disc] = add_multiplier_sums(
          scratch.lambda, scratch.lambda_nonnegative, JxW, h_K, cell);
        if (dt_vectors[0])
          cell[ContactSum::multiplier_l2] =
            split.oscillation_squared + split.mean_squared;
        if (undershoots)
          {
            means[index]      = split.mean;
            means_disc[index] = split_disc.mean;
          }
        return split;
      }

      // Without fluxes, only eta_lin (from below) and eta_alg (from above) are
      // asked for: the remainder (the residual r_h, the iterate being its own
      // look-ahead), the multiplier's sums and |||s_h - u_h|||, which vanishes
      // on the cells where s_h = u_h at every node; and 2 (lambda_h, u1h -
      // u2h) for p >= 2, which vanishes where lambda_h = 0. On the other cells
      // these terms need values and weights only, not the gradients, the
      // boundary lifting G and the loads: a fraction of the cost of a cell.
      bool
      lean_cell(const CellIterator &cell, ContactScratch<dim> &scratch) const
      {
        // (time derivatives: the remainder holds their change)
        if (with_fluxes || dt_vectors[0])
          return false;
        std::vector<double> &c = scratch.potential_coefficients,
                            &d = scratch.s_coefficients;
        // (u_h and s_h: exactly equal where no node was averaged)
        c.resize(cell->get_fe().n_dofs_per_cell());
        d.resize(c.size());
        for (unsigned int a = 0; a < 2; ++a)
          {
            cell->get_dof_values(*pairs.u[a], c.begin(), c.end());
            cell->get_dof_values(*pairs.s[a], d.begin(), d.end());
            if (c != d)
              return false;
          }
        if (contact_linearised_needed)
          {
            cell->get_dof_values(*in.lambda, c.begin(), c.end());
            for (const double value : c)
              if (value != 0.)
                return false;
          }
        return true;
      }

      // The terms of a lean cell: the remainder and the multiplier's sums.
      void
      add_lean_terms(const CellIterator  &potential_cell,
                     ContactScratch<dim> &scratch,
                     ContactSums         &cell)
      {
        FEValues<dim> &lean = scratch.lean_values;
        lean.reinit(potential_cell);
        const auto index  = potential_cell->active_cell_index();
        const auto values = [&](const TrilinosWrappers::MPI::Vector &v,
                                std::vector<double> &at_points) {
          cell_function_values(lean,
                               potential_cell,
                               v,
                               scratch.potential_coefficients,
                               &at_points);
        };
        cell.clear();
        for (unsigned int a = 0; a < n_membranes; ++a)
          {
            std::vector<double> &r = scratch.r_ahead[a];
            values(*r_vectors[a], r);
            for (unsigned int q = 0; q < n_q; ++q)
              {
                cell.of_membrane(ContactSum::remainder_1, a) +=
                  r[q] * r[q] * lean.JxW(q);
                if (remainder)
                  remainders[a][index * n_q + q] = r[q];
              }
          }
        if (in.cell_multiplier)
          {
            in.cell_multiplier->values(*in.lambda_cells, index, scratch.lambda);
            in.cell_multiplier->values(*in.lambda_nonnegative_cells,
                                       index,
                                       scratch.lambda_nonnegative);
          }
        else
          {
            values(*in.lambda, scratch.lambda);
            values(*in.lambda_nonnegative, scratch.lambda_nonnegative);
          }
        add_transmitted_load(index, scratch.lambda, scratch.lambda_nonnegative);
        add_multiplier_terms(lean.get_JxW_values(),
                             potential_cell->diameter(),
                             index,
                             scratch,
                             cell);
      }

      // u_h, s_h, the look-ahead residual, the fluxes (and their divergences),
      // the time derivatives and the multipliers at the quadrature points.
      void
      read_values(const CellIterator  &potential_cell,
                  ContactScratch<dim> &scratch) const
      {
        FEValues<dim>        &potential_values   = scratch.potential_values;
        PiolaDivergence<dim> &divergence         = scratch.divergence;
        std::vector<double>  &sigma_coefficients = scratch.sigma_coefficients;
        std::vector<double>  &potential_coefficients =
          scratch.potential_coefficients;
        std::vector<double> &unused_divergences = scratch.unused_divergences;
        auto                &grad_u = scratch.grad_u, &grad_s = scratch.grad_s,
             &sigma_disc  = scratch.sigma_disc,
             &sigma_ahead = scratch.sigma_ahead;
        auto &u = scratch.u, &s = scratch.s, &r_ahead = scratch.r_ahead,
             &div_ahead = scratch.div_ahead, &dt_u = scratch.dt_u,
             &dt_u_ahead                        = scratch.dt_u_ahead;
        std::vector<double> &lambda             = scratch.lambda,
                            &lambda_nonnegative = scratch.lambda_nonnegative,
                            &lambda_ahead       = scratch.lambda_ahead;

        const auto flux_cell = same_cell(potential_cell, *in.flux);
        potential_values.reinit(potential_cell);
        if (with_fluxes)
          divergence.reinit(potential_values,
                            ArrayView<const std::int8_t>(
                              in.flux_signs->data() +
                                potential_cell->active_cell_index() * n_tau,
                              n_tau));
        // values and divergences of a flux vector at the quadrature points
        const auto flux_at_points = [&](const TrilinosWrappers::MPI::Vector &v,
                                        std::vector<Tensor<1, dim>> &values,
                                        std::vector<double> &divergences) {
          flux_cell->get_dof_values(v,
                                    sigma_coefficients.begin(),
                                    sigma_coefficients.end());
          divergence.function_values_and_divergences(
            make_array_view(sigma_coefficients), values, divergences);
        };
        for (unsigned int a = 0; a < 2; ++a)
          {
            cell_function_values(potential_values,
                                 potential_cell,
                                 *pairs.u[a],
                                 potential_coefficients,
                                 &u[a],
                                 &grad_u[a]);
            cell_function_values(potential_values,
                                 potential_cell,
                                 *pairs.s[a],
                                 potential_coefficients,
                                 &s[a],
                                 &grad_s[a]);
            cell_function_values(potential_values,
                                 potential_cell,
                                 *r_vectors[a],
                                 potential_coefficients,
                                 &r_ahead[a]);
            if (with_fluxes)
              flux_at_points(*ahead_vectors[a], sigma_ahead[a], div_ahead[a]);
            else
              {
                // (the flux terms below are then not used)
                std::fill(sigma_ahead[a].begin(),
                          sigma_ahead[a].end(),
                          Tensor<1, dim>());
                std::fill(div_ahead[a].begin(), div_ahead[a].end(), 0.);
              }
            if (own_look_ahead)
              sigma_disc[a] = sigma_ahead[a];
            else
              flux_at_points(*disc_vectors[a],
                             sigma_disc[a],
                             unused_divergences);
            if (dt_vectors[a])
              {
                cell_function_values(potential_values,
                                     potential_cell,
                                     *dt_vectors[a],
                                     potential_coefficients,
                                     &dt_u[a]);
                cell_function_values(potential_values,
                                     potential_cell,
                                     *dt_ahead_vectors[a],
                                     potential_coefficients,
                                     &dt_u_ahead[a]);
              }
          }
        if (in.cell_multiplier)
          {
            const auto index = potential_cell->active_cell_index();
            in.cell_multiplier->values(*in.lambda_cells, index, lambda);
            in.cell_multiplier->values(*in.lambda_nonnegative_cells,
                                       index,
                                       lambda_nonnegative);
            if (!own_look_ahead)
              in.cell_multiplier->values(*in.lambda_ahead_cells,
                                         index,
                                         lambda_ahead);
          }
        else
          {
            cell_function_values(potential_values,
                                 potential_cell,
                                 *in.lambda,
                                 potential_coefficients,
                                 &lambda);
            cell_function_values(potential_values,
                                 potential_cell,
                                 *in.lambda_nonnegative,
                                 potential_coefficients,
                                 &lambda_nonnegative);
            if (!own_look_ahead)
              cell_function_values(potential_values,
                                   potential_cell,
                                   *in.lambda_ahead,
                                   potential_coefficients,
                                   &lambda_ahead);
          }
        add_transmitted_load(potential_cell->active_cell_index(),
                             lambda,
                             lambda_nonnegative,
                             own_look_ahead ? nullptr : &lambda_ahead);
        if (own_look_ahead)
          lambda_ahead = lambda;
      }

      // On the cells of J, the transmitted load g (TransmittedLoad) is
      // part of the multipliers.
      void
      add_transmitted_load(const unsigned int   index,
                           std::vector<double> &lambda,
                           std::vector<double> &lambda_nonnegative,
                           std::vector<double> *lambda_ahead = nullptr) const
      {
        if (!in.transmitted_load)
          return;
        const double *g       = in.transmitted_load->data() + index * n_q;
        const double *g_ahead = in.transmitted_load_ahead->data() + index * n_q;
        for (unsigned int q = 0; q < n_q; ++q)
          {
            lambda[q] += g[q];
            lambda_nonnegative[q] += g[q];
            if (lambda_ahead)
              (*lambda_ahead)[q] += g_ahead[q];
          }
      }

      // G = sum over boundary faces F of delta_F(t) (1 - n) in the
      // reference coordinates (t along F, n away from it), delta_F = g -
      // u_h on F: zero on the other faces (delta vanishes at the vertices,
      // where u_h interpolates g), so G is in H^1, and u_h + G = g on the
      // boundary.
      void
      add_lifting(const CellIterator  &potential_cell,
                  ContactScratch<dim> &scratch) const
      {
        FEValues<dim> &potential_values = scratch.potential_values;
        auto          &grad_u = scratch.grad_u, &grad_s = scratch.grad_s,
             &grad_G = scratch.grad_G;
        auto &u = scratch.u, &s = scratch.s, &G = scratch.G;
        lift_boundary_data(potential_cell,
                           potential_values,
                           scratch.face_values,
                           pairs.u,
                           pairs.g,
                           in.domain,
                           G,
                           grad_G);
        // From here on u_h stands for u_h + G, and s for s + G (s - u_h is
        // unchanged).
        for (unsigned int a = 0; a < 2; ++a)
          for (unsigned int q = 0; q < n_q; ++q)
            {
              u[a][q] += G[a][q];
              grad_u[a][q] += grad_G[a][q];
              s[a][q] += G[a][q];
              grad_s[a][q] += grad_G[a][q];
            }
      }

      // Over an obstacle, its values and gradient in place of membrane 2's
      // u2h and s2 (and no lifting of its boundary data): the gap, the
      // contact term and the cone reconstruction s~1 = max(s1, psi) are then
      // those of the obstacle itself, not of its interpolant.
      void
      set_obstacle_values(ContactScratch<dim> &scratch) const
      {
        const auto &points = scratch.potential_values.get_quadrature_points();
        for (unsigned int q = 0; q < n_q; ++q)
          {
            scratch.u[1][q] = scratch.s[1][q] = in.obstacle->value(points[q]);
            scratch.grad_u[1][q]              = scratch.grad_s[1][q] =
              in.obstacle->gradient(points[q]);
            scratch.G[1][q]      = 0;
            scratch.grad_G[1][q] = Tensor<1, dim>();
          }
      }

      // The flux, residual and algebraic terms of both membranes (of
      // membrane 1 over an obstacle) and the remainder; flux_total = eta_F
      // of each.
      void
      add_flux_residual_terms(const unsigned int   index,
                              const double         h_K,
                              ContactScratch<dim> &scratch,
                              double               flux_total[2],
                              ContactSums         &cell)
      {
        const FEValues<dim> &potential_values = scratch.potential_values;
        const auto &grad_u = scratch.grad_u, &sigma_disc = scratch.sigma_disc,
                   &sigma_ahead = scratch.sigma_ahead;
        const auto &r_ahead = scratch.r_ahead, &div_ahead = scratch.div_ahead,
                   &dt_u = scratch.dt_u, &dt_u_ahead = scratch.dt_u_ahead;
        const std::vector<double> &lambda       = scratch.lambda,
                                  &lambda_ahead = scratch.lambda_ahead;
        std::vector<double> &f                  = scratch.f;
        double flux_disc[2] = {}, residual[2] = {}, flux_cone[2] = {},
               algebraic = 0;
        const auto &s = scratch.s, &grad_s = scratch.grad_s;

        for (unsigned int a = 0; a < n_membranes; ++a)
          {
            // (-1)^alpha for alpha = a + 1: the multiplier pulls membrane 1
            // up and membrane 2 down.
            const double sign = (a == 0) ? -1. : 1.;
            if (load_values[a])
              std::copy_n(load_values[a]->begin() + index * n_q,
                          n_q,
                          f.begin());
            else
              pairs.f[a]->value_list(potential_values.get_quadrature_points(),
                                     f);
            for (unsigned int q = 0; q < n_q; ++q)
              {
                const double dx      = potential_values.JxW(q);
                const double sqrt_mu = std::sqrt(mu[a]);
                flux_total[a] +=
                  (sqrt_mu * grad_u[a][q] + sigma_ahead[a][q] / sqrt_mu)
                    .norm_square() *
                  dx;
                flux_disc[a] +=
                  (sqrt_mu * grad_u[a][q] + sigma_disc[a][q] / sqrt_mu)
                    .norm_square() *
                  dx;
                // grad s~_a, s~ = s + (theta w, -(1 - theta) w), w = (s2 -
                // s1)^+ (see add_nonconformity_contact_terms()), for the
                // second bound of an obstacle (bound_with_remainder())
                if (in.obstacle)
                  {
                    const Tensor<1, dim> grad_w =
                      (s[1][q] > s[0][q]) ? grad_s[1][q] - grad_s[0][q] :
                                            Tensor<1, dim>();
                    const Tensor<1, dim> grad_cone =
                      grad_s[a][q] + (a == 0 ? theta : -(1. - theta)) * grad_w;
                    flux_cone[a] +=
                      (sqrt_mu * grad_cone + sigma_ahead[a][q] / sqrt_mu)
                        .norm_square() *
                      dx;
                  }
                algebraic +=
                  (sigma_ahead[a][q] - sigma_disc[a][q]).norm_square() / mu[a] *
                  dx;
                residual[a] +=
                  std::pow(f[q] - dt_u_ahead[a][q] - sign * lambda_ahead[q] -
                             r_ahead[a][q] - div_ahead[a][q],
                           2) *
                  dx;
                const double rho = r_ahead[a][q] +
                                   sign * (lambda_ahead[q] - lambda[q]) +
                                   dt_u_ahead[a][q] - dt_u[a][q];
                cell.of_membrane(ContactSum::remainder_1, a) += rho * rho * dx;
                if (dt_vectors[a])
                  {
                    cell.of_membrane(ContactSum::energy_1, a) +=
                      mu[a] * grad_u[a][q].norm_square() * dx;
                    cell.of_membrane(ContactSum::load_1, a) +=
                      std::pow(f[q] - dt_u[a][q] - sign * lambda[q], 2) * dx;
                  }
                if (remainder)
                  remainders[a][index * n_q + q] = rho;
              }
            flux_total[a] = std::sqrt(flux_total[a]);
            flux_disc[a]  = std::sqrt(flux_disc[a]);
            residual[a] =
              h_K / numbers::PI / std::sqrt(mu[a]) * std::sqrt(residual[a]);
            cell[ContactSum::flux_residual_total] +=
              std::pow(flux_total[a] + residual[a], 2);
            if (dt_vectors[a])
              cell.of_membrane(ContactSum::flux_residual_1, a) +=
                std::pow(flux_total[a] + residual[a], 2);
            cell[ContactSum::flux_residual_disc] +=
              std::pow(flux_disc[a] + residual[a], 2);
            cell[ContactSum::flux_residual_cone] +=
              std::pow(std::sqrt(flux_cone[a]) + residual[a], 2);
            cell[ContactSum::flux_disc_squared] += std::pow(flux_disc[a], 2);
            cell[ContactSum::residual_squared] += std::pow(residual[a], 2);
          }
        cell[ContactSum::algebraic_squared] = algebraic;
      }

      // The non-conformity, contact and Dirichlet terms.
      void
      add_nonconformity_contact_terms(const ContactScratch<dim> &scratch,
                                      const MultiplierSplit     &split,
                                      ContactSums               &cell) const
      {
        const FEValues<dim> &potential_values = scratch.potential_values;
        const auto          &grad_u = scratch.grad_u, &grad_s = scratch.grad_s,
                   &grad_G           = scratch.grad_G;
        const auto                &u = scratch.u, &s = scratch.s;
        const std::vector<double> &lambda = scratch.lambda;
        // Non-conformity: s~ = s_h + (theta w, -(1 - theta) w), w = (s2 -
        // s1)^+, is in the cone; s_h - u_h vanishes once Newton has
        // converged, s~ - s_h is a discretisation term.
        for (unsigned int q = 0; q < n_q; ++q)
          {
            const double         dx     = potential_values.JxW(q);
            const Tensor<1, dim> grad_w = (s[1][q] > s[0][q]) ?
                                            grad_s[1][q] - grad_s[0][q] :
                                            Tensor<1, dim>();
            const Tensor<1, dim> d1     = grad_s[0][q] - grad_u[0][q],
                                 d2     = grad_s[1][q] - grad_u[1][q];
            const Tensor<1, dim> j1     = theta * grad_w,
                                 j2     = -(1 - theta) * grad_w;
            cell[ContactSum::nonc_total] += (mu[0] * (d1 + j1).norm_square() +
                                             mu[1] * (d2 + j2).norm_square()) *
                                            dx;
            cell[ContactSum::nonc_lin] +=
              (mu[0] * d1.norm_square() + mu[1] * d2.norm_square()) * dx;
            cell[ContactSum::nonc_disc] +=
              (mu[0] * j1.norm_square() + mu[1] * j2.norm_square()) * dx;

            const double positive_part = std::max(lambda[q], 0.);
            const double gap           = u[0][q] - u[1][q];
            cell[ContactSum::positive] += positive_part * positive_part * dx;
            cell[ContactSum::contact_total] += 2. * positive_part * gap * dx;
            cell[ContactSum::contact_cone] +=
              2. * split.cone_factor * positive_part *
              std::max(s[0][q] - s[1][q], 0.) * dx;
            cell[ContactSum::dirichlet_squared] +=
              (mu[0] * grad_G[0][q].norm_square() +
               mu[1] * grad_G[1][q].norm_square()) *
              dx;
            cell[ContactSum::contact_linearised] += 2. * lambda[q] * gap * dx;
          }
        if (in.obstacle && in.smooth_obstacle && !dt_vectors[0])
          add_obstacle_cross_term(scratch, cell);
      }

      // Over an obstacle (stationary): w = (psi - s1)^+, where s~ = psi.
      // With -mu1 Lap u = f1 + lambda and lambda = (-f1 - mu1 Lap psi) where
      // u = psi, 0 elsewhere (u and psi twice differentiable there),
      //   a(u - s~, w) = (f1 + lambda, w) - mu1 (grad psi, grad w)
      //               <= (f1 + (-f1 - mu1 Lap psi)^+, w)
      //                  - mu1 (grad psi, grad w),
      // which bound_with_remainder() uses to add |||u - s~||| and |||w||| in
      // quadrature. scratch.f holds f1 at the points (membrane 1 is the only
      // one add_flux_residual_terms() reads over an obstacle).
      void
      add_obstacle_cross_term(const ContactScratch<dim> &scratch,
                              ContactSums               &cell) const
      {
        const FEValues<dim> &values = scratch.potential_values;
        const auto          &s = scratch.s, &grad_s = scratch.grad_s;
        for (unsigned int q = 0; q < n_q; ++q)
          if (s[1][q] > s[0][q])
            {
              const Point<dim> &x = values.quadrature_point(q);
              const double      w = s[1][q] - s[0][q];
              const double      f = scratch.f[q];
              const double      load =
                std::max(-f - mu[0] * in.obstacle->laplacian(x), 0.);
              cell[ContactSum::cone_cross] +=
                ((f + load) * w -
                 mu[0] * grad_s[1][q] * (grad_s[1][q] - grad_s[0][q])) *
                values.JxW(q);
            }
      }

      const ContactEstimatorInput<dim>    &in;
      ContactEstimate                     &estimate;
      const Triangulation<dim>            &tria;
      const MembranePairs<dim>             pairs;
      const unsigned int                   n_q, n_tau;
      const TrilinosWrappers::MPI::Vector *r_vectors[2], *disc_vectors[2],
        *ahead_vectors[2];
      const std::vector<double>           *load_values[2];
      const TrilinosWrappers::MPI::Vector *dt_vectors[2], *dt_ahead_vectors[2];
      // The lifting G of g - I_h g on the cells at the boundary (see
      // add_lifting()) needs the values of u_h, g and the mapping on
      // the boundary faces, at the points that share the tangential
      // coordinate of the (tensor-product Gauss) cell quadrature points
      // (lifting_face_points()).
      const bool lifting;
      // An iterate estimated with itself as look-ahead (sigma_alg = 0): its
      // fluxes and multiplier are read once.
      const bool own_look_ahead;
      const bool with_fluxes;
      // The cell means m_K of the multiplier's undershoots (of lambda_h and of
      // lambda~), for the dual norm bound.
      const bool          undershoots;
      std::vector<double> means, means_disc;
      // The remainders rho_alpha at the quadrature points, for the same.
      const bool          remainder;
      std::vector<double> remainders[2];
      const bool          contact_linearised_needed;
      // The membranes with a flux: both, or membrane 1 over an obstacle.
      const unsigned int n_membranes = in.obstacle ? 1 : 2;
    };


    // The bound and its split for a bound of the remainder, which enters
    // eta_1, the cross terms and eta_alg: all of them grow with it.
    inline void
    bound_with_remainder(const ContactSums          &total,
                         const bool                  with_fluxes,
                         const double                remainder_bound,
                         const bool                  obstacle,
                         ContactEstimate            &e,
                         const std::optional<double> cone_cross = {})
    {
      e.remainder = remainder_bound;
      e.eta_1 =
        std::sqrt(total[ContactSum::flux_residual_total]) + remainder_bound;
      // Two bounds from (e, d) <= R D + c, d = u - s~, R = eta_1 + nonc_2,
      // c = eta_cone / 2, N = nonc_1 (doc/reference.md, "Flux and
      // non-conformity in quadrature"): |||e||| <= a/2 + (a^2/4 + b)^(1/2)
      // and |||e|||^2 <= R^2 + N^2 + 2 c. eta is the smaller; the split
      // below is the first's, which bounds both, so that the solvers stop
      // where they did (the second's lacks the cross term (R N)^(1/2) in
      // eta_lin and stopped Newton at rougher iterates).
      const double R = e.eta_1 + e.nonc_2;
      const double a = R + e.nonc_1;
      const double b = R * e.nonc_1 + 0.5 * e.contact_cone;
      const double quadratic =
        std::sqrt(std::max(R * R + e.nonc_1 * e.nonc_1 + e.contact_cone, 0.));
      // ... for u_h + G; and |||u - u_h||| <= |||u - (u_h + G)||| + |||G|||.
      e.eta = std::min(0.5 * a + std::sqrt(std::max(0.25 * a * a + b, 0.)),
                       quadratic) +
              e.dirichlet;
      // Over an obstacle also |||u - u_h||| <= |||u - s~||| + |||s~ - u_h|||,
      // the first bounded as above with grad s~ in the fluxes' place
      // (|||u - s~|||^2 <= a~ |||u - s~||| + eta_cone / 2): where the
      // membrane touches, u = s~ = psi, and the interpolation error of psi
      // is counted once, in eta_nonc1, instead of in eta_1 as well. Both
      // bounds hold; the smaller is taken.
      if (obstacle)
        {
          e.eta_1_cone =
            std::sqrt(total[ContactSum::flux_residual_cone]) + remainder_bound;
          const double a_cone = e.eta_1_cone + e.nonc_2;
          const double cone_error =
            0.5 * a_cone +
            std::sqrt(
              std::max(0.25 * a_cone * a_cone + 0.5 * e.contact_cone, 0.));
          e.eta = std::min(e.eta, cone_error + e.nonc_1 + e.dirichlet);
          // A third: with w = (psi - s1)^+ (so that s~ - u_h = (s1 - u_h)
          // + w), |||u - u_h||| <= |||u - s~ + w||| + |||s1 - u_h||| and
          // |||u - s~ + w|||^2 = |||u - s~|||^2 + |||w|||^2 + 2 a(u - s~, w),
          // the last bounded by cone_cross (stationary problems only): the
          // free part and the interpolation error of psi then add in
          // quadrature.
          if (cone_cross)
            e.eta = std::min(e.eta,
                             std::sqrt(cone_error * cone_error +
                                       e.nonc_1_disc * e.nonc_1_disc +
                                       2. * std::max(*cone_cross, 0.)) +
                               e.nonc_1_lin + e.dirichlet);
        }
      const auto cross = [&](const double nonc_1_part) {
        return std::sqrt((e.eta_1 + e.nonc_2) * nonc_1_part);
      };
      e.eta_disc = e.dirichlet + e.eta_1_disc + e.nonc_1_disc + e.nonc_2_disc +
                   cross(e.nonc_1_disc) +
                   std::sqrt(std::max(e.contact_disc, 0.) / 2.);
      // Without the fluxes eta_1 is unknown, and so is the cross term:
      // eta_lin is then a lower bound of the complete estimate's, and
      // eta_alg = eta_rem (sigma_alg = 0 for an iterate that is its own
      // look-ahead) with Friedrichs' inequality an upper bound (the complete
      // estimate may bound the remainder by equilibration, the smaller
      // bound).
      e.eta_lin = e.nonc_1_lin + e.nonc_2_lin +
                  (with_fluxes ? cross(e.nonc_1_lin) : 0.) +
                  std::sqrt(std::max(e.contact_lin, 0.) / 2.);
      e.eta_alg = e.flux_alg + e.remainder;
    }


    // The combination of the cell terms: the estimators from the global sums
    // and the final formula.
    template <int dim>
    void
    combine_contact_terms(const ContactCellTerms<dim> &terms,
                          const ContactSums           &total,
                          ContactEstimate             &e)
    {
      const ContactEstimatorInput<dim> &in          = terms.in;
      const double                      c_mu        = terms.c_mu;
      const double                      C           = terms.C;
      const bool                        undershoots = terms.undershoots;
      const bool                        with_fluxes = terms.with_fluxes;
      const bool                        remainder   = terms.remainder;
      const std::vector<double>        &means       = terms.means;
      const std::vector<double>        &means_disc  = terms.means_disc;
      const std::vector<double>        *remainders  = terms.remainders;
      // (Below 1 % of the discretisation flux and residual estimator, the
      // sharper bound of a dual norm changes eta by less than 1 %.)
      const double negligible =
        1e-2 * std::sqrt(total[ContactSum::flux_residual_disc]);
      const double friedrichs_remainder =
        in.friedrichs_constant *
        std::sqrt(total[ContactSum::remainder_1] / in.mu1 +
                  total[ContactSum::remainder_2] / in.mu2);
      e.flux_disc   = std::sqrt(total[ContactSum::flux_disc_squared]);
      e.residual    = std::sqrt(total[ContactSum::residual_squared]);
      e.flux_alg    = std::sqrt(total[ContactSum::algebraic_squared]);
      e.nonc_1      = std::sqrt(total[ContactSum::nonc_total]);
      e.nonc_1_disc = std::sqrt(total[ContactSum::nonc_disc]);
      e.nonc_1_lin  = std::sqrt(total[ContactSum::nonc_lin]);
      // |grad(w1 - w2)|_K <= c_mu |||w|||_K, |w1 - w2| <= C |||w|||, or
      // (m, w1 - w2) <= ||m||_{-1} c_mu |||w||| with the equilibrated bound.
      const auto mean_term = [&](const double               mean_squared,
                                 const std::vector<double> &cell_means) {
        if (undershoots && C * std::sqrt(mean_squared) > negligible)
          return c_mu * in.dual_norm->bound(cell_means);
        return C * std::sqrt(mean_squared);
      };
      e.nonc_2 = c_mu * std::sqrt(total[ContactSum::multiplier_local]) +
                 mean_term(total[ContactSum::multiplier_mean], means);
      e.nonc_2_disc =
        c_mu * std::sqrt(total[ContactSum::multiplier_local_disc]) +
        mean_term(total[ContactSum::multiplier_mean_disc], means_disc);
      // lambda_h = lambda~ once Newton has converged.
      e.nonc_2_lin                 = std::max(e.nonc_2 - e.nonc_2_disc, 0.);
      const double lambda_positive = std::sqrt(total[ContactSum::positive]);
      e.nonc_3                     = 2. * C * lambda_positive * e.nonc_1;
      e.contact_pos                = total[ContactSum::contact_total];
      e.contact_cone               = total[ContactSum::contact_cone];
      if (in.cell_multiplier || in.mass_lumped)
        {
          e.contact_lin  = in.complementarity;
          e.contact_disc = e.contact_cone - e.contact_lin;
        }
      else
        {
          // 2 (lambda, u1 - u2) vanishes with the discrete complementarity of
          // p >= 2; the rest is a discretisation term.
          e.contact_lin  = total[ContactSum::contact_linearised];
          e.contact_disc = e.contact_cone - e.contact_lin;
        }
      e.dirichlet  = std::sqrt(total[ContactSum::dirichlet_squared]);
      e.eta_1_disc = std::sqrt(total[ContactSum::flux_residual_disc]);
      for (unsigned int a = 0; a < 2; ++a)
        {
          e.flux_residual_squared[a] =
            total.of_membrane(ContactSum::flux_residual_1, a);
          e.energy_squared[a] = total.of_membrane(ContactSum::energy_1, a);
          e.load_squared[a]   = total.of_membrane(ContactSum::load_1, a);
          e.remainder_squared[a] =
            total.of_membrane(ContactSum::remainder_1, a);
        }
      e.multiplier_l2_squared = total[ContactSum::multiplier_l2];

      const bool                  obstacle = in.obstacle != nullptr;
      const std::optional<double> cone_cross =
        obstacle && in.smooth_obstacle && !terms.dt_vectors[0] ?
          std::optional<double>(total[ContactSum::cone_cross]) :
          std::nullopt;
      bound_with_remainder(
        total, with_fluxes, friedrichs_remainder, obstacle, e, cone_cross);
      // The dual norm bounds cost a Poisson solve and a reconstruction each
      // (the remainder's two fields share one):
      // they are computed only where Friedrichs' bound is not negligible,
      // above 1 % of the discretisation flux and residual estimator (either
      // bound is guaranteed; below that, the sharper one changes eta by less
      // than 1 %), and where the caller finds them worth it.
      if (remainder && with_fluxes && friedrichs_remainder > negligible &&
          (!in.sharpen_remainder || in.sharpen_remainder(e)))
        {
          // (rho_alpha, w_alpha) <= ||rho_alpha||_{-1} |grad w_alpha|
          const std::vector<double> rho =
            in.dual_norm->bounds_at_points({&remainders[0], &remainders[1]});
          bound_with_remainder(total,
                               with_fluxes,
                               std::sqrt(rho[0] * rho[0] / in.mu1 +
                                         rho[1] * rho[1] / in.mu2),
                               obstacle,
                               e,
                               cone_cross);
        }
      if (!with_fluxes)
        e.mark_unknown_terms();
    }
  } // namespace


  template <int dim>
  ContactEstimate
  estimate_contact_error(const ContactEstimatorInput<dim> &in)
  {
    ContactEstimate estimate;
    estimate.reinit_cell_indicators(
      in.potential->get_triangulation().n_active_cells());
    ContactCellTerms<dim> terms(in, estimate);

    ContactSums sums;
    const auto  worker =
      [&](const typename DoFHandler<dim>::active_cell_iterator &potential_cell,
          ContactScratch<dim>                                  &scratch,
          CellShare                                            &share) {
        terms.cell_terms(potential_cell, scratch, share);
      };
    const auto copier = [&](const CellShare &share) { sums += share.cell; };
    WorkStream::run(filter_iterators(in.potential->active_cell_iterators(),
                                     IteratorFilters::LocallyOwnedCell()),
                    worker,
                    copier,
                    ContactScratch<dim>(in, terms.lifting),
                    CellShare(),
                    /*queue_length=*/2 * MultithreadInfo::n_threads(),
                    /*chunk_size=*/32);

    combine_contact_terms(terms,
                          sums.sum_over_processes(
                            in.potential->get_communicator()),
                          estimate);
    return estimate;
  }


  template ContactEstimate
  estimate_contact_error(const ContactEstimatorInput<2> &);
} // namespace VI
