// The pieces that the contact estimators of estimators.cc and
// dg_estimators.cc share: the lifting of the Dirichlet data on the boundary
// cells, the split of the multiplier, the averaged potentials s_h and the
// cell indicators of an estimate.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>

#include <vi/domain.h>
#include <vi/estimators.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace VI
{
  using namespace dealii;


  template <int dim>
  Quadrature<dim>
  lifting_face_points(const unsigned int n_q, const unsigned int face)
  {
    const unsigned int n_1d = std::lround(std::sqrt(double(n_q)));
    AssertThrow(dim == 2 && n_1d * n_1d == n_q,
                ExcMessage("The Dirichlet lifting needs a 2d "
                           "tensor-product Gauss quadrature."));
    const QGauss<1>         gauss_1d(n_1d);
    std::vector<Point<dim>> points(n_1d);
    for (unsigned int k = 0; k < n_1d; ++k)
      {
        points[k][face / 2]     = double(face % 2);
        points[k][1 - face / 2] = gauss_1d.point(k)[0];
      }
    return Quadrature<dim>(points, std::vector<double>(n_1d, 1.));
  }


  template <int dim>
  void
  add_face_lifting(const FEValues<dim>                 &cell_values,
                   const FEValues<dim>                 &face_values,
                   const unsigned int                   face,
                   const TrilinosWrappers::MPI::Vector &v,
                   const Function<dim>                 &g,
                   std::vector<double>                 &G,
                   std::vector<Tensor<1, dim>>         &grad_G)
  {
    const unsigned int          n_1d = face_values.n_quadrature_points;
    std::vector<double>         face_v(n_1d);
    std::vector<Tensor<1, dim>> face_grad_v(n_1d);
    face_values.get_function_values(v, face_v);
    face_values.get_function_gradients(v, face_grad_v);
    const unsigned int normal = face / 2, tangent = 1 - normal;
    for (const unsigned int q : cell_values.quadrature_point_indices())
      {
        // cell point (x0, x1) = (p_(q % n), p_(q / n))
        const unsigned int k  = tangent == 0 ? q % n_1d : q / n_1d;
        const double       xn = cell_values.get_quadrature().point(q)[normal];
        const double       weight = (face % 2) ? xn : 1. - xn;
        const Point<dim>  &y      = face_values.quadrature_point(k);
        Tensor<1, dim>     along;
        for (unsigned int d = 0; d < dim; ++d)
          along[d] = face_values.jacobian(k)[d][tangent];
        const double   delta       = g.value(y) - face_v[k];
        const double   delta_prime = (g.gradient(y) - face_grad_v[k]) * along;
        Tensor<1, dim> reference_gradient;
        reference_gradient[tangent] = delta_prime * weight;
        reference_gradient[normal]  = (face % 2) ? delta : -delta;
        G[q] += delta * weight;
        const auto &inverse = cell_values.inverse_jacobian(q);
        for (unsigned int d = 0; d < dim; ++d)
          for (unsigned int e = 0; e < dim; ++e)
            grad_G[q][d] += inverse[e][d] * reference_gradient[e];
      }
  }


  template <int dim>
  void
  lift_boundary_data(
    const typename DoFHandler<dim>::active_cell_iterator &cell,
    const FEValues<dim>                                  &cell_values,
    const std::vector<std::unique_ptr<FEValues<dim>>>    &face_values,
    const TrilinosWrappers::MPI::Vector *const            v[2],
    const Function<dim> *const                            g[2],
    const Domain                                         *domain,
    std::vector<double>                                   G[2],
    std::vector<Tensor<1, dim>>                           grad_G[2])
  {
    for (unsigned int a = 0; a < 2; ++a)
      {
        std::fill(G[a].begin(), G[a].end(), 0.);
        std::fill(grad_G[a].begin(), grad_G[a].end(), Tensor<1, dim>());
      }
    if (g[0] && g[1] && cell->at_boundary())
      for (const unsigned int f : cell->face_indices())
        if (cell->face(f)->at_boundary() &&
            (domain == nullptr ||
             domain->is_clamped(cell->face(f)->boundary_id())))
          {
            FEValues<dim> &on_face = *face_values[f];
            on_face.reinit(cell);
            for (unsigned int a = 0; a < 2; ++a)
              add_face_lifting(
                cell_values, on_face, f, *v[a], *g[a], G[a], grad_G[a]);
          }
  }


  namespace
  {
    // Every cellwise indicator of an estimate.
    std::array<dealii::Vector<double> *, 6>
    indicators(ContactEstimate &e)
    {
      return {{&e.cell_flux,
               &e.cell_residual,
               &e.cell_algebraic,
               &e.cell_nonconformity,
               &e.cell_contact,
               &e.cell_total}};
    }
  } // namespace


  void
  ContactEstimate::reinit_cell_indicators(const unsigned int n_cells)
  {
    for (dealii::Vector<double> *indicator : indicators(*this))
      indicator->reinit(n_cells);
  }


  void
  ContactEstimate::mark_unknown_terms()
  {
    constexpr double unknown = std::numeric_limits<double>::quiet_NaN();
    complete                 = false;
    // (and the terms the cells without |||s_h - u_h||| skipped)
    for (double *term : {&eta,
                         &eta_disc,
                         &eta_1,
                         &eta_1_disc,
                         &flux_disc,
                         &residual,
                         &flux_alg,
                         &nonc_1,
                         &nonc_1_disc,
                         &nonc_3,
                         &contact_pos,
                         &contact_cone,
                         &contact_disc,
                         &dirichlet})
      *term = unknown;
    flux_residual_squared.fill(unknown);
    for (dealii::Vector<double> *indicator : indicators(*this))
      std::fill(indicator->begin(), indicator->end(), unknown);
  }


  MultiplierSplit
  split_multiplier(const std::vector<double> &lambda,
                   const std::vector<double> &JxW)
  {
    AssertDimension(lambda.size(), JxW.size());
    double measure = 0, integral = 0, positive_integral = 0;
    for (unsigned int q = 0; q < lambda.size(); ++q)
      {
        measure += JxW[q];
        integral += lambda[q] * JxW[q];
        positive_integral += std::max(lambda[q], 0.) * JxW[q];
      }
    MultiplierSplit split;
    split.cone_factor  = integral > 0 ? integral / positive_integral : 0.;
    const double mean  = std::min(integral, 0.) / measure;
    split.mean         = mean;
    split.mean_squared = mean * mean * measure;
    for (unsigned int q = 0; q < lambda.size(); ++q)
      {
        const double delta =
          lambda[q] - split.cone_factor * std::max(lambda[q], 0.);
        split.oscillation_squared += std::pow(delta - mean, 2) * JxW[q];
      }
    return split;
  }


  void
  average_at_violated_nodes(const double                         mu1,
                            const double                         mu2,
                            const TrilinosWrappers::MPI::Vector &u1,
                            const TrilinosWrappers::MPI::Vector &u2,
                            TrilinosWrappers::MPI::Vector       &s1,
                            TrilinosWrappers::MPI::Vector       &s2)
  {
    const double *x1 = u1.begin(), *x2 = u2.begin();
    double       *y1 = s1.begin(), *y2 = s2.begin();
    for (std::size_t k = 0; k < u1.locally_owned_size(); ++k)
      if (x1[k] < x2[k])
        y1[k] = y2[k] = (mu1 * x1[k] + mu2 * x2[k]) / (mu1 + mu2);
      else
        {
          y1[k] = x1[k];
          y2[k] = x2[k];
        }
  }


  double
  nodal_complementarity(const TrilinosWrappers::MPI::Vector &moments,
                        const TrilinosWrappers::MPI::Vector &u1,
                        const TrilinosWrappers::MPI::Vector &u2)
  {
    TrilinosWrappers::MPI::Vector gap(u1);
    gap -= u2;
    const double product = moments * gap;
    const double scale =
      moments.l1_norm() * std::max(u1.linfty_norm(), u2.linfty_norm());
    return std::abs(product) > 1e-12 * scale ? 2. * product : 0.;
  }


  std::vector<std::pair<std::string, dealii::Vector<float>>>
  cell_indicators(const ContactEstimate &e)
  {
    std::vector<std::pair<std::string, dealii::Vector<float>>> fields;
    for (const auto &[name, squares] :
         {std::make_pair("eta", &e.cell_total),
          std::make_pair("eta_flux", &e.cell_flux),
          std::make_pair("eta_residual", &e.cell_residual),
          std::make_pair("eta_algebraic", &e.cell_algebraic),
          std::make_pair("eta_nonconformity", &e.cell_nonconformity)})
      {
        dealii::Vector<float> root(squares->size());
        for (unsigned int c = 0; c < squares->size(); ++c)
          root(c) = std::sqrt(std::abs((*squares)(c)));
        fields.emplace_back(name, std::move(root));
      }
    fields.emplace_back("eta_contact",
                        dealii::Vector<float>(e.cell_contact.begin(),
                                              e.cell_contact.end()));
    return fields;
  }


  template Quadrature<2>
  lifting_face_points<2>(const unsigned int, const unsigned int);
  template void
  add_face_lifting<2>(const FEValues<2> &,
                      const FEValues<2> &,
                      const unsigned int,
                      const TrilinosWrappers::MPI::Vector &,
                      const Function<2> &,
                      std::vector<double> &,
                      std::vector<Tensor<1, 2>> &);
  template void
  lift_boundary_data<2>(const DoFHandler<2>::active_cell_iterator &,
                        const FEValues<2> &,
                        const std::vector<std::unique_ptr<FEValues<2>>> &,
                        const TrilinosWrappers::MPI::Vector *const[2],
                        const Function<2> *const[2],
                        const Domain *,
                        std::vector<double>[2],
                        std::vector<Tensor<1, 2>>[2]);
} // namespace VI
