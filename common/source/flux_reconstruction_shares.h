// What the owner of a cell sends the ranks that solve the patches of the
// cell's vertices (flux_reconstruction_setup.cc): the cell's data and the
// shares of the hat functions on it.
#pragma once

#include <deal.II/base/geometry_info.h>
#include <deal.II/base/types.h>

#include <vi/flux_reconstruction.h>

#include <boost/serialization/utility.hpp>
#include <boost/serialization/vector.hpp>
#include <cstdint>
#include <utility>
#include <vector>

namespace VI
{
  using namespace dealii;

  // What a patch needs to know of one of its cells, computed by the cell's
  // owner: its center (which orders the cells of a patch), how its
  // Raviart-Thomas dofs expand across hanging faces (the constraint's
  // entries, or the dof itself), the Piola signs of those dofs, its metric
  // J^T J / det J and the integrals (phi_v, q_k)_K of the Q1 shape functions
  // phi_v against Q_p. The rank that solves a patch needs nothing else of a
  // cell, so it need not see it.
  template <int dim>
  struct FluxReconstruction<dim>::CellData
  {
    double                    center[dim] = {};
    std::vector<unsigned int> expansion_start; ///< per local dof, and the end
    std::vector<std::pair<types::global_dof_index, double>> expansion;
    std::vector<std::int8_t>                                signs;
    std::vector<double>                                     metric;
    std::vector<double> vertex_mass; ///< [v n_q + k]
    CellIterator        cell;        ///< on the owner only

    template <class Archive>
    void
    serialize(Archive &ar, const unsigned int)
    {
      ar &center &expansion_start &expansion &signs &metric &vertex_mass;
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

    std::vector<CellData>                cells;
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
