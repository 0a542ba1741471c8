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

#include <array>
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
      // The non-constant Legendre polynomials at the quadrature points of
      // the reference cell, the same on every cell.
      legendre_values.resize(legendre.n_dofs_per_cell() - 1,
                             std::vector<double>(quadrature.size()));
      for (unsigned int m = 0; m < legendre_values.size(); ++m)
        for (unsigned int q = 0; q < quadrature.size(); ++q)
          legendre_values[m][q] =
            legendre.shape_value(m + 1, quadrature.point(q));
    }

    /// `phi[f][q]`: the outward normal flux at the face quadrature points;
    /// `grad_u`, `source` at the cell's. Returns the coefficients.
    Vector<double>
    compute(const typename DoFHandler<dim>::active_cell_iterator &cell,
            const std::vector<std::vector<double>>               &phi,
            const std::vector<Tensor<1, dim>>                    &mu_grad_u,
            const std::vector<double>                            &source)
    {
      reinit(cell);
      return solve(phi, mu_grad_u, source);
    }

    /// What depends on the cell only: the inverse matrices of the face
    /// projections and of the interior saddle-point system, and the shape
    /// functions at the quadrature points. The flux is linear in the data,
    /// so each cell is prepared once for both membranes (and for all the
    /// columns of a shape's linear map, hho_estimate.cc).
    void
    reinit(const typename DoFHandler<dim>::active_cell_iterator &cell)
    {
      const FiniteElement<dim>        &fe = values.get_fe();
      const FEValuesExtractors::Vector flux(0);
      const unsigned int               n = fe.n_dofs_per_cell();

      // The face degrees of freedom: the L2 projection onto the normal
      // traces of the face's basis functions (exact for phi in P_{p-1}).
      for (const unsigned int f : cell->face_indices())
        {
          face_values.reinit(cell, f);
          const unsigned int n_F  = fe.n_dofs_per_face(f);
          FaceData          &face = faces[f];
          face.dofs.resize(n_F);
          for (unsigned int k = 0; k < n_F; ++k)
            face.dofs[k] = fe.face_to_cell_index(k, f);
          face.weighted_traces.reinit(n_F, face_values.n_quadrature_points);
          face.inverse_mass.reinit(n_F, n_F);
          for (const unsigned int q : face_values.quadrature_point_indices())
            {
              const Tensor<1, dim> &normal = face_values.normal_vector(q);
              const double          ds     = face_values.JxW(q);
              for (unsigned int k = 0; k < n_F; ++k)
                {
                  const double psi_k =
                    face_values[flux].value(face.dofs[k], q) * normal;
                  face.weighted_traces(k, q) = psi_k * ds;
                  for (unsigned int l = 0; l < n_F; ++l)
                    face.inverse_mass(k, l) +=
                      psi_k *
                      (face_values[flux].value(face.dofs[l], q) * normal) * ds;
                }
            }
          face.inverse_mass.gauss_jordan();
        }

      // The interior ones: the saddle-point system of the constrained
      // minimisation, [M B^T; B 0] [sigma_I; gamma] = [-(sigma_b + mu grad
      // u, psi_i); (source - div sigma_b, q_m)].
      values.reinit(cell);
      const unsigned int n_q = values.n_quadrature_points;
      shape_values.resize(n * n_q);
      shape_divergences.resize(n * n_q);
      JxW.resize(n_q);
      for (const unsigned int q : values.quadrature_point_indices())
        {
          JxW[q] = values.JxW(q);
          for (unsigned int j = 0; j < n; ++j)
            {
              shape_values[j * n_q + q]      = values[flux].value(j, q);
              shape_divergences[j * n_q + q] = values[flux].divergence(j, q);
            }
        }
      const unsigned int n_I = interior.size();
      const unsigned int n_m = legendre_values.size();
      inverse_system.reinit(n_I + n_m, n_I + n_m);
      for (unsigned int q = 0; q < n_q; ++q)
        for (unsigned int i = 0; i < n_I; ++i)
          {
            const Tensor<1, dim> &psi_i = shape_values[interior[i] * n_q + q];
            for (unsigned int j = 0; j < n_I; ++j)
              inverse_system(i, j) +=
                psi_i * shape_values[interior[j] * n_q + q] * JxW[q];
            const double div_i = shape_divergences[interior[i] * n_q + q];
            for (unsigned int m = 0; m < n_m; ++m)
              {
                const double q_m = legendre_values[m][q];
                inverse_system(n_I + m, i) += div_i * q_m * JxW[q];
                inverse_system(i, n_I + m) += div_i * q_m * JxW[q];
              }
          }
      inverse_system.gauss_jordan();
    }

    /// The flux of the data on the cell of the last reinit().
    Vector<double>
    solve(const std::vector<std::vector<double>> &phi,
          const std::vector<Tensor<1, dim>>      &mu_grad_u,
          const std::vector<double>              &source) const
    {
      const unsigned int n   = values.get_fe().n_dofs_per_cell();
      const unsigned int n_q = JxW.size();
      Vector<double>     sigma(n);
      for (unsigned int f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f)
        {
          const FaceData    &face = faces[f];
          const unsigned int n_F  = face.dofs.size();
          Vector<double>     b(n_F), x(n_F);
          for (unsigned int q = 0; q < face.weighted_traces.n(); ++q)
            for (unsigned int k = 0; k < n_F; ++k)
              b(k) += phi[f][q] * face.weighted_traces(k, q);
          face.inverse_mass.vmult(x, b);
          for (unsigned int k = 0; k < n_F; ++k)
            sigma(face.dofs[k]) = x(k);
        }

      const unsigned int n_I = interior.size();
      const unsigned int n_m = legendre_values.size();
      Vector<double>     rhs(n_I + n_m), x(n_I + n_m);
      for (unsigned int q = 0; q < n_q; ++q)
        {
          Tensor<1, dim> boundary_part;
          double         boundary_divergence = 0;
          for (unsigned int j = 0; j < n; ++j)
            if (sigma(j) != 0.)
              {
                boundary_part += sigma(j) * shape_values[j * n_q + q];
                boundary_divergence +=
                  sigma(j) * shape_divergences[j * n_q + q];
              }
          for (unsigned int i = 0; i < n_I; ++i)
            rhs(i) -= (boundary_part + mu_grad_u[q]) *
                      shape_values[interior[i] * n_q + q] * JxW[q];
          for (unsigned int m = 0; m < n_m; ++m)
            rhs(n_I + m) += (source[q] - boundary_divergence) *
                            legendre_values[m][q] * JxW[q];
        }
      inverse_system.vmult(x, rhs);
      for (unsigned int i = 0; i < n_I; ++i)
        sigma(interior[i]) = x(i);
      return sigma;
    }

  private:
    FEValues<dim>             values;
    FEFaceValues<dim>         face_values;
    const FE_DGQLegendre<dim> legendre;
    std::vector<unsigned int> interior;
    /// legendre_values[m][q]: the (m + 1)-th Legendre polynomial at point q.
    std::vector<std::vector<double>> legendre_values;

    // The cell of the last reinit(): per face, its degrees of freedom, the
    // normal traces of their basis functions times the weights at the face
    // quadrature points, and the inverse of their mass matrix; the shape
    // functions and their divergences at the cell's points ([j * n_q + q]),
    // the weights, and the inverse of the interior system.
    struct FaceData
    {
      std::vector<unsigned int> dofs;
      FullMatrix<double>        weighted_traces, inverse_mass;
    };
    std::array<FaceData, GeometryInfo<dim>::faces_per_cell> faces;
    std::vector<Tensor<1, dim>>                             shape_values;
    std::vector<double>                                     shape_divergences;
    std::vector<double>                                     JxW;
    FullMatrix<double>                                      inverse_system;
  };
} // namespace StepHHO
