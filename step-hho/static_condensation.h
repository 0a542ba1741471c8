#pragma once

// Static condensation of the linearised two-membrane HHO system, one cell at
// a time. Header-only, so that the unit tests
// (tests/unit/hho_static_condensation_test.cc) use exactly this code.
//
// On a cell K, with the local HHO matrix of one membrane (unit tension, cell
// space in the nodal basis)
//
//   A = [ K_CC  A_CF ]      n_c cell unknowns, n_f face unknowns,
//       [ A_FC  A_FF ]
//
// a semismooth Newton step solves, for the cell unknowns dx1, dx2 (nodal
// values of the membranes), dx3 (the multiplier's coefficients in the dual
// basis) and the face unknowns dy1, dy2,
//
//   mu1 (K_CC dx1 + A_CF dy1) - dx3            = s1   (cell rows, u1)
//   mu2 (K_CC dx2 + A_CF dy2) + dx3            = s2   (cell rows, u2)
//   Ga (dx1 - dx2) + Gb dx3                    = s3   (complementarity rows)
//   sum_K mu_alpha (A_FC dx_alpha + A_FF dy_alpha) = r_F_alpha  (face rows)
//
// with Ga, Gb the diagonal matrices of the generalised Jacobian (dC/da,
// dC/db) of the C-function at each node. The coupling blocks -I, +I come
// from the dual basis of the multiplier (the slides' I_d), and the
// complementarity rows are nodewise, so the first three block rows only
// involve the unknowns of K and the face unknowns of its faces: dx1, dx2 and
// dx3 are eliminated cell by cell, in two stages.
//
// 1. The membranes: dx1 = K_CC^{-1}(s1 + dx3)/mu1 - P dy1,
//                   dx2 = K_CC^{-1}(s2 - dx3)/mu2 - P dy2,   P = K_CC^{-1}
//                   A_CF,
//    the classical HHO cell solve (K_CC is symmetric positive definite).
// 2. The multiplier: inserted into the complementarity rows,
//
//      M3 dx3 = s3 - Ga K_CC^{-1} (s1/mu1 - s2/mu2) + Ga P (dy1 - dy2),
//      M3 = c Ga K_CC^{-1} + Gb,   c = 1/mu1 + 1/mu2,
//
//    an n_c x n_c system. M3 is invertible for both C-functions: Ga, Gb <= 0
//    or >= 0 with Ga + Gb != 0 at each node and K_CC^{-1} SPD, hence a
//    P-matrix (for Newton-min it is I on the inactive nodes and c K_CC^{-1}
//    restricted to the active ones).
//
// With W = M3^{-1} Ga P and Q = P^T W (symmetric positive semidefinite), the
// face rows become the cell's contribution to the condensed system
//
//   [ mu1 Sc + Q    -Q       ] [dy1]   [r_F1 - P^T (s1 + d3)]
//   [   -Q        mu2 Sc + Q ] [dy2] = [r_F2 - P^T (s2 - d3)],
//
// Sc = A_FF - A_FC P the one-membrane HHO Schur complement and
// d3 = M3^{-1} (s3 - Ga K_CC^{-1} (s1/mu1 - s2/mu2)). Q couples the two
// membranes only where nodes are (partly) in contact. After the face solve,
// dx3 = d3 + W (dy1 - dy2) and stage 1 recover the cell unknowns.
//
// Mean and difference. Both membranes have the same local operator, so the
// condensed system splits exactly: with m = mu1 + mu2 and the face unknowns
// of the weighted mean and of the difference of the membranes,
//
//   ds = (mu1 dy1 + mu2 dy2) / m,   dd = dy1 - dy2,
//   dy1 = ds + (mu2 / m) dd,        dy2 = ds - (mu1 / m) dd,
//
// the energy mu1 dy1.Sc dy1 + mu2 dy2.Sc dy2 + dd.Q dd of the condensed
// matrix is m ds.Sc ds + (mu1 mu2 / m) dd.Sc dd + dd.Q dd (the cross terms
// cancel). The system is block diagonal:
//
//   m Sc ds = b1 + b2,   (mu1 mu2 / m Sc + Q) dd = (mu2 b1 - mu1 b2) / m,
//
// for the right-hand side (b1, b2) above. The first block is the HHO
// discretisation of -Lap(mu1 u1 + mu2 u2) = f1 + f2, which the contact does
// not see; it is the same in every Newton step. The second, the obstacle
// problem for u1 - u2, carries all of the contact.

#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

namespace StepHHO
{
  namespace StaticCondensation
  {
    using namespace dealii;

    /**
     * The matrices of a cell that depend only on the mesh: the local HHO
     * matrix A of one membrane (unit tension, nodal cell basis) and what the
     * elimination of the cell unknowns needs from it. Computed once per mesh
     * and reused in every Newton step.
     */
    struct CellOperators
    {
      unsigned int       n_cell = 0, n_face = 0;
      FullMatrix<double> A;         ///< (n_c + n_f)^2
      FullMatrix<double> K_inverse; ///< K_CC^{-1}
      FullMatrix<double> P;         ///< K_CC^{-1} A_CF, n_c x n_f
      FullMatrix<double> Sc;        ///< A_FF - A_FC P, n_f x n_f

      void
      reinit(const FullMatrix<double> &local_matrix, const unsigned int n_c)
      {
        A      = local_matrix;
        n_cell = n_c;
        n_face = A.m() - n_c;
        FullMatrix<double> K(n_cell, n_cell), A_CF(n_cell, n_face);
        K.extract_submatrix_from(A, range(0, n_cell), range(0, n_cell));
        A_CF.extract_submatrix_from(A,
                                    range(0, n_cell),
                                    range(n_cell, n_cell + n_face));
        K_inverse.reinit(n_cell, n_cell);
        K_inverse.invert(K);
        P.reinit(n_cell, n_face);
        K_inverse.mmult(P, A_CF);
        // Sc = A_FF - A_FC P, with A_FC = A_CF^T (A is symmetric).
        Sc.reinit(n_face, n_face);
        Sc.extract_submatrix_from(A,
                                  range(n_cell, n_cell + n_face),
                                  range(n_cell, n_cell + n_face));
        FullMatrix<double> A_FC_P(n_face, n_face);
        A_CF.Tmmult(A_FC_P, P);
        Sc.add(-1., A_FC_P);
        // Symmetric in exact arithmetic; exactly so in floating point, so
        // that the condensed matrix is symmetric to the last bit (CG).
        for (unsigned int k = 0; k < n_face; ++k)
          for (unsigned int l = 0; l < k; ++l)
            Sc(k, l) = Sc(l, k) = 0.5 * (Sc(k, l) + Sc(l, k));
      }

      static std::vector<unsigned int>
      range(const unsigned int begin, const unsigned int end)
      {
        std::vector<unsigned int> indices(end - begin);
        for (unsigned int i = begin; i < end; ++i)
          indices[i - begin] = i;
        return indices;
      }
    };


    /**
     * The elimination of the cell unknowns (dx1, dx2, dx3) of one cell for
     * one generalised Jacobian (see the top of this file). Local vectors:
     * r_L = (s1, s2, s3) and dx_L = (dx1, dx2, dx3), length 3 n_c; face
     * vectors dy = (dy1, dy2) and the condensed right-hand side, length
     * 2 n_f.
     */
    class CellElimination
    {
    public:
      /// Ga, Gb: the Jacobian of the C-function at the n_c nodes of K.
      void
      reinit(const CellOperators  &cell,
             const double          mu1,
             const double          mu2,
             const Vector<double> &Ga,
             const Vector<double> &Gb)
      {
        this->mu1         = mu1;
        this->mu2         = mu2;
        this->Ga          = Ga;
        const unsigned n  = cell.n_cell;
        const double   c  = 1. / mu1 + 1. / mu2;
        has_contact_terms = Ga.linfty_norm() > 0.;

        M3_inverse.reinit(n, n);
        W.reinit(n, cell.n_face);
        if (!has_contact_terms)
          {
            // No node sees the membranes' difference: dx3 = s3 / Gb.
            for (unsigned int I = 0; I < n; ++I)
              M3_inverse(I, I) = 1. / Gb(I);
            return;
          }
        FullMatrix<double> M3(n, n);
        for (unsigned int I = 0; I < n; ++I)
          {
            for (unsigned int J = 0; J < n; ++J)
              M3(I, J) = c * Ga(I) * cell.K_inverse(I, J);
            M3(I, I) += Gb(I);
          }
        M3_inverse.invert(M3);
        FullMatrix<double> GaP(cell.P);
        for (unsigned int I = 0; I < n; ++I)
          for (unsigned int k = 0; k < cell.n_face; ++k)
            GaP(I, k) *= Ga(I);
        M3_inverse.mmult(W, GaP);
      }


      /// The cell's contribution to the condensed face matrix, 2 n_f x 2 n_f,
      /// for the face unknowns (dy1, dy2).
      void
      condensed_matrix(const CellOperators &cell, FullMatrix<double> &S) const
      {
        const unsigned int n_f = cell.n_face;
        FullMatrix<double> Q;
        contact_coupling(cell, Q);
        S.reinit(2 * n_f, 2 * n_f);
        for (unsigned int k = 0; k < n_f; ++k)
          for (unsigned int l = 0; l < n_f; ++l)
            {
              S(k, l)             = mu1 * cell.Sc(k, l) + Q(k, l);
              S(n_f + k, n_f + l) = mu2 * cell.Sc(k, l) + Q(k, l);
              S(k, n_f + l)       = -Q(k, l);
              S(n_f + k, l)       = -Q(k, l);
            }
      }


      /// The cell's contribution to the matrix of the mean, (mu1 + mu2) Sc.
      static void
      mean_matrix(const CellOperators &cell,
                  const double         mu1,
                  const double         mu2,
                  FullMatrix<double>  &S_mean)
      {
        S_mean.reinit(cell.n_face, cell.n_face);
        S_mean.add(mu1 + mu2, cell.Sc);
      }


      /// The cell's contribution to the matrix of the difference,
      /// mu1 mu2 / (mu1 + mu2) Sc + Q.
      void
      difference_matrix(const CellOperators &cell,
                        FullMatrix<double>  &S_difference) const
      {
        contact_coupling(cell, S_difference);
        S_difference.add(mu1 * mu2 / (mu1 + mu2), cell.Sc);
      }


      /// The coupling of the membranes through the contact rows, Q = P^T W.
      void
      contact_coupling(const CellOperators &cell, FullMatrix<double> &Q) const
      {
        const unsigned int n_f = cell.n_face;
        Q.reinit(n_f, n_f);
        if (!has_contact_terms)
          return;
        cell.P.Tmmult(Q, W);
        // Q is symmetric in exact arithmetic; make it so in floating point,
        // so that the condensed matrices are symmetric to the last bit (CG).
        for (unsigned int k = 0; k < n_f; ++k)
          for (unsigned int l = 0; l < k; ++l)
            Q(k, l) = Q(l, k) = 0.5 * (Q(k, l) + Q(l, k));
      }


      /**
       * The cell's contribution to the right-hand side of the condensed
       * system: (-P^T (s1 + d3), -P^T (s2 - d3)).
       */
      void
      condensed_rhs(const CellOperators  &cell,
                    const Vector<double> &r_L,
                    Vector<double>       &rhs_F) const
      {
        const unsigned int n_c = cell.n_cell, n_f = cell.n_face;
        Vector<double>     s1(n_c), s2(n_c), d3(n_c);
        split(r_L, n_c, s1, s2);
        compute_d3(cell, r_L, d3);
        s1 += d3;
        s2 -= d3;
        Vector<double> t(n_f);
        rhs_F.reinit(2 * n_f);
        cell.P.Tvmult(t, s1);
        for (unsigned int k = 0; k < n_f; ++k)
          rhs_F(k) = -t(k);
        cell.P.Tvmult(t, s2);
        for (unsigned int k = 0; k < n_f; ++k)
          rhs_F(n_f + k) = -t(k);
      }


      /// The cell unknowns dx_L from the right-hand side r_L and the faces dy.
      void
      recover(const CellOperators  &cell,
              const Vector<double> &r_L,
              const Vector<double> &dy,
              Vector<double>       &dx_L) const
      {
        const unsigned int n_c = cell.n_cell, n_f = cell.n_face;
        Vector<double>     s1(n_c), s2(n_c), dx3(n_c), t(n_c);
        split(r_L, n_c, s1, s2);
        compute_d3(cell, r_L, dx3);

        Vector<double> dy1(n_f), dy2(n_f), jump(n_f);
        for (unsigned int k = 0; k < n_f; ++k)
          {
            dy1(k)  = dy(k);
            dy2(k)  = dy(n_f + k);
            jump(k) = dy1(k) - dy2(k);
          }
        if (has_contact_terms)
          W.vmult_add(dx3, jump);

        dx_L.reinit(3 * n_c);
        s1 += dx3;
        s2 -= dx3;
        Vector<double> x1(n_c), x2(n_c);
        cell.K_inverse.vmult(x1, s1);
        cell.K_inverse.vmult(x2, s2);
        cell.P.vmult(t, dy1);
        for (unsigned int I = 0; I < n_c; ++I)
          dx_L(I) = x1(I) / mu1 - t(I);
        cell.P.vmult(t, dy2);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            dx_L(n_c + I)     = x2(I) / mu2 - t(I);
            dx_L(2 * n_c + I) = dx3(I);
          }
      }

    private:
      static void
      split(const Vector<double> &r_L,
            const unsigned int    n_c,
            Vector<double>       &s1,
            Vector<double>       &s2)
      {
        for (unsigned int I = 0; I < n_c; ++I)
          {
            s1(I) = r_L(I);
            s2(I) = r_L(n_c + I);
          }
      }

      /// d3 = M3^{-1} (s3 - Ga K_CC^{-1} (s1/mu1 - s2/mu2)).
      void
      compute_d3(const CellOperators  &cell,
                 const Vector<double> &r_L,
                 Vector<double>       &d3) const
      {
        const unsigned int n_c = cell.n_cell;
        Vector<double>     z(n_c), s12(n_c), t(n_c);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            s12(I) = r_L(I) / mu1 - r_L(n_c + I) / mu2;
            z(I)   = r_L(2 * n_c + I);
          }
        if (has_contact_terms)
          {
            cell.K_inverse.vmult(t, s12);
            for (unsigned int I = 0; I < n_c; ++I)
              z(I) -= Ga(I) * t(I);
          }
        M3_inverse.vmult(d3, z);
      }

      double             mu1 = 1., mu2 = 1.;
      bool               has_contact_terms = false;
      Vector<double>     Ga;
      FullMatrix<double> M3_inverse; ///< (c Ga K_CC^{-1} + Gb)^{-1}
      FullMatrix<double> W;          ///< M3^{-1} Ga P
    };
  } // namespace StaticCondensation
} // namespace StepHHO
