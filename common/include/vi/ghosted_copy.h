#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/lac/trilinos_vector.h>

#include <memory>
#include <mpi.h>

class Epetra_Import;

namespace VI
{
  /**
   * Copies vectors of locally owned entries into vectors with the ghost
   * entries of one parallel layout (`owned` plus `relevant`), with the
   * Trilinos map of that layout and the Epetra_Import of the exchange built
   * once, in reinit(). (deal.II 9.4 builds a map from the index sets in
   * every reinit(owned, relevant, comm) and an Epetra_Import in every
   * assignment between layouts: about 0.1 s per copy of 4e5 entries per
   * process on two processes, doc/performance.md.)
   */
  class GhostedCopy
  {
  public:
    using Vector = dealii::TrilinosWrappers::MPI::Vector;

    GhostedCopy();
    ~GhostedCopy();

    /// The layout: `relevant` contains `owned`. Collective.
    void
    reinit(const dealii::IndexSet &owned,
           const dealii::IndexSet &relevant,
           const MPI_Comm          comm);

    /// ghosted = owned_vector, ghost entries included: `ghosted` takes the
    /// layout (sharing its map) unless it has it already. Collective.
    void
    copy(const Vector &owned_vector, Vector &ghosted) const;

  private:
    /// A zero vector of the ghosted layout, whose map the copies share.
    Vector                         layout;
    std::unique_ptr<Epetra_Import> import;
  };
} // namespace VI
