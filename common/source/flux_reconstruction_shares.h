// What the owner of a cell sends the ranks that solve the patches of the
// cell's vertices (flux_reconstruction_setup.cc): the cell's data and the
// shares of the hat functions on it.
#pragma once

#include <deal.II/base/array_view.h>
#include <deal.II/base/geometry_info.h>
#include <deal.II/base/types.h>
#include <deal.II/lac/affine_constraints.h>

#include <vi/flux_reconstruction.h>

#include <boost/serialization/utility.hpp>
#include <boost/serialization/vector.hpp>
#include <cstdint>
#include <utility>
#include <vector>

namespace VI
{
  using namespace dealii;

  // What a patch needs to know of its cells, computed by their owner: per
  // cell its center (which orders the cells of a patch), the Piola signs of
  // its Raviart-Thomas dofs, its metric J^T J / det J, the integrals
  // (phi_v, q_k)_K of the Q1 shape functions phi_v against Q_p, and how its
  // dofs expand across hanging faces (the constraint's entries, or the dof
  // itself). The rank that solves a patch needs nothing else of a cell, so
  // it need not see it. Flat arrays, cell after cell: a few large
  // allocations that go back to the system as a whole once the patches are
  // laid out, where a handful of small vectors per cell (a few hundred
  // bytes) would stay behind in the heap as fragments.
  template <int dim>
  struct FluxReconstruction<dim>::CellTable
  {
    static constexpr unsigned int n_v = GeometryInfo<dim>::vertices_per_cell;

    unsigned int             n_tau = 0, n_q = 0;
    std::vector<double>      centers;       ///< [c dim + d]
    std::vector<std::int8_t> signs;         ///< [c n_tau + k]
    std::vector<double>      metrics;       ///< [c n_metric + m]
    std::vector<double>      vertex_masses; ///< [(c n_v + v) n_q + k]
    /// dof k of cell c expands into expansion[expansion_start[c n_tau + k]
    /// ... expansion_start[c n_tau + k + 1] - 1]
    std::vector<unsigned int>                               expansion_start;
    std::vector<std::pair<types::global_dof_index, double>> expansion;

    /// Room for n_cells cells, without their expansions (added cell by cell
    /// with add_expansion()).
    void
    reinit(const unsigned int n_tau,
           const unsigned int n_q,
           const std::size_t  n_cells)
    {
      this->n_tau = n_tau;
      this->n_q   = n_q;
      centers.assign(n_cells * dim, 0.);
      signs.assign(n_cells * n_tau, 0);
      metrics.assign(n_cells * n_metric, 0.);
      vertex_masses.assign(n_cells * n_v * n_q, 0.);
      expansion_start.assign(1, 0);
      expansion.clear();
    }

    std::size_t
    size() const
    {
      return metrics.size() / n_metric;
    }

    /// The expansion of dof k of cell c.
    ArrayView<const std::pair<types::global_dof_index, double>>
    expansion_of(const std::size_t c, const unsigned int k) const
    {
      const unsigned int *start = &expansion_start[c * n_tau + k];
      return {expansion.data() + start[0], start[1] - start[0]};
    }

    /// Dof k of the next cell without expansion: the entries of its
    /// constraint, or the dof itself with weight 1.
    void
    add_expansion(const types::global_dof_index    dof,
                  const AffineConstraints<double> &constraints)
    {
      if (constraints.is_constrained(dof))
        for (const auto &entry : *constraints.get_constraint_entries(dof))
          expansion.push_back(entry);
      else
        expansion.emplace_back(dof, 1.);
      expansion_start.push_back(expansion.size());
    }

    /// Cell c of `other`, added at the end.
    void
    append(const CellTable &other, const std::size_t c)
    {
      if (size() == 0)
        reinit(other.n_tau, other.n_q, 0);
      const auto add = [c](auto &to, const auto &from, const std::size_t n) {
        to.insert(to.end(), from.begin() + c * n, from.begin() + (c + 1) * n);
      };
      add(centers, other.centers, dim);
      add(signs, other.signs, n_tau);
      add(metrics, other.metrics, n_metric);
      add(vertex_masses, other.vertex_masses, n_v * n_q);
      for (unsigned int k = 0; k < n_tau; ++k)
        {
          const auto entries = other.expansion_of(c, k);
          expansion.insert(expansion.end(), entries.begin(), entries.end());
          expansion_start.push_back(expansion.size());
        }
    }

    template <class Archive>
    void
    serialize(Archive &ar, const unsigned int)
    {
      ar &n_tau &n_q &centers &signs &metrics &vertex_masses &expansion_start
        &expansion;
    }
  };


  // (patch, cell) pairs: share i says that psi_a of the patch numbered by
  // the degree of freedom patch[i] does not vanish on cells[cell[i]], with
  // the values hat[i n_v ... (i + 1) n_v - 1] at its vertices. What one
  // rank sends another.
  template <int dim>
  struct FluxReconstruction<dim>::Shares
  {
    static constexpr unsigned int n_v = GeometryInfo<dim>::vertices_per_cell;

    CellTable                            cells;
    std::vector<types::global_dof_index> patch;
    std::vector<unsigned int>            cell;
    std::vector<double>                  hat;

    void
    add(const types::global_dof_index j,
        const unsigned int            c,
        const double                 *values)
    {
      patch.push_back(j);
      cell.push_back(c);
      hat.insert(hat.end(), values, values + n_v);
    }

    template <class Archive>
    void
    serialize(Archive &ar, const unsigned int)
    {
      ar &cells &patch &cell &hat;
    }
  };
} // namespace VI
