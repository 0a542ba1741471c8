// Static condensation of step-hho (step-hho/static_condensation.h): the
// two-stage elimination of the cell unknowns (membranes, then multiplier)
// must give the Schur complement of the full local system of a semismooth
// Newton step, and recover the cell unknowns that solve its cell rows, for
// every generalised Jacobian of the C-functions (Newton-min with any active
// set, Fischer-Burmeister).
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_dgp.h>
#include <deal.II/fe/fe_face.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>

#include <gtest/gtest.h>

#include "../../step-hho/local_operators.h"
#include "../../step-hho/static_condensation.h"
#include "test_helpers.h"

#include <cmath>
#include <string>
#include <vector>

using namespace dealii;
namespace LO = StepHHO::LocalOperators;
namespace SC = StepHHO::StaticCondensation;

namespace
{
  /// The local HHO matrix of a quadrilateral, in the nodal cell basis.
  FullMatrix<double>
  nodal_local_matrix(const unsigned int p, unsigned int &n_c)
  {
    Triangulation<2> tria;
    GridGenerator::general_cell(
      tria,
      std::vector<Point<2>>{{0, 0}, {0.3, 0.02}, {0.05, 0.2}, {0.3, 0.25}});
    const FE_DGP<2>    cell_fe(p);
    const FE_FaceQ<2>  face_fe(p - 1);
    const MappingQ<2>  mapping(1);
    FEValues<2>        cell_values(mapping,
                            cell_fe,
                            QGauss<2>(p + 2),
                            update_values | update_gradients |
                              update_JxW_values);
    FEFaceValues<2>    trace_values(mapping,
                                 cell_fe,
                                 QGauss<1>(p + 2),
                                 update_values | update_normal_vectors |
                                   update_JxW_values);
    FEFaceValues<2>    face_values(mapping,
                                face_fe,
                                QGauss<1>(p + 2),
                                update_values);
    FullMatrix<double> A;
    LO::local_hho_matrix<2>(tria.begin_active(),
                            cell_values,
                            trace_values,
                            face_values,
                            LO::subspace_basis(cell_fe, p),
                            A);
    const FullMatrix<double> V = LO::vandermonde_matrix(
      cell_fe, LO::contact_nodes(p, LO::ContactNodes::gauss_padua));
    FullMatrix<double> T(V.m(), V.n());
    T.invert(V);
    LO::change_cell_basis(T, A);
    n_c = cell_fe.n_dofs_per_cell();
    return A;
  }


  struct Jacobian
  {
    std::string    name;
    Vector<double> Ga, Gb;
  };

  /// Newton-min with all nodes inactive, all active, a mixed active set;
  /// Fischer-Burmeister at scattered points (a, b).
  std::vector<Jacobian>
  jacobians(const unsigned int n)
  {
    std::vector<Jacobian> result;
    for (const std::string name : {"inactive", "active", "mixed", "fb"})
      {
        Jacobian J{name, Vector<double>(n), Vector<double>(n)};
        for (unsigned int I = 0; I < n; ++I)
          {
            const bool active =
              name == "active" || (name == "mixed" && I % 3 != 1);
            if (name == "fb")
              {
                const double a = std::sin(3. * I + 1.), b = std::cos(5. * I);
                const double r = std::hypot(a, b);
                J.Ga(I)        = a / r - 1.;
                J.Gb(I)        = b / r - 1.;
              }
            else
              {
                J.Ga(I) = active ? 1. : 0.;
                J.Gb(I) = active ? 0. : 1.;
              }
          }
        result.push_back(J);
      }
    return result;
  }


  /// The full local matrix of the Newton step, unknowns (dx1, dx2, dx3,
  /// dy1, dy2), rows: cell rows u1, u2, complementarity, face rows.
  FullMatrix<double>
  full_local_system(const FullMatrix<double> &A,
                    const unsigned int        n_c,
                    const double              mu1,
                    const double              mu2,
                    const Jacobian           &J)
  {
    const unsigned int n_f = A.m() - n_c, N = 3 * n_c + 2 * n_f;
    FullMatrix<double> E(N, N);
    // position of (membrane alpha, local HHO index i) in the full system
    const auto at = [&](const unsigned int alpha, const unsigned int i) {
      return i < n_c ? alpha * n_c + i : 3 * n_c + alpha * n_f + (i - n_c);
    };
    const double mu[2] = {mu1, mu2};
    for (unsigned int alpha = 0; alpha < 2; ++alpha)
      for (unsigned int i = 0; i < A.m(); ++i)
        for (unsigned int j = 0; j < A.m(); ++j)
          E(at(alpha, i), at(alpha, j)) = mu[alpha] * A(i, j);
    for (unsigned int I = 0; I < n_c; ++I)
      {
        E(I, 2 * n_c + I)           = -1.;
        E(n_c + I, 2 * n_c + I)     = 1.;
        E(2 * n_c + I, I)           = J.Ga(I);
        E(2 * n_c + I, n_c + I)     = -J.Ga(I);
        E(2 * n_c + I, 2 * n_c + I) = J.Gb(I);
      }
    return E;
  }


  /// One case of the tests below: the cell of nodal_local_matrix() at
  /// degree p, with the Jacobian J, its cell unknowns eliminated and S the
  /// condensed matrix.
  struct CondensedCell
  {
    unsigned int               p, n_c;
    const FullMatrix<double>  &A;
    const SC::CellOperators   &cell;
    const Jacobian            &J;
    const SC::CellElimination &elimination;
    const FullMatrix<double>  &S;
  };

  /// Call `check` on the condensed cell of each degree in `degrees` with
  /// each Jacobian of jacobians().
  template <typename Check>
  void
  for_each_condensed_cell(const std::vector<unsigned int> &degrees,
                          const double                     mu1,
                          const double                     mu2,
                          const Check                     &check)
  {
    for (const unsigned int p : degrees)
      {
        unsigned int             n_c;
        const FullMatrix<double> A = nodal_local_matrix(p, n_c);
        SC::CellOperators        cell;
        cell.reinit(A, n_c);
        for (const Jacobian &J : jacobians(n_c))
          {
            SC::CellElimination elimination;
            elimination.reinit(cell, mu1, mu2, J.Ga, J.Gb);
            FullMatrix<double> S;
            elimination.condensed_matrix(cell, S);
            check(CondensedCell{p, n_c, A, cell, J, elimination, S});
          }
      }
  }
} // namespace


TEST(HHOStaticCondensation, CondensedMatrixIsTheSchurComplement)
{
  const double mu1 = 1., mu2 = 3.;
  for_each_condensed_cell({1, 2, 3, 4}, mu1, mu2, [&](const CondensedCell &c) {
    const FullMatrix<double> &S   = c.S;
    const unsigned int        n_f = c.cell.n_face, n_L = 3 * c.n_c;

    // Brute force: A_FF - A_FL A_LL^{-1} A_LF of the full system.
    const FullMatrix<double> E = full_local_system(c.A, c.n_c, mu1, mu2, c.J);
    FullMatrix<double> A_LL(n_L, n_L), A_LF(n_L, 2 * n_f), A_FL(2 * n_f, n_L),
      S_reference(2 * n_f, 2 * n_f);
    const auto L = SC::CellOperators::range(0, n_L);
    const auto F = SC::CellOperators::range(n_L, n_L + 2 * n_f);
    A_LL.extract_submatrix_from(E, L, L);
    A_LF.extract_submatrix_from(E, L, F);
    A_FL.extract_submatrix_from(E, F, L);
    S_reference.extract_submatrix_from(E, F, F);
    FullMatrix<double> A_LL_inverse(n_L, n_L), Z(n_L, 2 * n_f),
      correction(2 * n_f, 2 * n_f);
    A_LL_inverse.invert(A_LL);
    A_LL_inverse.mmult(Z, A_LF);
    A_FL.mmult(correction, Z);
    S_reference.add(-1., correction);

    const double scale = S_reference.linfty_norm();
    for (unsigned int k = 0; k < 2 * n_f; ++k)
      for (unsigned int l = 0; l < 2 * n_f; ++l)
        {
          EXPECT_NEAR(S(k, l), S_reference(k, l), 1e-11 * scale)
            << "p = " << c.p << ", " << c.J.name << ", (" << k << ", " << l
            << ")";
          EXPECT_EQ(S(k, l), S(l, k));
        }

    // Without contact the membranes decouple: no (u1, u2) block.
    if (c.J.name == "inactive")
      {
        for (unsigned int k = 0; k < n_f; ++k)
          for (unsigned int l = 0; l < n_f; ++l)
            EXPECT_EQ(S(k, n_f + l), 0.);
      }
  });
}


TEST(HHOStaticCondensation, RecoverySolvesTheCellRowsAndMatchesTheFaceRows)
{
  const double mu1 = 2., mu2 = 0.5;
  for_each_condensed_cell({1, 2, 3, 4}, mu1, mu2, [&](const CondensedCell &c) {
    const unsigned int n_f = c.cell.n_face, n_L = 3 * c.n_c;
    Vector<double>     r_L(n_L), dy(2 * n_f), dx_L, rhs_F;
    for (unsigned int i = 0; i < n_L; ++i)
      r_L(i) = std::sin(0.7 * i + 0.3);
    for (unsigned int k = 0; k < 2 * n_f; ++k)
      dy(k) = std::cos(1.3 * k);
    c.elimination.recover(c.cell, r_L, dy, dx_L);
    c.elimination.condensed_rhs(c.cell, r_L, rhs_F);

    // The full local system applied to (dx_L, dy): its cell rows must
    // give r_L, its face rows S dy - rhs_F (the cell's contribution to
    // the condensed equations).
    const FullMatrix<double> E = full_local_system(c.A, c.n_c, mu1, mu2, c.J);
    Vector<double>           x(n_L + 2 * n_f), Ex(n_L + 2 * n_f);
    for (unsigned int i = 0; i < n_L; ++i)
      x(i) = dx_L(i);
    for (unsigned int k = 0; k < 2 * n_f; ++k)
      x(n_L + k) = dy(k);
    E.vmult(Ex, x);
    Vector<double> Sdy(2 * n_f);
    c.S.vmult(Sdy, dy);
    const double scale = E.linfty_norm() * x.linfty_norm();
    for (unsigned int i = 0; i < n_L; ++i)
      EXPECT_NEAR(Ex(i), r_L(i), 1e-11 * scale)
        << "p = " << c.p << ", " << c.J.name << ", cell row " << i;
    for (unsigned int k = 0; k < 2 * n_f; ++k)
      EXPECT_NEAR(Ex(n_L + k), Sdy(k) - rhs_F(k), 1e-11 * scale)
        << "p = " << c.p << ", " << c.J.name << ", face row " << k;
  });
}


TEST(HHOStaticCondensation, CondensedMatrixIsPositiveSemidefinite)
{
  // For a fixed active set the condensed operator is the energy of the
  // equality-constrained local problem: symmetric positive semidefinite,
  // zero only on equal constants on the faces of both membranes.
  for_each_condensed_cell({3}, 1., 1., [](const CondensedCell &c) {
    const Vector<double> eigenvalues = VITest::symmetric_eigenvalues(c.S);
    const std::string   &name        = c.J.name;
    const double         largest     = eigenvalues(c.S.m() - 1);
    EXPECT_GE(eigenvalues(0), -1e-12 * largest) << name;
    // Kernel: constants on the faces of u1 and of u2 (independently when
    // they decouple, only equal ones when the multiplier ties them).
    const unsigned int kernel_dimension = name == "inactive" ? 2 : 1;
    EXPECT_GT(eigenvalues(kernel_dimension), 1e-6 * largest) << name;
    EXPECT_LE(std::abs(eigenvalues(kernel_dimension - 1)), 1e-10 * largest)
      << name;
  });
}


TEST(HHOStaticCondensation, MeanAndDifferenceDecoupleTheMembranes)
{
  // With dy1 = ds + (mu2/m) dd, dy2 = ds - (mu1/m) dd (m = mu1 + mu2), i.e.
  // dy = Y (ds, dd), the condensed matrix becomes Y^T S Y = diag(m Sc,
  // mu1 mu2 / m Sc + Q): the mean of the membranes does not see the contact.
  const double             mu1 = 0.7, mu2 = 2.5, m = mu1 + mu2;
  unsigned int             n_c;
  const FullMatrix<double> A = nodal_local_matrix(2, n_c);
  SC::CellOperators        cell;
  cell.reinit(A, n_c);
  const unsigned int n_f = cell.n_face;
  FullMatrix<double> Y(2 * n_f, 2 * n_f);
  for (unsigned int k = 0; k < n_f; ++k)
    {
      Y(k, k)             = 1.;
      Y(k, n_f + k)       = mu2 / m;
      Y(n_f + k, k)       = 1.;
      Y(n_f + k, n_f + k) = -mu1 / m;
    }
  for (const Jacobian &J : jacobians(n_c))
    {
      SC::CellElimination elimination;
      elimination.reinit(cell, mu1, mu2, J.Ga, J.Gb);
      FullMatrix<double> S, SY(2 * n_f, 2 * n_f), YSY(2 * n_f, 2 * n_f), S_mean,
        S_difference;
      elimination.condensed_matrix(cell, S);
      S.mmult(SY, Y);
      Y.Tmmult(YSY, SY);
      SC::CellElimination::mean_matrix(cell, mu1, mu2, S_mean);
      elimination.difference_matrix(cell, S_difference);
      const double scale = S.linfty_norm();
      for (unsigned int k = 0; k < n_f; ++k)
        for (unsigned int l = 0; l < n_f; ++l)
          {
            EXPECT_NEAR(YSY(k, l), S_mean(k, l), 1e-13 * scale) << J.name;
            EXPECT_NEAR(YSY(n_f + k, n_f + l),
                        S_difference(k, l),
                        1e-13 * scale)
              << J.name;
            EXPECT_NEAR(YSY(k, n_f + l), 0., 1e-13 * scale) << J.name;
            EXPECT_NEAR(YSY(n_f + k, l), 0., 1e-13 * scale) << J.name;
          }
    }
}
