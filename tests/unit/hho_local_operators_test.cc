// The local HHO operators of step-hho (step-hho/local_operators.h): the
// nodes of the cell space, the gradient reconstruction G_K, the
// stabilisation s_K and the local matrix they make.
//
// Nodes: the contact nodes (both families) are unisolvent for P_p; the
// interpolatory weights of the Gauss-Padua nodes are positive, those of the
// Padua points are not (which is why step-hho defaults to the former).
//
// Spaces (degree p >= 1): cell unknowns in P_p(K) (FE_DGP(p)), face unknowns
// in P_{p-1}(F) (FE_FaceQ(p-1)), G_K(v) in P_p(K)^2. For v in P_p(K), its
// interpolate I_K v = (v, Pi_F v) takes the L2 projection of the trace onto
// P_{p-1}(F) on each face. What must hold:
//  - G_K(I_K v) = grad v for every v in P_p(K) on parallelograms (squares,
//    rectangles, sheared cells): the degree-p face terms of opposite faces
//    cancel there (see local_operators.h);
//  - s_K(I_K v, w) = 0 for every v in P_p(K) and every w, on any cell;
//  - hence a_K(I_K v, I_K w) = (grad v, grad w)_K on parallelograms;
//  - a_K is positive semidefinite with the constants as its only kernel.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_dgp.h>
#include <deal.II/fe/fe_face.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/lapack_full_matrix.h>

#include <gtest/gtest.h>

#include "../../step-hho/local_operators.h"
#include "test_helpers.h"

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

using namespace dealii;
namespace LO = StepHHO::LocalOperators;

namespace
{
  struct Shape
  {
    std::string           name;
    std::vector<Point<2>> vertices; // lexicographic order
    bool                  parallelogram;
  };

  const std::vector<Shape> shapes = {
    {"square", {{0, 0}, {0.25, 0}, {0, 0.25}, {0.25, 0.25}}, true},
    {"rectangle", {{1, 2}, {3, 2}, {1, 2.5}, {3, 2.5}}, true},
    {"sheared", {{0, 0}, {1, 0.2}, {0.4, 0.8}, {1.4, 1.0}}, true},
    {"trapezoid", {{0, 0}, {1, 0}, {0.2, 0.7}, {0.7, 0.9}}, false}};


  /// One cell of the given shape with the element spaces of degree p.
  struct LocalSetting
  {
    LocalSetting(const Shape &shape, const unsigned int p)
        : cell_fe(p)
        , face_fe(p - 1)
        , mapping(1)
        , cell_values(mapping,
                      cell_fe,
                      QGauss<2>(p + 2),
                      update_values | update_gradients | update_JxW_values |
                        update_quadrature_points)
        , trace_values(mapping,
                       cell_fe,
                       QGauss<1>(p + 2),
                       update_values | update_normal_vectors |
                         update_JxW_values)
        , face_values(mapping, face_fe, QGauss<1>(p + 2), update_values)
    {
      GridGenerator::general_cell(tria, shape.vertices);
      cell = tria.begin_active();
    }

    /// (e_j, Pi_F P_j): the interpolate of the cell basis function P_j.
    Vector<double>
    interpolate(const unsigned int j)
    {
      const unsigned int n_c = cell_fe.n_dofs_per_cell();
      Vector<double>     v(n_c + face_fe.n_dofs_per_cell());
      v(j) = 1.;
      for (const unsigned int f : cell->face_indices())
        {
          trace_values.reinit(cell, f);
          face_values.reinit(cell, f);
          const unsigned int n_F = face_fe.n_dofs_per_face(f);
          FullMatrix<double> M_F(n_F, n_F);
          Vector<double>     b(n_F), c(n_F);
          for (const unsigned int q : trace_values.quadrature_point_indices())
            for (unsigned int k = 0; k < n_F; ++k)
              {
                const unsigned int ik = face_fe.face_to_cell_index(k, f);
                const double       ds = trace_values.JxW(q);
                b(k) += face_values.shape_value(ik, q) *
                        trace_values.shape_value(j, q) * ds;
                for (unsigned int l = 0; l < n_F; ++l)
                  M_F(k, l) +=
                    face_values.shape_value(ik, q) *
                    face_values.shape_value(face_fe.face_to_cell_index(l, f),
                                            q) *
                    ds;
              }
          M_F.gauss_jordan();
          M_F.vmult(c, b);
          for (unsigned int k = 0; k < n_F; ++k)
            v(n_c + face_fe.face_to_cell_index(k, f)) = c(k);
        }
      return v;
    }

    /// The reconstruction G_K of the gradient in the space spanned by
    /// `basis`, and the mass matrix of that space.
    void
    reconstruct_gradient(const std::vector<unsigned int> &basis,
                         FullMatrix<double>              &G,
                         FullMatrix<double>              &gradient_mass)
    {
      LO::gradient_reconstruction<2>(
        cell, cell_values, trace_values, face_values, basis, G, gradient_mass);
    }

    /// The local HHO matrix a_K, with the gradient reconstructed in
    /// P_k(K)^2.
    FullMatrix<double>
    local_matrix(const unsigned int k)
    {
      FullMatrix<double> A;
      LO::local_hho_matrix<2>(cell,
                              cell_values,
                              trace_values,
                              face_values,
                              LO::subspace_basis(cell_fe, k),
                              A);
      return A;
    }

    Triangulation<2>                tria;
    Triangulation<2>::cell_iterator cell;
    FE_DGP<2>                       cell_fe;
    FE_FaceQ<2>                     face_fe;
    MappingQ<2>                     mapping;
    FEValues<2>                     cell_values;
    FEFaceValues<2>                 trace_values, face_values;
  };
} // namespace


namespace
{
  const LO::ContactNodes node_families[] = {LO::ContactNodes::gauss_padua,
                                            LO::ContactNodes::padua};

  /// The interpolatory weights w_I = (1, phi_I) on the reference square:
  /// the solution of V^T w = (1, P_j) (only P_0 = 1 has a nonzero mean).
  Vector<double>
  interpolatory_weights(const FullMatrix<double> &V)
  {
    LAPACKFullMatrix<double> VT(V.n(), V.m());
    for (unsigned int I = 0; I < V.m(); ++I)
      for (unsigned int j = 0; j < V.n(); ++j)
        VT(j, I) = V(I, j);
    VT.compute_lu_factorization();
    Vector<double> w(V.m());
    w(0) = 1.;
    VT.solve(w);
    return w;
  }
} // namespace


TEST(HHOLocalOperators, ContactNodesAreUnisolventForPp)
{
  // For every degree the program accepts (1..10): (p+1)(p+2)/2 points in
  // the reference square whose Vandermonde matrix for a basis of P_p is
  // invertible, with a moderate condition number (a usable nodal basis).
  for (const auto family : node_families)
    for (unsigned int p = 1; p <= 10; ++p)
      {
        const auto nodes = LO::contact_nodes(p, family);
        ASSERT_EQ(nodes.size(), (p + 1) * (p + 2) / 2) << "p = " << p;
        for (const auto &x : nodes)
          for (unsigned int d = 0; d < 2; ++d)
            {
              EXPECT_GE(x[d], 0.);
              EXPECT_LE(x[d], 1.);
            }
        const FE_DGP<2>          fe(p);
        const FullMatrix<double> V = LO::vandermonde_matrix(fe, nodes);
        LAPACKFullMatrix<double> V_lapack(V.m(), V.n());
        V_lapack = V;
        V_lapack.compute_svd();
        EXPECT_GT(V_lapack.singular_value(V.m() - 1),
                  1e-3 * V_lapack.singular_value(0))
          << "p = " << p;
      }
}


TEST(HHOLocalOperators, GaussPaduaWeightsArePositive)
{
  // All interpolatory weights positive, the smallest at least 3% of their
  // mean (1 / number of nodes) for p = 1..10.
  for (unsigned int p = 1; p <= 10; ++p)
    {
      const FE_DGP<2>      fe(p);
      const Vector<double> w = interpolatory_weights(LO::vandermonde_matrix(
        fe, LO::contact_nodes(p, LO::ContactNodes::gauss_padua)));
      EXPECT_NEAR(std::accumulate(w.begin(), w.end(), 0.), 1., 1e-13);
      EXPECT_GT(*std::min_element(w.begin(), w.end()), 0.03 / w.size())
        << "p = " << p;
    }
}


TEST(HHOLocalOperators, PaduaWeightsAreNotAllPositive)
{
  // The Padua points (Chebyshev-Lobatto lines): positive weights for p = 1,
  // two zero weights (at the corners) for p = 2, negative ones for p >= 3.
  for (unsigned int p = 1; p <= 10; ++p)
    {
      const FE_DGP<2> fe(p);
      const auto      nodes = LO::contact_nodes(p, LO::ContactNodes::padua);
      const Vector<double> w =
        interpolatory_weights(LO::vandermonde_matrix(fe, nodes));
      const double smallest = *std::min_element(w.begin(), w.end());
      if (p == 1)
        {
          EXPECT_GT(smallest, 0.);
        }
      else if (p == 2)
        {
          EXPECT_NEAR(smallest, 0., 1e-14);
          for (unsigned int I = 0; I < w.size(); ++I)
            if (std::abs(w(I)) < 1e-14)
              {
                EXPECT_TRUE((nodes[I][0] == 0. || nodes[I][0] == 1.) &&
                            (nodes[I][1] == 0. || nodes[I][1] == 1.))
                  << nodes[I];
              }
        }
      else
        {
          EXPECT_LT(smallest, -1e-6) << "p = " << p;
        }
    }
}


TEST(HHOLocalOperators, PaduaPointsOfDegreeOne)
{
  // p = 1: (0, 0), (0, 1), (1, 1/2): two corners and an edge midpoint.
  const auto nodes = LO::contact_nodes(1, LO::ContactNodes::padua);
  EXPECT_NEAR(nodes[0].distance(Point<2>(0, 0)), 0., 1e-15);
  EXPECT_NEAR(nodes[1].distance(Point<2>(0, 1)), 0., 1e-15);
  EXPECT_NEAR(nodes[2].distance(Point<2>(1, 0.5)), 0., 1e-15);
}


namespace
{
  /**
   * G_K(I_K P_j) - Pi_k grad P_j for every basis function P_j of the cell
   * space, with Pi_k the L2 projection onto the gradient space P_k(K)^2;
   * returns the largest L2 norm of this defect relative to |grad P_j|_K.
   * If exact is true, compares with grad P_j itself instead.
   */
  double
  gradient_defect(LocalSetting &s, const unsigned int k, const bool exact)
  {
    const std::vector<unsigned int> basis = LO::subspace_basis(s.cell_fe, k);
    FullMatrix<double>              G, gradient_mass;
    s.reconstruct_gradient(basis, G, gradient_mass);
    const unsigned int n_c = s.cell_fe.n_dofs_per_cell(), n_g = basis.size();
    FullMatrix<double> M_inverse(n_g, n_g);
    for (unsigned int m = 0; m < n_g; ++m)
      for (unsigned int l = 0; l < n_g; ++l)
        M_inverse(m, l) = gradient_mass(m, l);
    M_inverse.gauss_jordan();

    double largest = 0;
    for (unsigned int j = 0; j < n_c; ++j)
      {
        const Vector<double> v = s.interpolate(j);
        Vector<double>       g(G.m()), moments(2 * n_g), projection(2 * n_g);
        G.vmult(g, v);
        // Coefficients of Pi_k grad P_j: M^{-1} (grad P_j, P_m e_d).
        s.cell_values.reinit(s.cell);
        for (const unsigned int q : s.cell_values.quadrature_point_indices())
          for (unsigned int m = 0; m < n_g; ++m)
            for (unsigned int d = 0; d < 2; ++d)
              moments(d * n_g + m) += s.cell_values.shape_grad(j, q)[d] *
                                      s.cell_values.shape_value(basis[m], q) *
                                      s.cell_values.JxW(q);
        for (unsigned int d = 0; d < 2; ++d)
          for (unsigned int m = 0; m < n_g; ++m)
            for (unsigned int l = 0; l < n_g; ++l)
              projection(d * n_g + m) += M_inverse(m, l) * moments(d * n_g + l);

        double error = 0., norm = 0.;
        for (const unsigned int q : s.cell_values.quadrature_point_indices())
          {
            Tensor<1, 2> Gv, Pi_grad;
            for (unsigned int d = 0; d < 2; ++d)
              for (unsigned int m = 0; m < n_g; ++m)
                {
                  const double P_m = s.cell_values.shape_value(basis[m], q);
                  Gv[d] += g(d * n_g + m) * P_m;
                  Pi_grad[d] += projection(d * n_g + m) * P_m;
                }
            const Tensor<1, 2> grad = s.cell_values.shape_grad(j, q);
            error += (Gv - (exact ? grad : Pi_grad)).norm_square() *
                     s.cell_values.JxW(q);
            norm += grad.norm_square() * s.cell_values.JxW(q);
          }
        if (norm > 0)
          largest = std::max(largest, std::sqrt(error / norm));
        else
          largest = std::max(largest, std::sqrt(error));
      }
    return largest;
  }
} // namespace


TEST(HHOLocalOperators, GradientReconstructionIsExactOnPpOnParallelograms)
{
  // G_K(I_K v) = grad v for all v in P_p(K), with G_K in P_p(K)^2 (the
  // slides) and in P_{p-1}(K)^2.
  for (const Shape &shape : shapes)
    if (shape.parallelogram)
      for (unsigned int p = 1; p <= 4; ++p)
        for (const unsigned int k : {p, p - 1})
          {
            LocalSetting s(shape, p);
            EXPECT_LE(gradient_defect(s, k, /*exact=*/true), 1e-12)
              << shape.name << ", p = " << p << ", k = " << k;
          }
}


TEST(HHOLocalOperators, GradientReconstructionOnOtherQuadrilaterals)
{
  // On a trapezoid (a bilinear map, FE_DGP is mapped P_p): with k = p - 1,
  // G_K(I_K v) is still the L2 projection of grad v onto the gradient space
  // (q.n is in P_{p-1}(F) on straight faces); with k = p the face terms no
  // longer cancel and G_K(I_K v) differs from that projection.
  for (unsigned int p = 1; p <= 4; ++p)
    {
      LocalSetting s(shapes[3], p);
      EXPECT_LE(gradient_defect(s, p - 1, /*exact=*/false), 1e-12)
        << "p = " << p;
      EXPECT_GT(gradient_defect(s, p, /*exact=*/false), 1e-3) << "p = " << p;
    }
}


TEST(HHOLocalOperators, GradientReconstructionSeesTheFaceUnknowns)
{
  // The same cell polynomial with other face values has another gradient:
  // G_K(v_K, v_dK + 1_F) - G_K(v_K, v_dK) = the lifting of the constant 1 on
  // one face, whose integral is |F| n_F (take q = e_d constant).
  LocalSetting       s(shapes[0], 2);
  FullMatrix<double> G, gradient_mass;
  const auto         basis = LO::subspace_basis(s.cell_fe, 2);
  s.reconstruct_gradient(basis, G, gradient_mass);
  const unsigned int n_c = s.cell_fe.n_dofs_per_cell();
  Vector<double>     v(G.n()), g(G.m());
  // Face 1 ({x = 0.25}, outer normal +e_x) of FE_FaceQ(1): its two nodal
  // functions sum to 1.
  for (unsigned int k = 0; k < s.face_fe.n_dofs_per_face(1); ++k)
    v(n_c + s.face_fe.face_to_cell_index(k, 1)) = 1.;
  G.vmult(g, v);
  // The integral of P_0 = 1 times G is the first coefficient times |K|.
  ASSERT_EQ(basis[0], 0u);
  const double area = 0.25 * 0.25;
  EXPECT_NEAR(g(0) * area, 0.25, 1e-14); // |F| n_x
  EXPECT_NEAR(g(n_c) * area, 0., 1e-14); // |F| n_y
}


TEST(HHOLocalOperators, SubspaceBasisSpansTheLowerDegrees)
{
  // FE_DGP(p) restricted to the returned functions is FE_DGP(k).
  for (unsigned int p = 1; p <= 5; ++p)
    for (unsigned int k = 0; k <= p; ++k)
      {
        const FE_DGP<2> fe(p), sub(k);
        const auto      basis = LO::subspace_basis(fe, k);
        ASSERT_EQ(basis.size(), sub.n_dofs_per_cell());
        for (unsigned int i = 0; i < basis.size(); ++i)
          EXPECT_NEAR(fe.shape_value(basis[i], Point<2>(0.3, 0.8)),
                      sub.shape_value(i, Point<2>(0.3, 0.8)),
                      1e-13);
      }
}


TEST(HHOLocalOperators, StabilisationVanishesOnPpOnAnyCell)
{
  for (const Shape &shape : shapes)
    for (unsigned int p = 1; p <= 4; ++p)
      {
        LocalSetting       s(shape, p);
        FullMatrix<double> S;
        LO::stabilisation<2>(s.cell, s.trace_values, s.face_values, S);
        const double scale = S.linfty_norm();
        EXPECT_GT(scale, 0.);
        for (unsigned int j = 0; j < s.cell_fe.n_dofs_per_cell(); ++j)
          {
            const Vector<double> v = s.interpolate(j);
            Vector<double>       Sv(v.size());
            S.vmult(Sv, v);
            EXPECT_LE(Sv.linfty_norm(), 1e-12 * scale * v.linfty_norm())
              << shape.name << ", p = " << p << ", basis function " << j;
          }
        // ...but not on a cell polynomial with face values off its trace.
        Vector<double> v(S.m()), Sv(S.m());
        v(0) = 1.; // v_K = 1, v_dK = 0
        S.vmult(Sv, v);
        EXPECT_GT(Sv * v, 0.) << shape.name << ", p = " << p;
      }
}


TEST(HHOLocalOperators, LocalMatrixIsConsistentOnParallelograms)
{
  // a_K(I_K v, I_K w) = (grad v, grad w)_K for v, w in P_p(K), with G_K
  // in P_p(K)^2 and in P_{p-1}(K)^2.
  for (const Shape &shape : shapes)
    {
      if (!shape.parallelogram)
        continue;
      for (unsigned int p = 1; p <= 4; ++p)
        for (const unsigned int k : {p, p - 1})
          {
            LocalSetting             s(shape, p);
            const FullMatrix<double> A   = s.local_matrix(k);
            const unsigned int       n_c = s.cell_fe.n_dofs_per_cell();
            FullMatrix<double>       stiffness(n_c, n_c);
            s.cell_values.reinit(s.cell);
            for (const unsigned int q :
                 s.cell_values.quadrature_point_indices())
              for (unsigned int i = 0; i < n_c; ++i)
                for (unsigned int j = 0; j < n_c; ++j)
                  stiffness(i, j) += s.cell_values.shape_grad(i, q) *
                                     s.cell_values.shape_grad(j, q) *
                                     s.cell_values.JxW(q);
            for (unsigned int i = 0; i < n_c; ++i)
              for (unsigned int j = 0; j < n_c; ++j)
                EXPECT_NEAR(A.matrix_scalar_product(s.interpolate(i),
                                                    s.interpolate(j)),
                            stiffness(i, j),
                            1e-12 * std::max(1., stiffness.linfty_norm()))
                  << shape.name << ", p = " << p << ", k = " << k << ", (" << i
                  << ", " << j << ")";
          }
    }
}


TEST(HHOLocalOperators, LocalMatrixIsStableWithTheConstantsAsKernel)
{
  // Symmetric positive semidefinite, with exactly one zero eigenvalue (v_K
  // and all v_F equal to the same constant): this is the stability of HHO,
  // which needs the stabilisation. The zero eigenvalue is round-off (below
  // 1e-12 of the largest); the next one is above 1e-8 of it (the smallest
  // ratio, about 3e-5, is that of the 4:1 rectangle at p = 4). Both
  // gradient spaces, P_p(K)^2 and P_{p-1}(K)^2.
  for (const Shape &shape : shapes)
    for (unsigned int p = 1; p <= 4; ++p)
      for (const unsigned int k : {p, p - 1})
        {
          LocalSetting             s(shape, p);
          const FullMatrix<double> A = s.local_matrix(k);
          for (unsigned int i = 0; i < A.m(); ++i)
            for (unsigned int j = 0; j < i; ++j)
              EXPECT_NEAR(A(i, j), A(j, i), 1e-13 * A.linfty_norm());

          const Vector<double> eigenvalues = VITest::symmetric_eigenvalues(A);
          ASSERT_EQ(eigenvalues.size(), A.m());
          const double largest = eigenvalues(A.m() - 1);
          EXPECT_LE(std::abs(eigenvalues(0)), 1e-12 * largest)
            << shape.name << ", p = " << p;
          EXPECT_GT(eigenvalues(1), 1e-8 * largest)
            << shape.name << ", p = " << p;

          // The kernel: a constant on the cell and on every face.
          Vector<double> constant(A.m()), Av(A.m());
          constant(0) = 1.; // P_0 = 1 of FE_DGP
          for (unsigned int k = 0; k < s.face_fe.n_dofs_per_cell(); ++k)
            constant(s.cell_fe.n_dofs_per_cell() + k) = 1.; // FE_FaceQ: nodal
          A.vmult(Av, constant);
          EXPECT_LE(Av.linfty_norm(), 1e-12 * largest)
            << shape.name << ", p = " << p;
        }
}


TEST(HHOLocalOperators, NodalBasisChangeKeepsTheBilinearForm)
{
  // a(v, w) is the same number in the modal and the nodal cell basis.
  LocalSetting             s(shapes[2], 3);
  const FullMatrix<double> A = s.local_matrix(3);
  const FullMatrix<double> V =
    LO::vandermonde_matrix(s.cell_fe,
                           LO::contact_nodes(3, LO::ContactNodes::gauss_padua));
  FullMatrix<double> T(V.m(), V.n());
  T.invert(V);
  FullMatrix<double> A_nodal(A);
  LO::change_cell_basis(T, A_nodal);

  const unsigned int n_c = V.m();
  Vector<double>     v_modal(A.m()), w_modal(A.m());
  for (unsigned int i = 0; i < A.m(); ++i)
    {
      v_modal(i) = std::sin(1. + i);
      w_modal(i) = std::cos(2. * i);
    }
  Vector<double> v_nodal(v_modal), w_nodal(w_modal);
  Vector<double> c(n_c), nodal(n_c);
  for (auto *pair : {&v_nodal, &w_nodal})
    {
      for (unsigned int i = 0; i < n_c; ++i)
        c(i) = (*pair)(i);
      V.vmult(nodal, c); // nodal values = V (modal coefficients)
      for (unsigned int i = 0; i < n_c; ++i)
        (*pair)(i) = nodal(i);
    }
  EXPECT_NEAR(A_nodal.matrix_scalar_product(v_nodal, w_nodal),
              A.matrix_scalar_product(v_modal, w_modal),
              1e-12 * A.linfty_norm());
}
