#include <deal.II/base/mpi.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_values.h>

#include <vi/dg_estimators.h>
#include <vi/domain.h>
#include <vi/piola_divergence.h>
#include <vi/same_cell.h>

#include "contact_estimator_internal.h"

#include <array>
#include <cmath>
#include <memory>

namespace VI
{
  using namespace dealii;

  template <int dim>
  double
  jump_seminorm(const Mapping<dim>                  &mapping,
                const DoFHandler<dim>               &broken,
                const Quadrature<dim - 1>           &face_quadrature,
                const InteriorPenalty               &penalty,
                const double                         mu1,
                const double                         mu2,
                const TrilinosWrappers::MPI::Vector &v1,
                const TrilinosWrappers::MPI::Vector &v2,
                const Function<dim>                 &g1,
                const Function<dim>                 &g2,
                dealii::Vector<float>               *cellwise,
                const Domain                        *domain)
  {
    FEInterfaceValues<dim>               interface(mapping,
                                     broken.get_fe(),
                                     face_quadrature,
                                     update_values | update_JxW_values |
                                       update_quadrature_points);
    FEFaceValues<dim>                    boundary(mapping,
                               broken.get_fe(),
                               face_quadrature,
                               update_values | update_JxW_values |
                                 update_quadrature_points);
    const unsigned int                   n_q = face_quadrature.size();
    std::vector<double>                  here(n_q), there(n_q);
    const TrilinosWrappers::MPI::Vector *v[2]  = {&v1, &v2};
    const Function<dim>                 *g[2]  = {&g1, &g2};
    const double                         mu[2] = {mu1, mu2};

    if (cellwise)
      cellwise->reinit(broken.get_triangulation().n_active_cells());
    double local = 0;
    for (const auto &cell : broken.active_cell_iterators())
      {
        if (!cell->is_locally_owned())
          continue;
        double cell_sum = 0;
        // mu gamma_F / h_F |[[v]]|^2 on a boundary face, half of it on an
        // interior one (each is seen from both sides).
        const auto add_jumps = [&](const FEFaceValuesBase<dim> &values,
                                   const bool                   at_boundary,
                                   const double                 gamma) {
          const double weight = at_boundary ? 1. : 0.5;
          for (unsigned int a = 0; a < 2; ++a)
            {
              values.get_function_values(*v[a], here);
              if (at_boundary)
                for (unsigned int q = 0; q < n_q; ++q)
                  there[q] = g[a]->value(values.quadrature_point(q));
              else
                interface.get_fe_face_values(1).get_function_values(*v[a],
                                                                    there);
              for (unsigned int q = 0; q < n_q; ++q)
                cell_sum += weight * mu[a] * gamma *
                            std::pow(here[q] - there[q], 2) * values.JxW(q);
            }
        };
        for (const unsigned int f : cell->face_indices())
          if (cell->at_boundary(f))
            {
              if (domain && !domain->is_clamped(cell->face(f)->boundary_id()))
                continue; // (free: no jump)
              boundary.reinit(cell, f);
              add_jumps(boundary,
                        true,
                        penalty.penalty(
                          InteriorPenalty::normal_extent<dim>(cell, f)));
            }
          else
            InteriorPenalty::for_each_face_part<dim>(
              interface, cell, f, [&](const unsigned int subface) {
                add_jumps(interface.get_fe_face_values(0),
                          false,
                          penalty.penalty(InteriorPenalty::normal_extent<dim>(
                            cell, f, subface)));
              });
        local += cell_sum;
        if (cellwise)
          (*cellwise)(cell->active_cell_index()) = cell_sum;
      }
    return std::sqrt(
      Utilities::MPI::sum(local,
                          broken.get_triangulation().get_communicator()));
  }


  namespace
  {
    // The global sums of the estimate (EstimateSums).
    enum class DGSum : unsigned int
    {
      flux_residual,    // sum (eta_F + eta_R)^2
      flux_squared,     // sum eta_F^2
      residual_squared, // sum eta_R^2
      remainder_1,      // |r1|^2
      remainder_2,      // |r2|^2
      // the multiplier's sums (add_multiplier_sums())
      multiplier_local,
      multiplier_mean,
      multiplier_local_disc,
      multiplier_mean_disc,
      nonc_total,        // |||s~ - u_h|||_h^2
      nonc_lin,          // |||s - oswald|||^2 (the averaging at violated nodes)
      nonc_disc,         // |||s~ - u_h - (s - oswald)|||_h^2
      nonc_cone,         // |||s~ - (s + G)|||^2
      oswald_squared,    // |||s - u_h|||_h^2
      positive,          // |lambda^pos|^2
      contact_total,     // 2 (lambda^pos, u1h - u2h)
      contact_cone,      // 2 (c_K lambda^pos, s~1 - s~2)
      contact_discrete,  // 2 (lambda, u1h - u2h)
      dirichlet_squared, // |||G|||^2
      n_sums
    };
    using DGSums = EstimateSums<DGSum>;

    // The cell terms of the DG contact estimate, the per-cell quadrature
    // work: the values of u_h, s_h, the fluxes and the multipliers at the
    // quadrature points of a cell, the lifting G of the boundary data, and
    // the terms of the cell.
    template <int dim>
    struct DGCellTerms : MembraneConstants
    {
      explicit DGCellTerms(const DGContactEstimatorInput<dim> &in)
          : MembraneConstants(in.mu1, in.mu2, in.friedrichs_constant)
          , in(in)
          , pairs(in)
          , n_q(in.quadrature->size())
          , broken_values(*in.mapping,
                          in.broken->get_fe(),
                          *in.quadrature,
                          update_values | update_gradients |
                            update_quadrature_points | update_JxW_values)
          , continuous_values(*in.mapping,
                              in.continuous->get_fe(),
                              *in.quadrature,
                              update_values | update_gradients |
                                update_inverse_jacobians)
          , flux_values(*in.mapping,
                        in.flux->get_fe(),
                        *in.quadrature,
                        PiolaDivergence<dim>::update_flags())
          , divergence(in.flux->get_fe(), *in.quadrature)
          , sigma_coefficients(in.flux->get_fe().n_dofs_per_cell())
          , f(n_q)
          , lambda(n_q)
          , lambda_nonnegative(n_q)
          , r_vectors{in.r1, in.r2}
          , flux_vectors{in.sigma1, in.sigma2}
      {
        for (unsigned int a = 0; a < 2; ++a)
          {
            for (auto *v :
                 {&grad_u[a], &grad_s[a], &grad_averaging[a], &flux[a]})
              v->resize(n_q);
            for (auto *v : {&u[a], &s[a], &r[a], &div_flux[a]})
              v->resize(n_q);
          }
        // The lifting G of g - s_h into the cells at the boundary: s_h
        // interpolates g at the boundary nodes only. On a cell with a boundary
        // face F, G = delta_F(t) (1 - n) in the reference coordinates (t along
        // F, n away from it), delta_F = g - s_h on F; delta vanishes at the
        // vertices, so G is continuous and s_h + G = g on the boundary. Face
        // values at the points that share the tangential coordinate of the
        // (tensor-product Gauss) cell quadrature points.
        for (unsigned int face = 0; face < GeometryInfo<dim>::faces_per_cell;
             ++face)
          face_values.emplace_back(
            std::make_unique<FEValues<dim>>(*in.mapping,
                                            in.continuous->get_fe(),
                                            lifting_face_points<dim>(n_q, face),
                                            update_values | update_gradients |
                                              update_jacobians |
                                              update_quadrature_points));
        for (unsigned int a = 0; a < 2; ++a)
          {
            G[a].resize(n_q);
            grad_G[a].resize(n_q);
          }
      }

      // The values at the quadrature points of the cell, and G.
      void
      read_values(
        const typename DoFHandler<dim>::active_cell_iterator &broken_cell)
      {
        const auto continuous_cell = same_cell(broken_cell, *in.continuous),
                   flux_cell       = same_cell(broken_cell, *in.flux);
        broken_values.reinit(broken_cell);
        continuous_values.reinit(continuous_cell);
        flux_values.reinit(flux_cell);
        divergence.reinit(flux_values);
        for (unsigned int a = 0; a < 2; ++a)
          {
            broken_values.get_function_values(*pairs.u[a], u[a]);
            broken_values.get_function_gradients(*pairs.u[a], grad_u[a]);
            broken_values.get_function_values(*r_vectors[a], r[a]);
            continuous_values.get_function_values(*pairs.s[a], s[a]);
            continuous_values.get_function_gradients(*pairs.s[a], grad_s[a]);
            // grad (s - oswald): the averaging at the violated nodes
            if (oswald[0])
              {
                continuous_values.get_function_gradients(*oswald[a],
                                                         grad_averaging[a]);
                for (unsigned int q = 0; q < n_q; ++q)
                  grad_averaging[a][q] = grad_s[a][q] - grad_averaging[a][q];
              }
            divergence.function_values_and_divergences(flux_values,
                                                       flux_cell,
                                                       *flux_vectors[a],
                                                       sigma_coefficients,
                                                       flux[a],
                                                       div_flux[a]);
          }
        broken_values.get_function_values(*in.lambda, lambda);
        broken_values.get_function_values(*in.lambda_nonnegative,
                                          lambda_nonnegative);
        if (in.transmitted_load)
          {
            const double *g = in.transmitted_load->data() +
                              broken_cell->active_cell_index() * lambda.size();
            for (unsigned int q = 0; q < lambda.size(); ++q)
              {
                lambda[q] += g[q];
                lambda_nonnegative[q] += g[q];
              }
          }

        lift_boundary_data(continuous_cell,
                           continuous_values,
                           face_values,
                           pairs.s,
                           pairs.g,
                           in.domain,
                           G,
                           grad_G);
      }

      // The flux and residual terms of both membranes, and the remainder;
      // flux_norm = eta_F of each.
      void
      add_flux_residual_terms(const double h_K,
                              DGSums      &cell,
                              double       flux_norm[2])
      {
        double residual[2] = {};
        for (unsigned int a = 0; a < 2; ++a)
          {
            // (-1)^alpha for alpha = a + 1.
            const double sign    = (a == 0) ? -1. : 1.;
            const double sqrt_mu = std::sqrt(mu[a]);
            pairs.f[a]->value_list(broken_values.get_quadrature_points(), f);
            for (unsigned int q = 0; q < n_q; ++q)
              {
                const double dx = broken_values.JxW(q);
                flux_norm[a] += (sqrt_mu * grad_u[a][q] + flux[a][q] / sqrt_mu)
                                  .norm_square() *
                                dx;
                residual[a] +=
                  std::pow(f[q] - sign * lambda[q] - r[a][q] - div_flux[a][q],
                           2) *
                  dx;
                cell.of_membrane(DGSum::remainder_1, a) +=
                  r[a][q] * r[a][q] * dx;
              }
            flux_norm[a] = std::sqrt(flux_norm[a]);
            residual[a]  = h_K / numbers::PI / sqrt_mu * std::sqrt(residual[a]);
            cell[DGSum::flux_residual] +=
              std::pow(flux_norm[a] + residual[a], 2);
            cell[DGSum::flux_squared] += std::pow(flux_norm[a], 2);
            cell[DGSum::residual_squared] += std::pow(residual[a], 2);
          }
      }

      MultiplierSplit
      add_multiplier_terms(const double h_K, DGSums &cell) const
      {
        return add_multiplier_sums(lambda,
                                   lambda_nonnegative,
                                   broken_values.get_JxW_values(),
                                   h_K,
                                   cell)
          .first;
      }

      void
      add_cone_terms(const MultiplierSplit &split, DGSums &cell) const
      {
        // The cone reconstruction s~ = (s + G) + (theta w, -(1 - theta) w),
        // w = ((s2 + G2) - (s1 + G1))^+: s~1 - s~2 = ((s1 + G1) - (s2 +
        // G2))^+ >= 0 and s~ = g on the boundary, i.e. s~ is in K_g.
        for (unsigned int q = 0; q < n_q; ++q)
          {
            const double         dx = broken_values.JxW(q);
            const double         S1 = s[0][q] + G[0][q], S2 = s[1][q] + G[1][q];
            const Tensor<1, dim> grad_S1 = grad_s[0][q] + grad_G[0][q],
                                 grad_S2 = grad_s[1][q] + grad_G[1][q];
            const Tensor<1, dim> grad_w =
              (S2 > S1) ? grad_S2 - grad_S1 : Tensor<1, dim>();
            const Tensor<1, dim> d1 = grad_S1 + theta * grad_w - grad_u[0][q],
                                 d2 = grad_S2 - (1 - theta) * grad_w -
                                      grad_u[1][q];
            cell[DGSum::nonc_total] +=
              (mu[0] * d1.norm_square() + mu[1] * d2.norm_square()) * dx;
            if (oswald[0])
              {
                const Tensor<1, dim> &a1 = grad_averaging[0][q],
                                     &a2 = grad_averaging[1][q];
                cell[DGSum::nonc_lin] +=
                  (mu[0] * a1.norm_square() + mu[1] * a2.norm_square()) * dx;
                cell[DGSum::nonc_disc] += (mu[0] * (d1 - a1).norm_square() +
                                           mu[1] * (d2 - a2).norm_square()) *
                                          dx;
              }
            cell[DGSum::nonc_cone] +=
              (mu[0] * theta * theta + mu[1] * (1 - theta) * (1 - theta)) *
              grad_w.norm_square() * dx;
            cell[DGSum::oswald_squared] +=
              (mu[0] * (grad_s[0][q] - grad_u[0][q]).norm_square() +
               mu[1] * (grad_s[1][q] - grad_u[1][q]).norm_square()) *
              dx;

            const double positive_part = std::max(lambda[q], 0.);
            const double gap           = u[0][q] - u[1][q];
            cell[DGSum::positive] += positive_part * positive_part * dx;
            cell[DGSum::contact_total] += 2. * positive_part * gap * dx;
            cell[DGSum::contact_cone] += 2. * split.cone_factor *
                                         positive_part * std::max(S1 - S2, 0.) *
                                         dx;
            cell[DGSum::contact_discrete] += 2. * lambda[q] * gap * dx;
            cell[DGSum::dirichlet_squared] +=
              (mu[0] * grad_G[0][q].norm_square() +
               mu[1] * grad_G[1][q].norm_square()) *
              dx;
          }
      }

      const DGContactEstimatorInput<dim> &in;
      const MembranePairs<dim>            pairs;
      const unsigned int                  n_q;
      FEValues<dim>               broken_values, continuous_values, flux_values;
      PiolaDivergence<dim>        divergence;
      std::vector<double>         sigma_coefficients;
      std::vector<Tensor<1, dim>> grad_u[2], grad_s[2], grad_averaging[2],
        flux[2];
      std::vector<double> u[2], s[2], r[2], div_flux[2], f, lambda,
        lambda_nonnegative;
      const TrilinosWrappers::MPI::Vector *r_vectors[2], *flux_vectors[2];
      const TrilinosWrappers::MPI::Vector *oswald[2] = {in.oswald1, in.oswald2};
      std::vector<std::unique_ptr<FEValues<dim>>> face_values;
      std::vector<double>                         G[2];
      std::vector<Tensor<1, dim>>                 grad_G[2];
    };


    // The combination of the cell terms: the jumps and the estimators from
    // the global sums, and the final formula.
    template <int dim>
    void
    combine_dg_terms(const DGContactEstimatorInput<dim> &in,
                     const DGSums                       &total,
                     const double                        c_mu,
                     const double                        C,
                     DGContactEstimate                  &e)
    {
      // The jumps, and their share of the local indicators.
      dealii::Vector<float> cell_jumps;
      e.jump = jump_seminorm(*in.mapping,
                             *in.broken,
                             *in.face_quadrature,
                             *in.penalty,
                             in.mu1,
                             in.mu2,
                             *in.u1,
                             *in.u2,
                             *in.g1,
                             *in.g2,
                             &cell_jumps,
                             in.domain);
      for (unsigned int c = 0; c < cell_jumps.size(); ++c)
        e.cell_total(c) += cell_jumps(c);

      e.remainder =
        in.friedrichs_constant * std::sqrt(total[DGSum::remainder_1] / in.mu1 +
                                           total[DGSum::remainder_2] / in.mu2);
      const double eta_flux = std::sqrt(total[DGSum::flux_residual]);
      e.eta_1               = eta_flux + e.remainder;
      e.flux_disc           = std::sqrt(total[DGSum::flux_squared]);
      e.residual            = std::sqrt(total[DGSum::residual_squared]);
      e.flux_alg            = 0;
      e.nonc_1              = std::sqrt(total[DGSum::nonc_total]);
      // |||s~ - u_h||| <= |||s~ - u_h - (s - oswald)||| + |||s - oswald|||
      e.nonc_1_disc =
        in.oswald1 ? std::sqrt(total[DGSum::nonc_disc]) : e.nonc_1;
      e.nonc_1_lin = in.oswald1 ? std::sqrt(total[DGSum::nonc_lin]) : 0.;
      e.oswald     = std::sqrt(total[DGSum::oswald_squared]);
      // |grad(w1 - w2)|_K <= c_mu |||w|||_K, |w1 - w2| <= C |||w||| (w in
      // H^1_0).
      e.nonc_2 = c_mu * std::sqrt(total[DGSum::multiplier_local]) +
                 C * std::sqrt(total[DGSum::multiplier_mean]);
      e.nonc_2_disc = c_mu * std::sqrt(total[DGSum::multiplier_local_disc]) +
                      C * std::sqrt(total[DGSum::multiplier_mean_disc]);
      e.nonc_2_lin   = std::max(e.nonc_2 - e.nonc_2_disc, 0.);
      e.nonc_3       = 2. * C * std::sqrt(total[DGSum::positive]) * e.nonc_1;
      e.contact_pos  = total[DGSum::contact_total];
      e.contact_cone = total[DGSum::contact_cone];
      // 2 <lambda_h, u1h - u2h>_h vanishes with the discrete complementarity;
      // the rest is discretisation. With the nodal multiplier it is given,
      // otherwise (lambda, u1h - u2h) is that bracket (the dual basis).
      e.contact_lin =
        in.mass_lumped ? in.complementarity : total[DGSum::contact_discrete];
      e.contact_disc = e.contact_cone - e.contact_lin;
      e.dirichlet    = std::sqrt(total[DGSum::dirichlet_squared]);

      // Two bounds of |||e|||_h, e = u - u_h, from the same inequality
      // (e, d) <= R D + c, d = u - s~, D = |||d|||, R = eta_1 + nonc_2,
      // c = eta_cone / 2, N = nonc_1 = |||s~ - u_h||| (doc/reference.md,
      // "The estimate of dG and HHO"):
      // - Cauchy-Schwarz on (e, s~ - u_h): |||e|||^2 <= a |||e||| + b,
      //   |||e||| <= a/2 + (a^2/4 + b)^(1/2);
      // - the identity |||e|||^2 = D^2 + 2 (s~ - u_h, d) + N^2 with the
      //   inequality for (s~ - u_h, d) = (e, d) - D^2: |||e|||^2 <= 2 R D -
      //   D^2 + N^2 + 2 c <= R^2 + N^2 + 2 c.
      // The second adds the flux and the non-conformity in quadrature and
      // is the smaller one unless the contact term dominates; the bound is
      // the smaller of the two. The jumps of the error are those of u_h.
      const double R = e.eta_1 + e.nonc_2;
      const double a = R + e.nonc_1;
      const double b = R * e.nonc_1 + 0.5 * e.contact_cone;
      const double additive =
        0.5 * a + std::sqrt(std::max(0.25 * a * a + b, 0.));
      const double quadratic =
        std::sqrt(std::max(R * R + e.nonc_1 * e.nonc_1 + e.contact_cone, 0.));
      e.broken = std::min(additive, quadratic);
      e.eta    = std::sqrt(e.broken * e.broken + e.jump * e.jump);

      // Components: broken <= D + L + A, and (broken^2 + J^2)^(1/2) <=
      // (D^2 + J^2)^(1/2) + L + A. R <= (eta_flux + nonc_2_disc) +
      // nonc_2_lin + remainder, nonc_1 <= nonc_1_disc + nonc_1_lin, and the
      // contact term splits as contact_disc + contact_lin.
      // - additive: a/2 + (a^2/4 + b)^(1/2) <= a + b^(1/2), with the cross
      //   term sqrt(R nonc_1) split along nonc_1;
      // - quadratic: the Euclidean norm of (R, nonc_1, contact^(1/2)) is at
      //   most the sum of those of the parts (Minkowski).
      const double contact_disc = std::max(e.contact_disc, 0.);
      const double contact_lin  = std::max(e.contact_lin, 0.);
      double       D, L;
      if (quadratic <= additive)
        {
          D = std::sqrt(std::pow(eta_flux + e.nonc_2_disc, 2) +
                        std::pow(e.nonc_1_disc, 2) + contact_disc);
          L = std::sqrt(std::pow(e.nonc_2_lin, 2) + std::pow(e.nonc_1_lin, 2) +
                        contact_lin);
        }
      else
        {
          const auto cross = [&](const double nonc_1_part) {
            return std::sqrt(R * nonc_1_part);
          };
          D = eta_flux + e.nonc_1_disc + e.nonc_2_disc + cross(e.nonc_1_disc) +
              std::sqrt(contact_disc / 2.);
          L = e.nonc_1_lin + cross(e.nonc_1_lin) + e.nonc_2_lin +
              std::sqrt(contact_lin / 2.);
        }
      e.broken_disc = D;
      e.eta_disc    = std::sqrt(D * D + e.jump * e.jump);
      e.eta_lin     = L;
      e.eta_alg     = e.remainder;
    }
  } // namespace


  template <int dim>
  DGContactEstimate
  estimate_dg_contact_error(const DGContactEstimatorInput<dim> &in)
  {
    const Triangulation<dim> &tria = in.broken->get_triangulation();

    DGContactEstimate estimate;
    estimate.reinit_cell_indicators(tria.n_active_cells());
    DGCellTerms<dim> terms(in);
    const double     c_mu = terms.c_mu;
    const double     C    = terms.C;
    DGSums           sums;

    for (const auto &broken_cell : in.broken->active_cell_iterators())
      {
        if (!broken_cell->is_locally_owned())
          continue;
        terms.read_values(broken_cell);

        const double h_K   = broken_cell->diameter();
        const auto   index = broken_cell->active_cell_index();
        DGSums       cell;
        double       flux_norm[2] = {};
        terms.add_flux_residual_terms(h_K, cell, flux_norm);
        const MultiplierSplit split = terms.add_multiplier_terms(h_K, cell);
        terms.add_cone_terms(split, cell);

        sums += cell;
        estimate.cell_flux(index) =
          std::pow(flux_norm[0], 2) + std::pow(flux_norm[1], 2);
        estimate.cell_residual(index)      = cell[DGSum::residual_squared];
        estimate.cell_algebraic(index)     = 0;
        estimate.cell_nonconformity(index) = cell[DGSum::nonc_total];
        estimate.cell_contact(index)       = cell[DGSum::contact_cone];
        estimate.cell_total(index) =
          cell[DGSum::flux_residual] + cell[DGSum::nonc_total] +
          c_mu * c_mu * cell[DGSum::multiplier_local] +
          C * C * cell[DGSum::multiplier_mean] + cell[DGSum::contact_cone];
      }

    combine_dg_terms(
      in, sums.sum_over_processes(tria.get_communicator()), c_mu, C, estimate);
    return estimate;
  }


  template DGContactEstimate
  estimate_dg_contact_error(const DGContactEstimatorInput<2> &);
  template double
  jump_seminorm(const Mapping<2> &,
                const DoFHandler<2> &,
                const Quadrature<1> &,
                const InteriorPenalty &,
                const double,
                const double,
                const TrilinosWrappers::MPI::Vector &,
                const TrilinosWrappers::MPI::Vector &,
                const Function<2> &,
                const Function<2> &,
                dealii::Vector<float> *,
                const Domain *);
} // namespace VI
