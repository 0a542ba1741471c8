#include <deal.II/dofs/dof_accessor.h>
#include <deal.II/dofs/dof_handler.h>

#include <vi/nodal_fields.h>

#include <algorithm>
#include <iterator>
#include <vector>

namespace VI
{
  namespace NodalFields
  {
    using namespace dealii;

    IndexSet
    system_index_set(const IndexSet &nodes)
    {
      IndexSet system(n_fields * nodes.size());
      for (auto interval = nodes.begin_intervals();
           interval != nodes.end_intervals();
           ++interval)
        system.add_range(index(*interval->begin(), 0),
                         index(interval->last(), n_fields - 1) + 1);
      system.compress();
      return system;
    }


    void
    make_system_constraints(const AffineConstraints<double> &u1_constraints,
                            const AffineConstraints<double> &u2_constraints,
                            const IndexSet            &relevant_system_indices,
                            AffineConstraints<double> &system_constraints)
    {
      system_constraints.clear();
      system_constraints.reinit(relevant_system_indices);

      const auto copy_lines = [&](const AffineConstraints<double> &scalar,
                                  const unsigned int               field) {
        for (const auto &line : scalar.get_lines())
          {
            const global_dof_index row = index(line.index, field);
            if (!relevant_system_indices.is_element(row))
              continue;
            system_constraints.add_line(row);
            for (const auto &entry : line.entries)
              system_constraints.add_entry(row,
                                           index(entry.first, field),
                                           entry.second);
            system_constraints.set_inhomogeneity(row, line.inhomogeneity);
          }
      };
      copy_lines(u1_constraints, u1);
      copy_lines(u2_constraints, u2);

      for (const auto &line : u1_constraints.get_lines())
        if (relevant_system_indices.is_element(index(line.index, multiplier)))
          system_constraints.add_line(index(line.index, multiplier));

      system_constraints.close();
    }


    void
    make_system_sparsity(const DynamicSparsityPattern &scalar_pattern,
                         const IndexSet               &owned_nodes,
                         DynamicSparsityPattern       &system_pattern)
    {
      // Every row of the scalar pattern, including the rows of ghost nodes
      // that assembly on this process writes into: Trilinos needs them to
      // set up the communication of those entries to their owners. The
      // node-local blocks (coupling and contact rows) are only written by
      // the owner. Each row goes in whole, its columns sorted (entry by
      // entry, the pattern would search and grow its rows millions of
      // times on a large mesh).
      const IndexSet               &rows = scalar_pattern.row_index_set();
      std::vector<global_dof_index> columns;
      for (const global_dof_index i : rows)
        {
          const bool             owned = owned_nodes.is_element(i);
          const global_dof_index x3    = index(i, multiplier);
          for (const unsigned int field : {u1, u2})
            {
              columns.clear();
              for (auto entry = scalar_pattern.begin(i);
                   entry != scalar_pattern.end(i);
                   ++entry)
                columns.push_back(index(entry->column(), field));
              if (owned)
                columns.insert(
                  std::upper_bound(columns.begin(), columns.end(), x3), x3);
              system_pattern.add_entries(index(i, field),
                                         columns.begin(),
                                         columns.end(),
                                         /*indices_are_unique_and_sorted=*/
                                         true);
            }
        }
      for (const global_dof_index i : owned_nodes)
        {
          const global_dof_index x3           = index(i, multiplier);
          const global_dof_index node_block[] = {index(i, u1),
                                                 index(i, u2),
                                                 x3};
          system_pattern.add_entries(x3,
                                     std::begin(node_block),
                                     std::end(node_block),
                                     /*indices_are_unique_and_sorted=*/true);
        }
    }


    namespace
    {
      // Both vectors store their locally owned entries in increasing index
      // order, and system_index_set() keeps the node order: the k-th owned
      // node's values are the owned entries 3 k, 3 k + 1, 3 k + 2 of X.
      // Calls visit(k, 3 k) for every owned node.
      template <typename Visit>
      void
      for_each_owned_node(
        [[maybe_unused]] const TrilinosWrappers::MPI::Vector &X,
        const TrilinosWrappers::MPI::Vector                  &field_values,
        const Visit                                          &visit)
      {
        Assert(!X.has_ghost_elements() && !field_values.has_ghost_elements(),
               ExcMessage("extract() and insert() work on vectors without "
                          "ghost entries."));
        const auto n = field_values.locally_owned_size();
        AssertDimension(X.locally_owned_size(), n_fields * n);
        for (std::size_t k = 0; k < n; ++k)
          visit(k, n_fields * k);
      }
    } // namespace


    void
    extract(const TrilinosWrappers::MPI::Vector &X,
            const unsigned int                   field,
            TrilinosWrappers::MPI::Vector       &field_values)
    {
      const double *x     = X.begin();
      double       *value = field_values.begin();
      for_each_owned_node(X,
                          field_values,
                          [&](const std::size_t k, const std::size_t first) {
                            value[k] = x[first + field];
                          });
    }


    void
    insert(const TrilinosWrappers::MPI::Vector &field_values,
           const unsigned int                   field,
           TrilinosWrappers::MPI::Vector       &X)
    {
      double       *x     = X.begin();
      const double *value = field_values.begin();
      for_each_owned_node(X,
                          field_values,
                          [&](const std::size_t k, const std::size_t first) {
                            x[first + field] = value[k];
                          });
    }


    void
    insert_displacements(const TrilinosWrappers::MPI::Vector &u1,
                         const TrilinosWrappers::MPI::Vector &u2,
                         TrilinosWrappers::MPI::Vector       &X)
    {
      insert(u1, NodalFields::u1, X);
      insert(u2, NodalFields::u2, X);
    }


    template <int dim>
    std::vector<dealii::types::global_dof_index>
    vertex_nodes(const dealii::DoFHandler<dim, dim> &dof_handler)
    {
      std::vector<dealii::types::global_dof_index> nodes(
        dof_handler.get_triangulation().n_vertices(),
        dealii::numbers::invalid_dof_index);
      for (const auto &cell : dof_handler.active_cell_iterators())
        if (!cell->is_artificial())
          for (const unsigned int v : cell->vertex_indices())
            nodes[cell->vertex_index(v)] = cell->vertex_dof_index(v, 0);
      return nodes;
    }


    template std::vector<dealii::types::global_dof_index>
    vertex_nodes(const dealii::DoFHandler<2, 2> &);
  } // namespace NodalFields
} // namespace VI
