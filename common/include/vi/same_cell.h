#pragma once

#include <deal.II/dofs/dof_handler.h>

namespace VI
{
  /**
   * `cell` (an active cell of the triangulation or of any DoFHandler on it)
   * as a cell of `dofs`, a DoFHandler on the same triangulation: to read
   * the values of another element on the same cell.
   */
  template <int dim, typename CellIterator>
  typename dealii::DoFHandler<dim>::active_cell_iterator
  same_cell(const CellIterator &cell, const dealii::DoFHandler<dim> &dofs)
  {
    return typename dealii::DoFHandler<dim>::active_cell_iterator(
      &dofs.get_triangulation(), cell->level(), cell->index(), &dofs);
  }
} // namespace VI
