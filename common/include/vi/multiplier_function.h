#pragma once

#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/contact_rows.h>
#include <vi/ghosted_copy.h>

namespace VI
{
  /**
   * The discrete multiplier as a finite element function. lambda_h acts on
   * the potentials only through its moments m_i = <lambda_h, psi_i>_h =
   * D_i X3_i at the contact nodes; its representative v has v_i = m_i / D_i
   * for the lumped bracket of p = 1 and solves M v = m (the L2 Gram matrix)
   * for p >= 2; hanging nodes follow their parents.
   *
   * It reads the program's objects at every call, so they may be rebuilt on
   * every mesh.
   */
  class MultiplierFunction
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    /// `mass_matrix` is used for p >= 2 only; `ghosts` copies into the
    /// layout with the locally relevant nodes (that of the functions
    /// with_nonnegative_part() returns).
    MultiplierFunction(
      const unsigned int                            degree,
      const ContactRows                            &contact_rows,
      const Vector                                 &coupling,
      const dealii::TrilinosWrappers::SparseMatrix &mass_matrix,
      const dealii::AffineConstraints<double>      &hanging_nodes,
      const GhostedCopy                            &ghosts);

    /// v with <v, psi_i>_h = m_i (m = 0 on constrained nodes); v owned.
    void
    from_moments(const Vector &moments, Vector &v) const;

    /// lambda_h and the function of the nonnegative moments max(m, 0) (the
    /// multiplier of the discretisation estimate), both with ghosts; with
    /// an `offset` G, the functions of m - G and max(m, 0) - G (the moments
    /// a TransmittedLoad leaves).
    void
    with_nonnegative_part(const Vector &moments,
                          Vector       &lambda,
                          Vector       &lambda_nonnegative,
                          const Vector *offset = nullptr) const;

  private:
    const unsigned int                            degree;
    const ContactRows                            &contact_rows;
    const Vector                                 &coupling;
    const dealii::TrilinosWrappers::SparseMatrix &mass_matrix;
    const dealii::AffineConstraints<double>      &hanging_nodes;
    const GhostedCopy                            &ghosts;
  };
} // namespace VI
