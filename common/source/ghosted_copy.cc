#include <deal.II/base/exceptions.h>
#include <deal.II/lac/exceptions.h>

#include <vi/ghosted_copy.h>

#include <Epetra_Import.h>

namespace VI
{
  using namespace dealii;

  GhostedCopy::GhostedCopy() = default;

  GhostedCopy::~GhostedCopy() = default;


  void
  GhostedCopy::reinit(const IndexSet &owned,
                      const IndexSet &relevant,
                      const MPI_Comm  comm)
  {
    layout.reinit(owned, relevant, comm);
    const Vector owned_layout(owned, comm);
    import =
      std::make_unique<Epetra_Import>(layout.trilinos_partitioner(),
                                      owned_layout.trilinos_partitioner());
  }


  void
  GhostedCopy::copy(const Vector &owned_vector, Vector &ghosted) const
  {
    Assert(import, ExcNotInitialized());
    // (the identity of the map's data, not Epetra's SameAs, which compares
    // the maps entry by entry and across the processes)
    if (ghosted.trilinos_partitioner().DataPtr() !=
        layout.trilinos_partitioner().DataPtr())
      ghosted.reinit(layout);
    const int error =
      ghosted.trilinos_vector().Import(owned_vector.trilinos_vector(),
                                       *import,
                                       Insert);
    AssertThrow(error == 0, ExcTrilinosError(error));
  }
} // namespace VI
