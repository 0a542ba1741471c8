#pragma once

#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/complementarity.h>
#include <vi/contact_rows.h>

#include <vector>

namespace VI
{
  /**
   * Preconditioner for the linearised semismooth Newton systems of the
   * two-membrane problems,
   *
   *   [mu1 S    0   -D] [d1]   [r1]
   *   [  0   mu2 S  +D] [d2] = [r2],     (node-interleaved, see NodalFields)
   *   [  J_C rows     ] [d3]   [r3]
   *
   * whose C-function rows read alpha_i (d1_i - d2_i) + beta_i d3_i = r3_i
   * (alpha, beta the gradient of the rows: of C, or of the smoothed C_mu on
   * the continuation's path, where both are nonzero near contact).
   * It rests on an exact decoupling: with the mean and the gap
   *
   *   m = (mu1 d1 + mu2 d2) / (mu1 + mu2),    w = d1 - d2,
   *
   * the energy mu1 |grad d1|^2 + mu2 |grad d2|^2 = (mu1 + mu2) |grad m|^2 +
   * mu_r |grad w|^2, mu_r = mu1 mu2 / (mu1 + mu2), has no cross term, and the
   * multiplier only acts on w. Eliminating d3 node by node (d3 = (r3 - alpha
   * w) / beta where beta != 0) leaves two scalar SPD problems:
   *
   *   (mu1 + mu2) S m = r1' + r2',        (contact-free: set up once per mesh)
   *   (mu_r S + K) w = (mu2 r1' - mu1 r2') / (mu1 + mu2),
   *
   * with K = diag(D_i alpha_i / beta_i) >= 0 (0 on the inactive nodes of
   * Newton-min) and, where beta_i = 0 (the nodes in contact), the tie
   * w_i = r3_i / alpha_i imposed by a penalty. Each is approximated by one
   * AMG V-cycle (Trilinos ML); d3 on the tied nodes follows from the first
   * row. The preconditioner is a fixed linear operator, so the outer GMRES
   * on the exact system converges with iteration counts independent of the
   * mesh size (issue 4 measures them).
   */
  class ContactPreconditioner
  {
  public:
    struct AdditionalData
    {
      /// Penalty of the ties relative to the diagonal of mu_r S.
      double tie_penalty = 1e4;
      /// AMG for elements of degree > 1 (ML's higher-order settings).
      bool higher_order_elements = false;
    };

    explicit ContactPreconditioner(const AdditionalData &data);

    /**
     * Once per mesh: the scalar stiffness matrix S (assembled with the
     * homogeneous constraints, so constrained rows are decoupled), the
     * tensions, the coupling D per node (zero on constrained nodes) and the
     * contact rows.
     */
    void
    initialize_mesh(const dealii::TrilinosWrappers::SparseMatrix &S,
                    const double                                  mu1,
                    const double                                  mu2,
                    const dealii::TrilinosWrappers::MPI::Vector  &coupling,
                    const ContactRows                            &rows);

    /// Once per Newton step: the generalised Jacobian rows at X.
    void
    initialize_jacobian(const ComplementarityFunction               &C,
                        const dealii::TrilinosWrappers::MPI::Vector &X);

    /// dst = P^{-1} src (node-interleaved vectors without ghosts).
    void
    vmult(dealii::TrilinosWrappers::MPI::Vector       &dst,
          const dealii::TrilinosWrappers::MPI::Vector &src) const;

  private:
    AdditionalData                                data;
    const dealii::TrilinosWrappers::SparseMatrix *stiffness = nullptr;
    double                                        mu1 = 1, mu2 = 1;
    dealii::TrilinosWrappers::PreconditionAMG     amg_mean, amg_gap;
    dealii::TrilinosWrappers::SparseMatrix        gap_matrix;
    std::vector<double> coupling;    ///< D per owned node
    std::vector<double> diagonal;    ///< S_ii per owned node
    std::vector<bool>   is_contact;  ///< owned node has a contact row
    std::vector<double> alpha, beta; ///< J_C rows per owned node
    std::vector<bool>   tied;
    std::vector<double> penalty; ///< per owned node
    const ContactRows  *rows = nullptr;
    mutable dealii::TrilinosWrappers::MPI::Vector mean, gap, rhs_mean, rhs_gap,
      first, stiffness_first;
  };
} // namespace VI
