#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_solver.h>

#include <vi/multiplier_function.h>

#include <algorithm>

namespace VI
{
  using namespace dealii;

  MultiplierFunction::MultiplierFunction(
    const unsigned int                    degree,
    const ContactRows                    &contact_rows,
    const Vector                         &coupling,
    const TrilinosWrappers::SparseMatrix &mass_matrix,
    const AffineConstraints<double>      &hanging_nodes,
    const GhostedCopy                    &ghosts)
      : degree(degree)
      , contact_rows(contact_rows)
      , coupling(coupling)
      , mass_matrix(mass_matrix)
      , hanging_nodes(hanging_nodes)
      , ghosts(ghosts)
  {
  }


  void
  MultiplierFunction::from_moments(const Vector &moments, Vector &v) const
  {
    v = 0;
    if (degree == 1)
      {
        for (const types::global_dof_index i : contact_rows.nodes())
          v(i) = moments(i) / coupling(i);
        v.compress(VectorOperation::insert);
      }
    else
      {
        const double norm = moments.l2_norm();
        if (norm > 0)
          {
            SolverControl                        control(1000, 1e-13 * norm);
            TrilinosWrappers::SolverCG           cg(control);
            TrilinosWrappers::PreconditionJacobi jacobi;
            jacobi.initialize(mass_matrix);
            cg.solve(mass_matrix, v, moments, jacobi);
          }
      }
    hanging_nodes.distribute(v);
  }


  void
  MultiplierFunction::with_nonnegative_part(const Vector &moments,
                                            Vector       &lambda,
                                            Vector       &lambda_nonnegative,
                                            const Vector *offset) const
  {
    const IndexSet owned = moments.locally_owned_elements();
    const MPI_Comm comm  = moments.get_mpi_communicator();
    Vector         function(owned, comm), shifted(moments);
    if (offset)
      shifted -= *offset;
    from_moments(shifted, function);
    ghosts.copy(function, lambda);

    Vector nonnegative(moments);
    for (double &m : nonnegative)
      m = std::max(m, 0.);
    if (offset)
      nonnegative -= *offset;
    from_moments(nonnegative, function);
    ghosts.copy(function, lambda_nonnegative);
  }
} // namespace VI
