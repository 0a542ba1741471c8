#pragma once

#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>

#include <optional>

namespace VI
{
  template <int dim>
  struct MembraneData;

  /// The errors of a discrete solution where the exact one is known.
  struct MembraneErrors
  {
    /// (mu1 |u1 - u1_h|_1^2 + mu2 |u2 - u2_h|_1^2)^(1/2), the gradients
    /// taken cell by cell (the broken seminorm for discontinuous spaces).
    double energy = 0;
    /// ||lambda - lambda_h||_0 where the exact multiplier is known.
    std::optional<double> multiplier;
    /// The energy error of each active cell (zero on other ranks' cells):
    /// beside the indicators in the VTU, the local effectivity.
    dealii::Vector<float> cellwise;
  };

  /**
   * The errors of the ghosted finite element functions u1_h, u2_h and
   * lambda_h (one scalar element on `dof_handler`) against the exact
   * solution of `data`, with p + 3 Gauss points per direction on every
   * owned cell (p the element's degree).
   *
   * The cells are shared among the threads (MeshWorker::mesh_loop) and the
   * exact gradients are the data's own: for a parsed expression these are
   * fourth-order differences, eight evaluations per point, and on one
   * thread this was the longest part of a run after the solve.
   */
  template <int dim>
  MembraneErrors
  membrane_errors(const dealii::Mapping<dim>                  &mapping,
                  const dealii::DoFHandler<dim>               &dof_handler,
                  const MembraneData<dim>                     &data,
                  const dealii::TrilinosWrappers::MPI::Vector &u1_h,
                  const dealii::TrilinosWrappers::MPI::Vector &u2_h,
                  const dealii::TrilinosWrappers::MPI::Vector &lambda_h);
} // namespace VI
