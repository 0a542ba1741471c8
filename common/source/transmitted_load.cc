#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/vector.h>

#include <vi/reduced_tension.h>
#include <vi/transmitted_load.h>

#include <algorithm>
#include <cmath>

namespace VI
{
  using namespace dealii;

  template <int dim>
  void
  TransmittedLoad<dim>::reinit(const Mapping<dim>              &mapping,
                               const DoFHandler<dim>           &dof_handler,
                               const AffineConstraints<double> &no_moment,
                               const Quadrature<dim>           &quadrature,
                               const double        friedrichs_constant,
                               const BoundaryCells boundary_cells)
  {
    this->mapping             = &mapping;
    this->dof_handler         = &dof_handler;
    this->no_moment           = &no_moment;
    this->quadrature          = quadrature;
    this->friedrichs_constant = friedrichs_constant;
    this->boundary_cells      = boundary_cells;
  }


  namespace
  {
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


    // Whether a cell at the contact set (not a contact cell) goes into J,
    // comparing what it costs the estimate in squared energy:
    // - left out: lambda~ carries a cell mean of g at best, and the
    //   residuals of the membranes the rest, (h_K / pi)^2 / m |g - mean_K
    //   g|_K^2 (m = mu1 mu2 / (mu1 + mu2));
    // - in J: the contact term of the cone reconstruction,
    //   2 (g^+, (s1 - s2)^+)_K, and the undershoot g^- as the estimate
    //   weighs it, (|(g^- - mean_K g^-)|_K^2 (h_K / pi)^2 + C_F^2 |K|
    //   (mean_K g^-)^2) / m.
    // `values` is reinitialised on the cell, `g` holds g at its points.
    template <int dim>
    bool
    takes_load(const FEValues<dim>                 &values,
               const std::vector<double>           &g,
               const double                         m,
               const double                         h,
               const double                         friedrichs_constant,
               const TrilinosWrappers::MPI::Vector &s1,
               const TrilinosWrappers::MPI::Vector &s2,
               std::vector<double>                 &s1_values,
               std::vector<double>                 &s2_values)
    {
      values.get_function_values(s1, s1_values);
      values.get_function_values(s2, s2_values);
      double measure = 0, mean = 0, mean_negative = 0, in_j = 0;
      for (unsigned int q = 0; q < g.size(); ++q)
        {
          measure += values.JxW(q);
          mean += g[q] * values.JxW(q);
          mean_negative += std::min(g[q], 0.) * values.JxW(q);
          in_j += 2. * std::max(g[q], 0.) *
                  std::max(s1_values[q] - s2_values[q], 0.) * values.JxW(q);
        }
      mean /= measure;
      mean_negative /= measure;
      const double local    = std::pow(h / numbers::PI, 2) / m;
      double       left_out = 0, undershoot = 0;
      for (unsigned int q = 0; q < g.size(); ++q)
        {
          left_out += std::pow(g[q] - mean, 2) * values.JxW(q);
          undershoot +=
            std::pow(std::min(g[q], 0.) - mean_negative, 2) * values.JxW(q);
        }
      in_j += local * undershoot + std::pow(friedrichs_constant, 2) / m *
                                     measure * mean_negative * mean_negative;
      return local * left_out > in_j;
    }
  } // namespace


  template <int dim>
  void
  TransmittedLoad<dim>::split(const double               mu1,
                              const double               mu2,
                              const std::vector<double> &l1,
                              const std::vector<double> &l2,
                              const Vector              &contact,
                              const Vector              &s1,
                              const Vector              &s2,
                              Split                     &split) const
  {
    const MPI_Comm     comm  = dof_handler->get_communicator();
    const IndexSet    &owned = dof_handler->locally_owned_dofs();
    const unsigned int n_q   = quadrature.size();
    split.values.assign(dof_handler->get_triangulation().n_active_cells() * n_q,
                        0.);
    split.node_moments.reinit(owned, comm);
    split.load_nodes.reinit(owned, comm);

    FEValues<dim>                        values(*mapping,
                         dof_handler->get_fe(),
                         quadrature,
                         update_values | update_JxW_values);
    std::vector<double>                  g(n_q), s1_values(n_q), s2_values(n_q);
    const double                         m = reduced_tension(mu1, mu2);
    std::vector<types::global_dof_index> dofs(
      dof_handler->get_fe().n_dofs_per_cell());
    std::vector<types::global_dof_index> load_nodes;
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
        // the data jump).
        const auto index = cell->active_cell_index();
        for (unsigned int q = 0; q < n_q; ++q)
          g[q] = value(mu1, mu2, l1[index * n_q + q], l2[index * n_q + q]);
        values.reinit(cell);
        if (n_in_contact < n_nodes &&
            boundary_cells == BoundaryCells::by_cost &&
            !takes_load(values,
                        g,
                        m,
                        cell->diameter(),
                        friedrichs_constant,
                        s1,
                        s2,
                        s1_values,
                        s2_values))
          continue;
        std::copy(g.begin(), g.end(), split.values.begin() + index * n_q);
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
  }


  template class TransmittedLoad<2>;
} // namespace VI
