#include <deal.II/base/exceptions.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/cell_multiplier.h>

#include <algorithm>
#include <cmath>

namespace VI
{
  using namespace dealii;

  namespace
  {
    // A copy of a vector of locally owned values with the ghost entries of
    // `relevant` (after its compress()).
    TrilinosWrappers::MPI::Vector
    with_ghosts(const TrilinosWrappers::MPI::Vector &values,
                const IndexSet                      &relevant)
    {
      TrilinosWrappers::MPI::Vector ghosted(values.locally_owned_elements(),
                                            relevant,
                                            values.get_mpi_communicator());
      ghosted = values;
      return ghosted;
    }


    // The moments of the hanging nodes back from their parents (see the
    // class documentation): the densities m_i / (phi_i + sum_j c_ji phi_j,
    // 1) at the nodes that carry a moment, then at each locally owned
    // hanging node x_j its moment M_j, which its parents give up; not
    // where a parent has a contact cell and x_j none (at the free
    // boundary), since a moment on x_j would leave the contact cells and
    // add a contact term.
    TrilinosWrappers::MPI::Vector
    hanging_node_moments(
      const TrilinosWrappers::MPI::Vector &moments,
      const AffineConstraints<double>     &no_moment,
      const TrilinosWrappers::MPI::Vector &node_integral,
      const TrilinosWrappers::MPI::Vector &conforming_integral,
      const TrilinosWrappers::MPI::Vector &contact_cells_at,
      const IndexSet                      &owned,
      const IndexSet                      &relevant)
    {
      const MPI_Comm                comm = moments.get_mpi_communicator();
      TrilinosWrappers::MPI::Vector density(owned, comm), nodal(owned, comm);
      for (const types::global_dof_index i : owned)
        if (!no_moment.is_constrained(i) && conforming_integral(i) > 0)
          density(i) = moments(i) / conforming_integral(i);
      density.compress(VectorOperation::insert);
      const TrilinosWrappers::MPI::Vector parents_density =
        with_ghosts(density, relevant);
      // First the interpolated moments M_j and what each parent would give
      // up, G_i = sum_j c_ji M_j.
      struct Interpolated
      {
        types::global_dof_index                                        j;
        const std::vector<std::pair<types::global_dof_index, double>> *entries;
        double                                                         moment;
      };
      std::vector<Interpolated>            interpolated;
      std::vector<types::global_dof_index> parents;
      std::vector<double>                  given_up;
      for (const types::global_dof_index j : owned)
        if (const auto *entries = no_moment.get_constraint_entries(j))
          {
            // Only where every parent carries a moment: the constraints of
            // the Dirichlet nodes have no entries, and a hanging node next to
            // them has lost those parents (its weights no longer sum to 1),
            // whose hats, also conforming, would not see its moment.
            double density_j = 0, weights = 0;
            for (const auto &[i, c] : *entries)
              {
                density_j += c * parents_density(i);
                weights += c;
              }
            if (std::abs(weights - 1.) > 1e-12)
              continue;
            if (!(contact_cells_at(j) > 0) &&
                std::any_of(entries->begin(),
                            entries->end(),
                            [&](const auto &e) {
                              return contact_cells_at(e.first) > 0;
                            }))
              continue;
            interpolated.push_back({j, entries, node_integral(j) * density_j});
            for (const auto &[i, c] : *entries)
              {
                parents.push_back(i);
                given_up.push_back(c * interpolated.back().moment);
              }
          }
      TrilinosWrappers::MPI::Vector give(owned, comm);
      give.add(parents, given_up);
      give.compress(VectorOperation::add);
      // A parent gives up at most its own moment: alpha_i G_i with alpha_i =
      // m_i / G_i clamped to [0, 1] (below 1 where the parents' densities
      // differ much, at the free boundary; 0 where m_i has the other sign,
      // among them the moments that are zero up to round-off, so that
      // lambda~ is continuous in them); a hanging node takes the least alpha
      // of its parents. (alpha = 1 wherever the density varies little, and
      // for a constant.)
      TrilinosWrappers::MPI::Vector limit(owned, comm);
      for (const types::global_dof_index i : owned)
        {
          const double m = no_moment.is_constrained(i) ? 0. : moments(i),
                       g = give(i);
          limit(i)       = (g == 0) ? 1. : std::clamp(m / g, 0., 1.);
        }
      limit.compress(VectorOperation::insert);
      const TrilinosWrappers::MPI::Vector parents_limit =
        with_ghosts(limit, relevant);

      given_up.clear();
      parents.clear();
      for (const types::global_dof_index i : owned)
        if (!no_moment.is_constrained(i))
          nodal(i) = moments(i);
      for (const auto &[j, entries, moment] : interpolated)
        {
          double alpha = 1;
          for (const auto &[i, c] : *entries)
            alpha = std::min(alpha, static_cast<double>(parents_limit(i)));
          nodal(j) = alpha * moment;
          for (const auto &[i, c] : *entries)
            {
              parents.push_back(i);
              given_up.push_back(-c * nodal(j));
            }
        }
      nodal.compress(VectorOperation::insert);
      nodal.add(parents, given_up);
      nodal.compress(VectorOperation::add);
      return with_ghosts(nodal, relevant);
    }
  } // namespace

  template <int dim>
  void
  CellMultiplier<dim>::reinit(const Mapping<dim>              &mapping,
                              const DoFHandler<dim>           &dofs,
                              const AffineConstraints<double> &constraints,
                              const Quadrature<dim>           &quadrature)
  {
    dof_handler = &dofs;
    no_moment   = &constraints;
    relevant    = DoFTools::extract_locally_relevant_dofs(dofs);

    const FiniteElement<dim> &fe = dofs.get_fe();
    AssertThrow(fe.has_support_points(),
                ExcMessage("The cellwise multiplier needs a Lagrange "
                           "element."));
    const FE_Q<dim>    q1(1);
    const unsigned int n_nodes = fe.n_dofs_per_cell(), n_q = quadrature.size();

    // Reference integrals of the local shape functions (positive for the
    // Gauss-Lobatto-based FE_Q; they define the shares of the moments).
    const QGauss<dim> exact(fe.degree + 1);
    reference_weights.assign(n_nodes, 0.);
    for (unsigned int i = 0; i < n_nodes; ++i)
      {
        for (unsigned int q = 0; q < exact.size(); ++q)
          reference_weights[i] +=
            fe.shape_value(i, exact.point(q)) * exact.weight(q);
        AssertThrow(reference_weights[i] > 0,
                    ExcMessage("The cellwise multiplier needs shape functions "
                               "with positive integrals."));
      }
    vertex_function_at_node.reinit(n_nodes, n_vertices);
    for (unsigned int i = 0; i < n_nodes; ++i)
      for (unsigned int v = 0; v < n_vertices; ++v)
        vertex_function_at_node(i, v) =
          q1.shape_value(v, fe.get_unit_support_points()[i]);
    vertex_function_at_point.reinit(n_q, n_vertices);
    for (unsigned int q = 0; q < n_q; ++q)
      for (unsigned int v = 0; v < n_vertices; ++v)
        vertex_function_at_point(q, v) = q1.shape_value(v, quadrature.point(q));

    const auto &tria = dofs.get_triangulation();
    measure.assign(tria.n_active_cells(), 0.);
    inverse_mass.assign(tria.n_active_cells() * n_vertices * n_vertices, 0.);
    FEValues<dim>      values(mapping, fe, quadrature, update_JxW_values);
    FullMatrix<double> mass(n_vertices, n_vertices);
    for (const auto &cell : dofs.active_cell_iterators())
      {
        if (cell->is_artificial())
          continue;
        values.reinit(cell);
        const auto index = cell->active_cell_index();
        mass             = 0;
        for (unsigned int q = 0; q < n_q; ++q)
          {
            measure[index] += values.JxW(q);
            for (unsigned int v = 0; v < n_vertices; ++v)
              for (unsigned int w = 0; w < n_vertices; ++w)
                mass(v, w) += vertex_function_at_point(q, v) *
                              vertex_function_at_point(q, w) * values.JxW(q);
          }
        if (!cell->is_locally_owned())
          continue;
        mass.gauss_jordan();
        std::copy(mass.begin(),
                  mass.end(),
                  inverse_mass.begin() + index * n_vertices * n_vertices);
      }

    // The integrals of the nodal basis functions, plain and conforming
    // (summed over the processes).
    const MPI_Comm                comm  = dofs.get_communicator();
    const IndexSet               &owned = dofs.locally_owned_dofs();
    TrilinosWrappers::MPI::Vector plain(owned, comm), conforming(owned, comm);
    std::vector<types::global_dof_index> cell_dofs(n_nodes);
    dealii::Vector<double>               local(n_nodes);
    for (const auto &cell : dofs.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(cell_dofs);
          for (unsigned int i = 0; i < n_nodes; ++i)
            local(i) =
              measure[cell->active_cell_index()] * reference_weights[i];
          plain.add(cell_dofs, local);
          constraints.distribute_local_to_global(local, cell_dofs, conforming);
        }
    plain.compress(VectorOperation::add);
    conforming.compress(VectorOperation::add);
    node_integral       = with_ghosts(plain, relevant);
    conforming_integral = with_ghosts(conforming, relevant);
  }


  template <int dim>
  void
  CellMultiplier<dim>::distribute(const TrilinosWrappers::MPI::Vector &moments,
                                  const TrilinosWrappers::MPI::Vector &contact,
                                  std::vector<double> &coefficients) const
  {
    Assert(dof_handler, ExcMessage("Call reinit() first."));
    const unsigned int n_nodes = dof_handler->get_fe().n_dofs_per_cell();
    std::vector<types::global_dof_index> dofs(n_nodes);
    std::vector<double>                  m(n_nodes);

    // The denominators of the shares: sums of |K| (phi^_i, 1) over the
    // contact cells and over all cells at node i. All cells at a node of an
    // owned cell are owned or ghost cells. A cell is a contact cell when
    // all its nodes that carry a moment are in contact.
    std::vector<double> on_contact(relevant.n_elements(), 0.),
      on_all(relevant.n_elements(), 0.);
    std::vector<bool> is_contact(measure.size(), false);
    for (const auto &cell : dof_handler->active_cell_iterators())
      if (cell->is_locally_owned() || cell->is_ghost())
        {
          cell->get_dof_indices(dofs);
          const auto index           = cell->active_cell_index();
          bool       is_contact_cell = true;
          for (unsigned int i = 0; i < n_nodes; ++i)
            if (!no_moment->is_constrained(dofs[i]) && !(contact(dofs[i]) > 0))
              is_contact_cell = false;
          is_contact[index] = is_contact_cell;
          const double size = measure[index];
          for (unsigned int i = 0; i < n_nodes; ++i)
            {
              const auto k = relevant.index_within_set(dofs[i]);
              on_all[k] += size * reference_weights[i];
              if (is_contact_cell)
                on_contact[k] += size * reference_weights[i];
            }
        }

    // Which nodes have a contact cell (counted over the processes: the
    // parents of a hanging node need not be nodes of an owned cell).
    const MPI_Comm                comm  = moments.get_mpi_communicator();
    const IndexSet               &owned = dof_handler->locally_owned_dofs();
    TrilinosWrappers::MPI::Vector contact_cells(owned, comm);
    std::vector<types::global_dof_index> at_contact_cells;
    for (const auto &cell : dof_handler->active_cell_iterators())
      if (cell->is_locally_owned() && is_contact[cell->active_cell_index()])
        {
          cell->get_dof_indices(dofs);
          at_contact_cells.insert(at_contact_cells.end(),
                                  dofs.begin(),
                                  dofs.end());
        }
    contact_cells.add(at_contact_cells,
                      std::vector<double>(at_contact_cells.size(), 1.));
    contact_cells.compress(VectorOperation::add);
    const TrilinosWrappers::MPI::Vector contact_cells_at =
      with_ghosts(contact_cells, relevant);

    // The moments of the nodes, those of the hanging nodes back from
    // their parents.
    const TrilinosWrappers::MPI::Vector node_moments =
      hanging_node_moments(moments,
                           *no_moment,
                           node_integral,
                           conforming_integral,
                           contact_cells_at,
                           owned,
                           relevant);

    // The dofs and moments of a cell (zero on the nodes that carry none).
    const auto read_cell = [&](const auto &cell) {
      cell->get_dof_indices(dofs);
      for (unsigned int i = 0; i < n_nodes; ++i)
        m[i] = node_moments(dofs[i]);
    };

    coefficients.assign(measure.size() * n_vertices, 0.);
    double cell_moments[n_vertices];
    for (const auto &cell : dof_handler->active_cell_iterators())
      if (cell->is_locally_owned())
        {
          read_cell(cell);
          const auto   index           = cell->active_cell_index();
          const bool   is_contact_cell = is_contact[index];
          const double size            = measure[index];
          std::fill_n(cell_moments, n_vertices, 0.);
          for (unsigned int i = 0; i < n_nodes; ++i)
            {
              if (m[i] == 0)
                continue;
              const auto   k = relevant.index_within_set(dofs[i]);
              const double share =
                on_contact[k] > 0 ?
                  (is_contact_cell ?
                     size * reference_weights[i] / on_contact[k] :
                     0.) :
                  size * reference_weights[i] / on_all[k];
              for (unsigned int v = 0; v < n_vertices; ++v)
                cell_moments[v] += share * m[i] * vertex_function_at_node(i, v);
            }
          const double *inverse =
            inverse_mass.data() + index * n_vertices * n_vertices;
          for (unsigned int v = 0; v < n_vertices; ++v)
            for (unsigned int w = 0; w < n_vertices; ++w)
              coefficients[index * n_vertices + v] +=
                inverse[v * n_vertices + w] * cell_moments[w];
        }
  }


  template <int dim>
  void
  CellMultiplier<dim>::values(const std::vector<double> &coefficients,
                              const unsigned int         index,
                              std::vector<double>       &values) const
  {
    AssertDimension(values.size(), vertex_function_at_point.size(0));
    const double *c = coefficients.data() + index * n_vertices;
    for (unsigned int q = 0; q < values.size(); ++q)
      {
        double value = 0;
        for (unsigned int v = 0; v < n_vertices; ++v)
          value += c[v] * vertex_function_at_point(q, v);
        values[q] = value;
      }
  }


  template class CellMultiplier<2>;
} // namespace VI
