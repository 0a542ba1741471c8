#pragma once

// The cell-local operators of the Hybrid High-Order (HHO) method of
// step-hho: the nodes of the cell space, the gradient reconstruction G_K and
// the stabilisation s_K. Header-only, so that the unit tests
// (tests/unit/hho_local_operators_test.cc) use exactly this code.
//
// Local unknowns of one membrane on a cell K (the "local vector"):
//   v_K  in P_p(K):        n_c = (p+1)(p+2)/2 coefficients in the basis of
//                          the cell element (FE_DGP(p), or the nodal basis
//                          after change_cell_basis());
//   v_dK in P_{p-1}(F) on each face F of K: the n_f = 4 p degrees of freedom
//                          of the face element (FE_FaceQ(p-1)), in its
//                          cell-local order.
// The local vector is (v_K, v_dK), of length n_c + n_f.

#include <deal.II/base/point.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_dgp.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace StepHHO
{
  namespace LocalOperators
  {
    using namespace dealii;

    /**
     * Nodes x_I of the cell space P_p on the reference square [0,1]^2, at
     * which the constraint u1h - u2h >= 0 is imposed (the slides' V_K): the
     * "checkerboard" half of a (p+1) x (p+2) tensor grid,
     *
     *   (s_j, t_k),  0 <= j <= p,  0 <= k <= p+1,  j + k even,
     *
     * (p+1)(p+2)/2 points, with s the p+1 and t the p+2 points of a 1D rule:
     * - gauss-padua: the Gauss-Legendre points (interior of the cell);
     * - padua: the Chebyshev-Lobatto points (1 - cos(j pi / p)) / 2, i.e.
     *   the Padua points (Bos, Caliari, De Marchi, Vianello, Xu, J. Approx.
     *   Theory 143, 2006), with two corners and nodes on every edge.
     * Both are unisolvent for P_p, p = 1..10 (checked in the unit tests).
     *
     * What decides between them is the sign of the interpolatory weights
     * w_I = (1, phi_I)_K of the nodal basis: the multiplier's coefficients
     * X3_I = (lambda_h, phi_I)_K are about lambda(x_I) w_I, so the sign
     * condition X3_I >= 0 agrees with lambda >= 0 only if every w_I > 0.
     * The Gauss-Padua weights are positive for p = 1..10; the Padua weights
     * vanish at two corners for p = 2 and are negative at some nodes for
     * p >= 3 (the unit tests check both). A set symmetric under all eight
     * symmetries of the square does not exist for p = 1..4: its size would
     * be a sum of orbit sizes 1, 4 and 8, but 3, 6, 10, 15 are neither 0 nor
     * 1 modulo 4.
     */
    enum class ContactNodes
    {
      gauss_padua,
      padua
    };

    inline std::vector<Point<2>>
    contact_nodes(const unsigned int p, const ContactNodes type)
    {
      const auto points_1d = [&](const unsigned int n) {
        std::vector<double> s(n);
        const QGauss<1>     gauss(n);
        for (unsigned int i = 0; i < n; ++i)
          s[i] = type == ContactNodes::gauss_padua ?
                   gauss.point(i)[0] :
                   0.5 * (1. - std::cos(i * M_PI / (n - 1)));
        std::sort(s.begin(), s.end());
        return s;
      };
      const std::vector<double> s = points_1d(p + 1), t = points_1d(p + 2);
      std::vector<Point<2>>     points;
      for (unsigned int j = 0; j <= p; ++j)
        for (unsigned int k = 0; k <= p + 1; ++k)
          if ((j + k) % 2 == 0)
            points.emplace_back(s[j], t[k]);
      return points;
    }


    /**
     * The generalised Vandermonde matrix V_Ij = P_j(x_I) of the basis P_j of
     * `fe` at the reference points x_I. For unisolvent nodes, the nodal
     * (Lagrange) basis is phi_I = sum_j (V^{-1})_jI P_j, and a function with
     * coefficients c in the basis P_j has the nodal values V c.
     */
    template <int dim>
    FullMatrix<double>
    vandermonde_matrix(const FiniteElement<dim>      &fe,
                       const std::vector<Point<dim>> &nodes)
    {
      FullMatrix<double> V(nodes.size(), fe.n_dofs_per_cell());
      for (unsigned int I = 0; I < nodes.size(); ++I)
        for (unsigned int j = 0; j < fe.n_dofs_per_cell(); ++j)
          V(I, j) = fe.shape_value(j, nodes[I]);
      return V;
    }


    /**
     * Express a local matrix in another basis of the cell space: if the new
     * cell basis is phi_I = sum_j T_jI P_j (T = V^{-1} for the nodal basis),
     * the local vector transforms with T_hat = diag(T, I_{n_f}) and the
     * matrix becomes T_hat^T A T_hat.
     */
    inline void
    change_cell_basis(const FullMatrix<double> &T, FullMatrix<double> &A)
    {
      const unsigned int n_c = T.m(), n = A.m();
      FullMatrix<double> T_hat(n, n);
      for (unsigned int i = 0; i < n_c; ++i)
        for (unsigned int j = 0; j < n_c; ++j)
          T_hat(i, j) = T(i, j);
      for (unsigned int i = n_c; i < n; ++i)
        T_hat(i, i) = 1.;
      FullMatrix<double> AT(n, n);
      A.mmult(AT, T_hat);
      T_hat.Tmmult(A, AT);
    }


    /**
     * The basis functions of the cell element (FE_DGP(p)) that span
     * P_k(K), k <= p: FE_DGP's basis functions are products of Legendre
     * polynomials on the reference cell, and those of FE_DGP(k) are among
     * them. Returned as indices into the basis of `cell_fe`.
     */
    template <int dim>
    std::vector<unsigned int>
    subspace_basis(const FiniteElement<dim> &cell_fe, const unsigned int k)
    {
      const FE_DGP<dim>         sub_fe(k);
      const QGauss<dim>         points(k + 2);
      std::vector<unsigned int> indices;
      for (unsigned int i = 0; i < sub_fe.n_dofs_per_cell(); ++i)
        for (unsigned int j = 0; j < cell_fe.n_dofs_per_cell(); ++j)
          {
            bool equal = true;
            for (const Point<dim> &x : points.get_points())
              equal = equal && std::abs(sub_fe.shape_value(i, x) -
                                        cell_fe.shape_value(j, x)) < 1e-12;
            if (equal)
              {
                indices.push_back(j);
                break;
              }
          }
      AssertDimension(indices.size(), sub_fe.n_dofs_per_cell());
      return indices;
    }


    /**
     * The gradient reconstruction G_K : P_p(K) x prod_F P_{p-1}(F) ->
     * P_k(K)^dim: for all q in P_k(K)^dim,
     *
     *   (G_K(v), q)_K = (grad v_K, q)_K + (v_dK - v_K, q.n_K)_dK,
     *
     * with k = p in the slides, or k = p - 1. The basis of P_k(K) is given by
     * `gradient_basis`: indices j of the cell element's basis functions P_j
     * (subspace_basis()). Returns the matrix G with G_K(v) = sum_{d,m}
     * (G v)_{d n_g + m} P_{j_m} e_d (n_g = dim P_k), i.e. the solution of
     * M_G G = B, and the Gram matrix M_G of this basis. The consistent part
     * of the HHO bilinear form is then (G_K v, G_K w)_K = w^T G^T M_G G v.
     *
     * What it reproduces, for v in P_p(K) and v_F the L2 projection of its
     * trace onto P_{p-1}(F) (checked in the unit tests):
     * - k = p - 1: q.n is in P_{p-1}(F) on every straight face, so the face
     *   term vanishes and G_K(v) is the L2 projection of grad v onto
     *   P_{p-1}(K)^dim on any straight-sided cell: grad v itself on
     *   parallelograms (where FE_DGP is P_p in physical coordinates).
     * - k = p: the face term sum_F (Pi_F v - v, q.n)_F pairs the degree-p
     *   parts of v and q.n along each face; on a parallelogram those of
     *   opposite faces cancel (same tangent, opposite normal), so again
     *   G_K(v) = grad v, now in a larger space. On other cells the
     *   cancellation is only approximate.
     *
     * `cell_values` (the cell element, with values, gradients and JxW),
     * `trace_values` (the cell element on faces, with values, normals and
     * JxW) and `face_values` (the scalar face element, with values) are
     * reinitialised here on `cell`.
     */
    template <int dim>
    void
    gradient_reconstruction(
      const typename Triangulation<dim>::cell_iterator &cell,
      FEValues<dim>                                    &cell_values,
      FEFaceValues<dim>                                &trace_values,
      FEFaceValues<dim>                                &face_values,
      const std::vector<unsigned int>                  &gradient_basis,
      FullMatrix<double>                               &G,
      FullMatrix<double>                               &gradient_mass)
    {
      const FiniteElement<dim> &face_fe = face_values.get_fe();
      const unsigned int        n_c = cell_values.get_fe().n_dofs_per_cell();
      const unsigned int        n_f = face_fe.n_dofs_per_cell();
      const unsigned int        n   = n_c + n_f;
      const unsigned int        n_g = gradient_basis.size();

      // Mass matrix M of the basis of P_k and B = the right-hand side, row
      // (d, m) for the test function q = P_{j_m} e_d.
      FullMatrix<double> M(n_g, n_g), B(dim * n_g, n);
      cell_values.reinit(cell);
      for (const unsigned int q : cell_values.quadrature_point_indices())
        {
          const double dx = cell_values.JxW(q);
          for (unsigned int m = 0; m < n_g; ++m)
            {
              const double P_m = cell_values.shape_value(gradient_basis[m], q);
              for (unsigned int l = 0; l < n_g; ++l)
                M(m, l) +=
                  P_m * cell_values.shape_value(gradient_basis[l], q) * dx;
              for (unsigned int i = 0; i < n_c; ++i)
                {
                  const Tensor<1, dim> grad_i = cell_values.shape_grad(i, q);
                  for (unsigned int d = 0; d < dim; ++d)
                    B(d * n_g + m, i) += grad_i[d] * P_m * dx;
                }
            }
        }

      for (const unsigned int f : cell->face_indices())
        {
          trace_values.reinit(cell, f);
          face_values.reinit(cell, f);
          for (const unsigned int q : trace_values.quadrature_point_indices())
            {
              const Tensor<1, dim> &normal = trace_values.normal_vector(q);
              const double          ds     = trace_values.JxW(q);
              for (unsigned int m = 0; m < n_g; ++m)
                for (unsigned int d = 0; d < dim; ++d)
                  {
                    const double q_dot_n =
                      trace_values.shape_value(gradient_basis[m], q) *
                      normal[d] * ds;
                    for (unsigned int i = 0; i < n_c; ++i)
                      B(d * n_g + m, i) -=
                        trace_values.shape_value(i, q) * q_dot_n;
                    for (unsigned int k = 0; k < face_fe.n_dofs_per_face(f);
                         ++k)
                      {
                        const unsigned int i = face_fe.face_to_cell_index(k, f);
                        B(d * n_g + m, n_c + i) +=
                          face_values.shape_value(i, q) * q_dot_n;
                      }
                  }
            }
        }

      FullMatrix<double> M_inverse(n_g, n_g);
      M_inverse.invert(M);
      G.reinit(dim * n_g, n);
      gradient_mass.reinit(dim * n_g, dim * n_g);
      for (unsigned int d = 0; d < dim; ++d)
        for (unsigned int m = 0; m < n_g; ++m)
          for (unsigned int l = 0; l < n_g; ++l)
            {
              gradient_mass(d * n_g + m, d * n_g + l) = M(m, l);
              for (unsigned int i = 0; i < n; ++i)
                G(d * n_g + m, i) += M_inverse(m, l) * B(d * n_g + l, i);
            }
    }


    /**
     * The stabilisation of the slides,
     *
     *   s_K(v, w) = h_K^{-1} (Pi_dK^{p-1}(v_dK - v_K), w_dK - w_K)_dK
     *             = h_K^{-1} sum_F (Pi_F (v_F - v_K), Pi_F (w_F - w_K))_F,
     *
     * with Pi_F the L2 projection onto P_{p-1}(F) and h_K the diameter of K.
     * On each face, the coefficients of Pi_F(v_F - v_K) are
     * v_F - M_F^{-1} T_F v_K with the face mass matrix M_F and T_F,ki =
     * (P_i, psi_k)_F; hence the face's contribution
     *
     *   h_K^{-1} [ T_F^T M_F^{-1} T_F   -T_F^T ]
     *            [ -T_F                  M_F   ]
     *
     * on (v_K, v_F). It vanishes on v in P_p(K) with v_F = Pi_F v (any cell
     * shape): then Pi_F(v_F - v_K) = Pi_F v - Pi_F v = 0. This is what makes
     * the face degree p - 1 (one less than the cell degree) sufficient.
     */
    template <int dim>
    void
    stabilisation(const typename Triangulation<dim>::cell_iterator &cell,
                  FEFaceValues<dim>  &trace_values,
                  FEFaceValues<dim>  &face_values,
                  FullMatrix<double> &S)
    {
      const FiniteElement<dim> &face_fe = face_values.get_fe();
      const unsigned int        n_c = trace_values.get_fe().n_dofs_per_cell();
      const unsigned int        n_f = face_fe.n_dofs_per_cell();
      S.reinit(n_c + n_f, n_c + n_f);
      const double inverse_h = 1. / cell->diameter();

      for (const unsigned int f : cell->face_indices())
        {
          const unsigned int        n_F = face_fe.n_dofs_per_face(f);
          std::vector<unsigned int> face_dofs(n_F);
          for (unsigned int k = 0; k < n_F; ++k)
            face_dofs[k] = face_fe.face_to_cell_index(k, f);

          trace_values.reinit(cell, f);
          face_values.reinit(cell, f);
          FullMatrix<double> M_F(n_F, n_F), T_F(n_F, n_c);
          for (const unsigned int q : trace_values.quadrature_point_indices())
            {
              const double ds = trace_values.JxW(q);
              for (unsigned int k = 0; k < n_F; ++k)
                {
                  const double psi_k = face_values.shape_value(face_dofs[k], q);
                  for (unsigned int l = 0; l < n_F; ++l)
                    M_F(k, l) +=
                      psi_k * face_values.shape_value(face_dofs[l], q) * ds;
                  for (unsigned int i = 0; i < n_c; ++i)
                    T_F(k, i) += psi_k * trace_values.shape_value(i, q) * ds;
                }
            }

          FullMatrix<double> M_F_inverse(n_F, n_F), M_inv_T(n_F, n_c),
            TMT(n_c, n_c);
          M_F_inverse.invert(M_F);
          M_F_inverse.mmult(M_inv_T, T_F);
          T_F.Tmmult(TMT, M_inv_T);
          for (unsigned int i = 0; i < n_c; ++i)
            for (unsigned int j = 0; j < n_c; ++j)
              S(i, j) += inverse_h * TMT(i, j);
          for (unsigned int k = 0; k < n_F; ++k)
            {
              for (unsigned int i = 0; i < n_c; ++i)
                {
                  S(n_c + face_dofs[k], i) -= inverse_h * T_F(k, i);
                  S(i, n_c + face_dofs[k]) -= inverse_h * T_F(k, i);
                }
              for (unsigned int l = 0; l < n_F; ++l)
                S(n_c + face_dofs[k], n_c + face_dofs[l]) +=
                  inverse_h * M_F(k, l);
            }
        }
    }


    /**
     * The local HHO matrix of one membrane with unit tension, with G_K in
     * P_k(K)^dim (the basis `gradient_basis`, see gradient_reconstruction()),
     *
     *   a_K(v, w) = (G_K v, G_K w)_K + s_K(v, w),
     *
     * in the basis of the cell element (FE_DGP).
     */
    template <int dim>
    void
    local_hho_matrix(const typename Triangulation<dim>::cell_iterator &cell,
                     FEValues<dim>                   &cell_values,
                     FEFaceValues<dim>               &trace_values,
                     FEFaceValues<dim>               &face_values,
                     const std::vector<unsigned int> &gradient_basis,
                     FullMatrix<double>              &A)
    {
      FullMatrix<double> G, gradient_mass;
      gradient_reconstruction(cell,
                              cell_values,
                              trace_values,
                              face_values,
                              gradient_basis,
                              G,
                              gradient_mass);
      stabilisation(cell, trace_values, face_values, A);
      FullMatrix<double> MG(G.m(), G.n());
      gradient_mass.mmult(MG, G);
      G.Tmmult(A, MG, /*adding=*/true);
    }
  } // namespace LocalOperators
} // namespace StepHHO
