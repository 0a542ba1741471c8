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

#include <vi/reduced_tension.h>

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
        const unsigned n  = cell.n_cell;
        const double   c  = 1. / mu1 + 1. / mu2;
        has_contact_terms = Ga.linfty_norm() > 0.;
        this->Ga.reinit(has_contact_terms ? n : 0);
        if (!has_contact_terms)
          {
            // No node sees the membranes' difference: dx3 = s3 / Gb.
            M3_inverse.reinit(n, 1);
            for (unsigned int I = 0; I < n; ++I)
              M3_inverse(I, 0) = 1. / Gb(I);
            W.reinit(0, 0);
            return;
          }
        this->Ga     = Ga;
        Workspace &w = workspace();
        w.M3.reinit(n, n);
        for (unsigned int I = 0; I < n; ++I)
          {
            for (unsigned int J = 0; J < n; ++J)
              w.M3(I, J) = c * Ga(I) * cell.K_inverse(I, J);
            w.M3(I, I) += Gb(I);
          }
        M3_inverse.reinit(n, n);
        M3_inverse.invert(w.M3);
        w.GaP = cell.P;
        for (unsigned int I = 0; I < n; ++I)
          for (unsigned int k = 0; k < cell.n_face; ++k)
            w.GaP(I, k) *= Ga(I);
        W.reinit(n, cell.n_face);
        M3_inverse.mmult(W, w.GaP);
      }


      /// The cell's contribution to the condensed face matrix, 2 n_f x 2 n_f,
      /// for the face unknowns (dy1, dy2).
      void
      condensed_matrix(const CellOperators &cell, FullMatrix<double> &S) const
      {
        const unsigned int  n_f = cell.n_face;
        FullMatrix<double> &Q   = workspace().Q;
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
        S_difference.add(VI::reduced_tension(mu1, mu2), cell.Sc);
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
        Workspace         &w = workspace();
        compute_d3(cell, r_L, w.d3);
        w.s1.reinit(n_c, true);
        w.s2.reinit(n_c, true);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            w.s1(I) = r_L(I) + w.d3(I);
            w.s2(I) = r_L(n_c + I) - w.d3(I);
          }
        w.t_f.reinit(n_f, true);
        rhs_F.reinit(2 * n_f, true);
        cell.P.Tvmult(w.t_f, w.s1);
        for (unsigned int k = 0; k < n_f; ++k)
          rhs_F(k) = -w.t_f(k);
        cell.P.Tvmult(w.t_f, w.s2);
        for (unsigned int k = 0; k < n_f; ++k)
          rhs_F(n_f + k) = -w.t_f(k);
      }


      /// The cell unknowns dx_L from the right-hand side r_L and the faces dy.
      void
      recover(const CellOperators  &cell,
              const Vector<double> &r_L,
              const Vector<double> &dy,
              Vector<double>       &dx_L) const
      {
        const unsigned int n_c = cell.n_cell, n_f = cell.n_face;
        Workspace         &w   = workspace();
        Vector<double>    &dx3 = w.d3;
        compute_d3(cell, r_L, dx3);
        w.dy1.reinit(n_f, true);
        w.dy2.reinit(n_f, true);
        for (unsigned int k = 0; k < n_f; ++k)
          {
            w.dy1(k) = dy(k);
            w.dy2(k) = dy(n_f + k);
          }
        if (has_contact_terms)
          {
            w.t_f.reinit(n_f, true);
            for (unsigned int k = 0; k < n_f; ++k)
              w.t_f(k) = w.dy1(k) - w.dy2(k);
            W.vmult_add(dx3, w.t_f);
          }

        w.s1.reinit(n_c, true);
        w.s2.reinit(n_c, true);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            w.s1(I) = r_L(I) + dx3(I);
            w.s2(I) = r_L(n_c + I) - dx3(I);
          }
        w.x1.reinit(n_c, true);
        w.x2.reinit(n_c, true);
        cell.K_inverse.vmult(w.x1, w.s1);
        cell.K_inverse.vmult(w.x2, w.s2);
        dx_L.reinit(3 * n_c, true);
        w.t_c.reinit(n_c, true);
        cell.P.vmult(w.t_c, w.dy1);
        for (unsigned int I = 0; I < n_c; ++I)
          dx_L(I) = w.x1(I) / mu1 - w.t_c(I);
        cell.P.vmult(w.t_c, w.dy2);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            dx_L(n_c + I)     = w.x2(I) / mu2 - w.t_c(I);
            dx_L(2 * n_c + I) = dx3(I);
          }
      }

    private:
      /**
       * Temporaries of the calls above. The cell loops run on several
       * threads, each with its own workspace; it is reused from cell to cell
       * instead of allocating vectors and matrices for every cell.
       */
      struct Workspace
      {
        FullMatrix<double> M3, GaP, Q;
        Vector<double>     s1, s2, s12, z, d3, t_c, t_f, dy1, dy2, x1, x2;
      };

      static Workspace &
      workspace()
      {
        static thread_local Workspace w;
        return w;
      }

      /// d3 = M3^{-1} (s3 - Ga K_CC^{-1} (s1/mu1 - s2/mu2)).
      void
      compute_d3(const CellOperators  &cell,
                 const Vector<double> &r_L,
                 Vector<double>       &d3) const
      {
        const unsigned int n_c = cell.n_cell;
        Workspace         &w   = workspace();
        d3.reinit(n_c, true);
        if (!has_contact_terms)
          {
            for (unsigned int I = 0; I < n_c; ++I)
              d3(I) = M3_inverse(I, 0) * r_L(2 * n_c + I);
            return;
          }
        w.s12.reinit(n_c, true);
        w.z.reinit(n_c, true);
        w.t_c.reinit(n_c, true);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            w.s12(I) = r_L(I) / mu1 - r_L(n_c + I) / mu2;
            w.z(I)   = r_L(2 * n_c + I);
          }
        cell.K_inverse.vmult(w.t_c, w.s12);
        for (unsigned int I = 0; I < n_c; ++I)
          w.z(I) -= Ga(I) * w.t_c(I);
        M3_inverse.vmult(d3, w.z);
      }

      double         mu1 = 1., mu2 = 1.;
      bool           has_contact_terms = false;
      Vector<double> Ga; ///< (empty without contact terms)
      /// (c Ga K_CC^{-1} + Gb)^{-1}; its diagonal 1 / Gb (one column)
      /// without contact terms.
      FullMatrix<double> M3_inverse;
      FullMatrix<double> W; ///< M3^{-1} Ga P (empty without contact terms)
    };
  } // namespace StaticCondensation
} // namespace StepHHO
