#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>

#include <vi/process_usage.h>

#include <mpi.h>

namespace dealii::TrilinosWrappers::MPI
{
  class Vector;
}

namespace StepMembranes
{
  /// What one reference Poisson solve cost.
  struct PoissonCost
  {
    double       seconds    = 0; ///< wall time, set-up to solution
    unsigned int iterations = 0; ///< CG iterations
    /// CPU time and page faults of the same span, summed over the processes
    VI::ProcessUsage usage;
  };

  /**
   * The cost unit of the cost benchmark (bench/membranes_cost.py,
   * doc/performance.md): one membrane without contact,
   *
   *   -mu Lap u = f in Omega,  u = g on the boundary,
   *
   * on the mesh and the DoFHandler of the contact problem, solved as a user
   * of deal.II and Trilinos would: constraints (hanging nodes and Dirichlet
   * data), sparsity pattern, assembly through the constraints (with
   * `quadrature`: the caller passes Gauss with p + 1 points per direction,
   * the rule such a code takes), AMG (Trilinos
   * ML, the settings of the contact preconditioner) and CG to a residual
   * 1e-8 times that of the zero vector. As in the contact problem, the cell
   * integrals run on all threads (f must be safe to evaluate from several
   * threads at once, as the problem data are). All of it is timed; the DoFs are
   * already distributed. Collective over the processes of the mesh.
   *
   * If `solution` is given, it receives u_h (reinitialised to the owned
   * DoFs, constrained entries set), after the timer has stopped: the unit
   * test checks with it that the cost unit solves the problem it claims
   * to (tests/unit/reference_poisson_test.cc).
   */
  template <int dim>
  PoissonCost
  reference_poisson_solve(
    const dealii::Mapping<dim>            &mapping,
    const dealii::DoFHandler<dim>         &dof_handler,
    const dealii::Quadrature<dim>         &quadrature,
    const double                           mu,
    const dealii::Function<dim>           &f,
    const dealii::Function<dim>           &g,
    const MPI_Comm                         comm,
    dealii::TrilinosWrappers::MPI::Vector *solution = nullptr);
} // namespace StepMembranes
