#pragma once

// The equilibrated flux of step-hho's a posteriori estimate on one cell
// (hho_estimate.cc, doc/reference.md "The estimate of HHO"). Header-only,
// so that the unit tests (tests/unit/hho_cell_flux_test.cc) use exactly
// this code.

#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vector>

namespace StepHHO
{
  using namespace dealii;

  /**
   * The flux of one membrane on one cell K: sigma in RT_p(K) with the
   * normal trace phi on every face (phi in P_{p-1}(F) is in the trace
   * space P_p(F), so the face degrees of freedom reproduce it), and,
   * among those, with (div sigma, q)_K = (source, q)_K for the
   * non-constant q of Q_p (the constant is the compatibility the normal
   * traces already satisfy) and |sigma + mu grad u_K|_K smallest. The
   * Legendre basis of the reference cell spans Q_p; its first function is
   * the constant.
   */
  template <int dim>
  class CellFlux
  {
  public:
    CellFlux(const Mapping<dim>        &mapping,
             const FiniteElement<dim>  &flux_fe,
             const Quadrature<dim>     &quadrature,
             const Quadrature<dim - 1> &face_quadrature,
             const unsigned int         p)
        : values(mapping,
                 flux_fe,
                 quadrature,
                 update_values | update_gradients | update_JxW_values)
        , face_values(mapping,
                      flux_fe,
                      face_quadrature,
                      update_values | update_normal_vectors | update_JxW_values)
        , legendre(p)
    {
      const unsigned int n = flux_fe.n_dofs_per_cell();
      std::vector<bool>  on_face(n, false);
      for (unsigned int f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f)
        for (unsigned int k = 0; k < flux_fe.n_dofs_per_face(f); ++k)
          on_face[flux_fe.face_to_cell_index(k, f)] = true;
      for (unsigned int i = 0; i < n; ++i)
        if (!on_face[i])
          interior.push_back(i);
    }

    /// `phi[f][q]`: the outward normal flux at the face quadrature points;
    /// `grad_u`, `source` at the cell's. Returns the coefficients.
    Vector<double>
    compute(const typename DoFHandler<dim>::active_cell_iterator &cell,
            const std::vector<std::vector<double>>               &phi,
            const std::vector<Tensor<1, dim>>                    &mu_grad_u,
            const std::vector<double>                            &source)
    {
      const FiniteElement<dim>        &fe = values.get_fe();
      const FEValuesExtractors::Vector flux(0);
      Vector<double>                   sigma(fe.n_dofs_per_cell());

      // The face degrees of freedom: the L2 projection of phi onto the
      // normal traces of the face's basis functions (exact).
      for (const unsigned int f : cell->face_indices())
        {
          face_values.reinit(cell, f);
          const unsigned int        n_F = fe.n_dofs_per_face(f);
          FullMatrix<double>        A(n_F, n_F);
          Vector<double>            b(n_F), x(n_F);
          std::vector<unsigned int> dofs(n_F);
          for (unsigned int k = 0; k < n_F; ++k)
            dofs[k] = fe.face_to_cell_index(k, f);
          for (const unsigned int q : face_values.quadrature_point_indices())
            {
              const Tensor<1, dim> &n  = face_values.normal_vector(q);
              const double          ds = face_values.JxW(q);
              for (unsigned int k = 0; k < n_F; ++k)
                {
                  const double psi_k = face_values[flux].value(dofs[k], q) * n;
                  b(k) += phi[f][q] * psi_k * ds;
                  for (unsigned int l = 0; l < n_F; ++l)
                    A(k, l) +=
                      psi_k * (face_values[flux].value(dofs[l], q) * n) * ds;
                }
            }
          A.gauss_jordan();
          A.vmult(x, b);
          for (unsigned int k = 0; k < n_F; ++k)
            sigma(dofs[k]) = x(k);
        }

      // The interior ones: the saddle-point system of the constrained
      // minimisation, [M B^T; B 0] [sigma_I; gamma] = [-(sigma_b + mu grad
      // u, psi_i); (source - div sigma_b, q_m)].
      values.reinit(cell);
      const unsigned int n_I = interior.size();
      const unsigned int n_m = legendre.n_dofs_per_cell() - 1;
      FullMatrix<double> K(n_I + n_m, n_I + n_m);
      Vector<double>     rhs(n_I + n_m), x(n_I + n_m);
      for (const unsigned int q : values.quadrature_point_indices())
        {
          const double   dx = values.JxW(q);
          Tensor<1, dim> boundary_part;
          double         boundary_divergence = 0;
          for (unsigned int j = 0; j < fe.n_dofs_per_cell(); ++j)
            if (sigma(j) != 0.)
              {
                boundary_part += sigma(j) * values[flux].value(j, q);
                boundary_divergence += sigma(j) * values[flux].divergence(j, q);
              }
          const Point<dim> &x_ref = values.get_quadrature().point(q);
          for (unsigned int i = 0; i < n_I; ++i)
            {
              const Tensor<1, dim> psi_i = values[flux].value(interior[i], q);
              rhs(i) -= (boundary_part + mu_grad_u[q]) * psi_i * dx;
              for (unsigned int j = 0; j < n_I; ++j)
                K(i, j) += psi_i * values[flux].value(interior[j], q) * dx;
              const double div_i = values[flux].divergence(interior[i], q);
              for (unsigned int m = 0; m < n_m; ++m)
                {
                  const double q_m = legendre.shape_value(m + 1, x_ref);
                  K(n_I + m, i) += div_i * q_m * dx;
                  K(i, n_I + m) += div_i * q_m * dx;
                }
            }
          for (unsigned int m = 0; m < n_m; ++m)
            rhs(n_I + m) += (source[q] - boundary_divergence) *
                            legendre.shape_value(m + 1, x_ref) * dx;
        }
      K.gauss_jordan();
      K.vmult(x, rhs);
      for (unsigned int i = 0; i < n_I; ++i)
        sigma(interior[i]) = x(i);
      return sigma;
    }

  private:
    FEValues<dim>             values;
    FEFaceValues<dim>         face_values;
    const FE_DGQLegendre<dim> legendre;
    std::vector<unsigned int> interior;
  };
} // namespace StepHHO
