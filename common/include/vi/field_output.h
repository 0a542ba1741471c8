#pragma once

#include <deal.II/base/mpi.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>

#include <memory>
#include <optional>
#include <string>

namespace VI
{
  struct ContactEstimate;

  /**
   * The fields of a solution of the membrane problems, functions of one
   * DoFHandler, and where the membranes touch: a nodal indicator of the
   * contact set, or (for the HHO cell unknowns) the share of each cell's
   * nodes in contact.
   */
  struct MembraneFields
  {
    using Vector = dealii::TrilinosWrappers::MPI::Vector;
    const Vector                &u1, &u2, &gap, &lambda;
    const Vector                *contact_set      = nullptr;
    const dealii::Vector<float> *contact_fraction = nullptr;
  };


  /**
   * The VTU output of the membrane programs, one file per cycle (or time
   * step) with its .pvtu record. Every program writes the same fields under
   * the same names (doc/ and ParaView states rely on them): u1, u2, gap,
   * lambda, contact, partition (the process that owns the cell), then cell
   * fields such as the estimators' indicators. Patches have the degree of
   * the finite element, curved inner cells where the domain's cells are
   * curved (`curved_cells`).
   * Fields given by reference must outlive write().
   */
  template <int dim>
  class FieldOutput
  {
  public:
    FieldOutput(const dealii::Mapping<dim>    &mapping,
                const bool                     curved_cells,
                const dealii::DoFHandler<dim> &dof_handler,
                const MembraneFields          &fields);

    ~FieldOutput();

    /// The cellwise indicators of `estimate`, if there is one.
    void
    add_indicators(const ContactEstimate *estimate);

    void
    add_cell_field(const dealii::Vector<float> &field, const std::string &name);

    /**
     * Write <directory>/solution_<counter>.vtu (`n_digits` digits) with its
     * .pvtu record, with the time of the step if it is given. Returns the
     * name of the record.
     */
    std::string
    write(const std::string          &directory,
          const unsigned int          counter,
          const unsigned int          n_digits,
          const MPI_Comm              comm,
          const std::optional<double> time = {});

  private:
    struct Data;
    std::unique_ptr<Data> data;
  };
} // namespace VI
