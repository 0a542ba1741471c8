#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/vector.h>

#include <vi/transmitted_load.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace VI
{
  using namespace dealii;

  template <int dim>
  void
  TransmittedLoad<dim>::reinit(const Mapping<dim>              &mapping,
                               const DoFHandler<dim>           &dof_handler,
                               const AffineConstraints<double> &no_moment,
                               const Quadrature<dim>           &quadrature)
  {
    this->mapping     = &mapping;
    this->dof_handler = &dof_handler;
    this->no_moment   = &no_moment;
    this->quadrature  = quadrature;
  }


  namespace
  {
    // What a cell at the contact set (not a contact cell) costs the
    // estimate, in squared energy, for each way of treating it:
    // - left out of J: lambda~ carries a cell mean of g at best, and the
    //   residuals of the membranes the rest, (h_K / pi)^2 / m |g - mean_K
    //   g|_K^2 (m = mu1 mu2 / (mu1 + mu2));
    // - in J: the contact term of the nodal cone reconstruction s_h,
    //   2 (g^+, (s1 - s2)^+)_K;
    // - in J and joined: the energy of the gap's nodal values taken off,
    //   m sum_i gap_i^2 |grad phi_i|^2 (the cell's part of |grad phi_i|^2
    //   times the number of cells at x_i).
    // `values` is reinitialised on the cell, `g` holds g at its points.
    // A constrained node with parents (a hanging node), not a Dirichlet
    // one.
    bool
    is_hanging(const AffineConstraints<double> &constraints,
               const types::global_dof_index    i)
    {
      const auto *entries = constraints.get_constraint_entries(i);
      return entries && !entries->empty();
    }


    // The nodes that carry a moment and decide the values on a cell: its
    // unconstrained nodes and the parents of its hanging nodes.
    void
    add_free_nodes(const AffineConstraints<double>            &constraints,
                   const std::vector<types::global_dof_index> &dofs,
                   std::vector<types::global_dof_index>       &nodes)
    {
      for (const types::global_dof_index i : dofs)
        if (!constraints.is_constrained(i))
          nodes.push_back(i);
        else if (is_hanging(constraints, i))
          for (const auto &[parent, weight] :
               *constraints.get_constraint_entries(i))
            nodes.push_back(parent);
    }


    struct CellChoice
    {
      double left_out = 0, in_j = 0, joined = 0;
    };

    template <int dim>
    CellChoice
    cell_choice(const FEValues<dim>                        &values,
                const std::vector<types::global_dof_index> &dofs,
                const AffineConstraints<double>            &no_moment,
                const std::vector<double>                  &g,
                const double                                m,
                const double                                h,
                const TrilinosWrappers::MPI::Vector        &s1,
                const TrilinosWrappers::MPI::Vector        &s2,
                std::vector<double>                        &gap,
                std::vector<double>                        &s2_values)
    {
      CellChoice choice;
      values.get_function_values(s1, gap);
      values.get_function_values(s2, s2_values);
      double measure = 0, mean = 0;
      for (unsigned int q = 0; q < gap.size(); ++q)
        {
          measure += values.JxW(q);
          mean += g[q] * values.JxW(q);
          choice.in_j += 2. * std::max(g[q], 0.) *
                         std::max(gap[q] - s2_values[q], 0.) * values.JxW(q);
        }
      mean /= measure;
      for (unsigned int q = 0; q < gap.size(); ++q)
        choice.left_out += std::pow(g[q] - mean, 2) * values.JxW(q);
      choice.left_out *= std::pow(h / numbers::PI, 2) / m;

      const FiniteElement<dim> &fe = values.get_fe();
      for (unsigned int i = 0; i < dofs.size(); ++i)
        {
          const double gap_i = s1(dofs[i]) - s2(dofs[i]);
          if (gap_i == 0.)
            continue;
          // (a Dirichlet node keeps its gap: the cell cannot be joined; a
          // hanging node follows its parents)
          if (no_moment.is_constrained(dofs[i]))
            {
              if (!is_hanging(no_moment, dofs[i]))
                {
                  choice.joined = std::numeric_limits<double>::infinity();
                  break;
                }
              continue;
            }
          const GeometryPrimitive primitive =
            fe.get_associated_geometry_primitive(i);
          const double cells_at_node =
            primitive == GeometryPrimitive::vertex          ? (1U << dim) :
            primitive == GeometryPrimitive::line && dim > 1 ? 2. :
                                                              1.;
          double stiffness = 0;
          for (unsigned int q = 0; q < gap.size(); ++q)
            stiffness += values.shape_grad(i, q).norm_square() * values.JxW(q);
          choice.joined += m * gap_i * gap_i * stiffness * cells_at_node;
        }
      return choice;
    }
  } // namespace


  template <int dim>
  void
  TransmittedLoad<dim>::split(const double               mu1,
                              const double               mu2,
                              const std::vector<double> &f1,
                              const std::vector<double> &f2,
                              const Vector              &contact,
                              const Vector              &s1,
                              const Vector              &s2,
                              Split                     &split) const
  {
    const MPI_Comm  comm  = dof_handler->get_communicator();
    const IndexSet &owned = dof_handler->locally_owned_dofs();
    const auto     &tria  = dof_handler->get_triangulation();
    split.joined_cells.assign(tria.n_active_cells(), 0);
    split.node_moments.reinit(owned, comm);
    split.load_nodes.reinit(owned, comm);
    split.joined_nodes.reinit(owned, comm);

    const unsigned int                   n_q = quadrature.size();
    FEValues<dim>                        values(*mapping,
                         dof_handler->get_fe(),
                         quadrature,
                         update_values | update_gradients | update_JxW_values);
    std::vector<double>                  g(n_q), gap(n_q), s2_values(n_q);
    const double                         m = mu1 * mu2 / (mu1 + mu2);
    std::vector<types::global_dof_index> dofs(
      dof_handler->get_fe().n_dofs_per_cell());
    std::vector<types::global_dof_index> load_nodes, joined_nodes;
    dealii::Vector<double>               cell_moments(dofs.size());

    for (const auto &cell : dof_handler->active_cell_iterators())
      {
        if (!cell->is_locally_owned())
          continue;
        cell->get_dof_indices(dofs);
        unsigned int n_nodes = 0, n_in_contact = 0;
        for (const types::global_dof_index i : dofs)
          if (!no_moment->is_constrained(i))
            {
              ++n_nodes;
              n_in_contact += contact(i) > 0;
            }
        if (n_in_contact == 0)
          continue;

        // J: the contact cells, and the cells at the contact set where g
        // varies too much to be left out (across the free boundary, where
        // the data jump), joined where the contact term would cost more.
        const auto index = cell->active_cell_index();
        cell_values(mu1, mu2, f1, f2, index, g);
        values.reinit(cell);
        if (n_in_contact < n_nodes)
          {
            const CellChoice choice = cell_choice(values,
                                                  dofs,
                                                  *no_moment,
                                                  g,
                                                  m,
                                                  cell->diameter(),
                                                  s1,
                                                  s2,
                                                  gap,
                                                  s2_values);
            if (choice.left_out <= std::min(choice.in_j, choice.joined))
              continue;
            if (choice.joined < choice.in_j)
              add_free_nodes(*no_moment, dofs, joined_nodes);
          }
        split.joined_cells[index] = 1;
        add_free_nodes(*no_moment, dofs, load_nodes);
        // (g 1_J, phi_i) for the conforming basis functions: a hanging
        // node's part goes to its parents, a Dirichlet node's is dropped
        for (unsigned int i = 0; i < dofs.size(); ++i)
          {
            cell_moments[i] = 0;
            for (unsigned int q = 0; q < n_q; ++q)
              cell_moments[i] +=
                g[q] * values.shape_value(i, q) * values.JxW(q);
          }
        no_moment->distribute_local_to_global(cell_moments,
                                              dofs,
                                              split.node_moments);
      }

    split.node_moments.compress(VectorOperation::add);
    split.load_nodes.add(load_nodes,
                         std::vector<double>(load_nodes.size(), 1.));
    split.load_nodes.compress(VectorOperation::add);
    split.joined_nodes.add(joined_nodes,
                           std::vector<double>(joined_nodes.size(), 1.));
    split.joined_nodes.compress(VectorOperation::add);
  }


  void
  join_at_nodes(const double                         mu1,
                const double                         mu2,
                const TrilinosWrappers::MPI::Vector &joined,
                TrilinosWrappers::MPI::Vector       &s1,
                TrilinosWrappers::MPI::Vector       &s2)
  {
    for (const types::global_dof_index i : s1.locally_owned_elements())
      if (joined(i) > 0)
        {
          const double mean = (mu1 * s1(i) + mu2 * s2(i)) / (mu1 + mu2);
          s1(i)             = mean;
          s2(i)             = mean;
        }
    s1.compress(VectorOperation::insert);
    s2.compress(VectorOperation::insert);
  }


  template class TransmittedLoad<2>;
} // namespace VI
