// The multiplier of the estimate on the contact cells (VI::CellMultiplier):
// it keeps the moments of the discrete multiplier against the vertex hats
// (the compatibility of the patch problems), lives on the contact cells
// where it can, and reproduces a constant multiplier.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/cell_multiplier.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace
{
  using namespace dealii;
  using TrilinosVector = TrilinosWrappers::MPI::Vector;

  // A Q_p space on a mesh with hanging nodes, the multiplier of the
  // estimate on it, and the quadrature it is evaluated with.
  struct Setting
  {
    explicit Setting(const unsigned int degree, const bool hanging)
        : fe(degree)
        , dofs(tria)
        , quadrature(degree + 2)
    {
      GridGenerator::hyper_cube(tria);
      tria.refine_global(2);
      if (hanging)
        {
          tria.begin_active()->set_refine_flag();
          tria.execute_coarsening_and_refinement();
        }
      dofs.distribute_dofs(fe);
      DoFTools::make_hanging_node_constraints(dofs, no_moment);
      VectorTools::interpolate_boundary_values(dofs,
                                               0,
                                               Functions::ZeroFunction<2>(),
                                               no_moment);
      no_moment.close();
      multiplier.reinit(mapping, dofs, no_moment, quadrature);
    }

    TrilinosVector
    vector() const
    {
      return TrilinosVector(complete_index_set(dofs.n_dofs()), MPI_COMM_WORLD);
    }

    // lambda~ at the quadrature points of every cell.
    std::vector<std::vector<double>>
    cell_values(const std::vector<double> &coefficients) const
    {
      std::vector<std::vector<double>> values;
      for (const auto &cell : dofs.active_cell_iterators())
        {
          values.emplace_back(quadrature.size());
          multiplier.values(coefficients,
                            cell->active_cell_index(),
                            values.back());
        }
      return values;
    }

    Triangulation<2>          tria;
    FE_Q<2>                   fe;
    DoFHandler<2>             dofs;
    QGauss<2>                 quadrature;
    MappingQ<2>               mapping{1};
    AffineConstraints<double> no_moment;
    VI::CellMultiplier<2>     multiplier;
  };
} // namespace


// For every conforming vertex hat psi_b (the Q1 basis functions with their
// hanging node constraints), (lambda~, psi_b) = sum_i m_i psi_b(x_i) over
// the nodes that carry a moment, for moments of both signs and an
// arbitrary contact set.
TEST(CellMultiplier, KeepsTheMomentsAgainstTheVertexHats)
{
  for (const unsigned int degree : {2u, 3u})
    {
      Setting        s(degree, true);
      TrilinosVector moments = s.vector(), contact = s.vector();
      for (types::global_dof_index i = 0; i < s.dofs.n_dofs(); ++i)
        if (!s.no_moment.is_constrained(i))
          {
            moments(i) = std::sin(1.7 * i + 0.3);
            contact(i) = (i % 3 == 0) ? 0. : 1.;
          }
      std::vector<double> coefficients;
      s.multiplier.distribute(moments, contact, coefficients);
      const auto lambda = s.cell_values(coefficients);

      // The hats.
      const FE_Q<2>             q1(1);
      DoFHandler<2>             hats(s.tria);
      AffineConstraints<double> hat_constraints;
      hats.distribute_dofs(q1);
      DoFTools::make_hanging_node_constraints(hats, hat_constraints);
      hat_constraints.close();

      // Values of the hats at the quadrature points and at the nodes.
      FEValues<2>                          at_points(s.mapping,
                            q1,
                            s.quadrature,
                            update_values | update_JxW_values);
      FEValues<2>                          at_nodes(s.mapping,
                           q1,
                           Quadrature<2>(s.fe.get_unit_support_points()),
                           update_values);
      std::vector<types::global_dof_index> hat_dofs(4),
        node_dofs(s.fe.n_dofs_per_cell());
      unsigned int n_checked = 0;
      for (types::global_dof_index b = 0; b < hats.n_dofs(); ++b)
        {
          if (hat_constraints.is_constrained(b))
            continue;
          dealii::Vector<double> psi(hats.n_dofs());
          psi(b) = 1;
          hat_constraints.distribute(psi);

          double              integral = 0, functional = 0;
          std::vector<bool>   counted(s.dofs.n_dofs(), false);
          std::vector<double> psi_q(s.quadrature.size()),
            psi_node(s.fe.n_dofs_per_cell());
          auto node_cell = s.dofs.begin_active();
          for (const auto &cell : hats.active_cell_iterators())
            {
              at_points.reinit(cell);
              at_points.get_function_values(psi, psi_q);
              for (unsigned int q = 0; q < psi_q.size(); ++q)
                integral += lambda[cell->active_cell_index()][q] * psi_q[q] *
                            at_points.JxW(q);
              at_nodes.reinit(cell);
              at_nodes.get_function_values(psi, psi_node);
              node_cell->get_dof_indices(node_dofs);
              for (unsigned int i = 0; i < node_dofs.size(); ++i)
                if (!counted[node_dofs[i]] &&
                    !s.no_moment.is_constrained(node_dofs[i]))
                  {
                    counted[node_dofs[i]] = true;
                    functional += moments(node_dofs[i]) * psi_node[i];
                  }
              ++node_cell;
            }
          EXPECT_NEAR(integral, functional, 1e-13)
            << "Q" << degree << ", hat " << b;
          ++n_checked;
        }
      EXPECT_GT(n_checked, 20u);
    }
}


// The moments of a constant multiplier c against the basis functions that
// are conforming under the hanging node constraints (assembled through
// them, as the discrete system does), with only the hanging nodes
// carrying no moment.
static TrilinosVector
constant_moments(Setting &s, const double c)
{
  s.no_moment.clear();
  DoFTools::make_hanging_node_constraints(s.dofs, s.no_moment);
  s.no_moment.close();
  s.multiplier.reinit(s.mapping, s.dofs, s.no_moment, s.quadrature);

  TrilinosVector                       moments = s.vector();
  FEValues<2>                          values(s.mapping,
                     s.fe,
                     s.quadrature,
                     update_values | update_JxW_values);
  std::vector<types::global_dof_index> dofs(s.fe.n_dofs_per_cell());
  dealii::Vector<double>               local(s.fe.n_dofs_per_cell());
  for (const auto &cell : s.dofs.active_cell_iterators())
    {
      values.reinit(cell);
      cell->get_dof_indices(dofs);
      local = 0;
      for (unsigned int i = 0; i < dofs.size(); ++i)
        for (unsigned int q = 0; q < s.quadrature.size(); ++q)
          local(i) += c * values.shape_value(i, q) * values.JxW(q);
      s.no_moment.distribute_local_to_global(local, dofs, moments);
    }
  moments.compress(VectorOperation::add);
  return moments;
}


// The constant's moments with all nodes in contact: lambda~ = c on every
// cell.
static void
expect_constant_reproduced(const unsigned int degree, const bool hanging)
{
  Setting        s(degree, hanging);
  const double   c       = 2.5;
  TrilinosVector moments = constant_moments(s, c), contact = s.vector();
  ASSERT_EQ(s.no_moment.n_constraints() > 0, hanging);
  for (types::global_dof_index i = 0; i < s.dofs.n_dofs(); ++i)
    contact(i) = 1;

  std::vector<double> coefficients;
  s.multiplier.distribute(moments, contact, coefficients);
  const auto lambda = s.cell_values(coefficients);
  for (const auto &cell : s.dofs.active_cell_iterators())
    for (const double v : lambda[cell->active_cell_index()])
      EXPECT_NEAR(v, c, 1e-12)
        << "Q" << degree << ", cell at " << cell->center();
}


// On a mesh of parallelograms.
TEST(CellMultiplier, ReproducesAConstant)
{
  expect_constant_reproduced(2, false);
}


// On a mesh with hanging nodes, where the moment of a node x_i is that of
// phi_i + sum_j c_ji phi_j over the hanging nodes x_j it constrains: the
// share of the hanging nodes must go back to their cells.
TEST(CellMultiplier, ReproducesAConstantAtHangingNodes)
{
  for (const unsigned int degree : {2u, 3u})
    expect_constant_reproduced(degree, true);
}


// Contact on the left half (x <= 1/2), a multiplier there: every node with
// a moment has a contact cell, so lambda~ vanishes on the right half,
// whose first layer of cells shares the nodes on x = 1/2.
TEST(CellMultiplier, LivesOnTheContactCells)
{
  Setting               s(2, false);
  TrilinosVector        moments = s.vector(), contact = s.vector();
  std::vector<Point<2>> support(s.dofs.n_dofs());
  DoFTools::map_dofs_to_support_points(s.mapping, s.dofs, support);
  for (types::global_dof_index i = 0; i < s.dofs.n_dofs(); ++i)
    if (support[i][0] <= 0.5 + 1e-12 && !s.no_moment.is_constrained(i))
      {
        contact(i) = 1;
        moments(i) = 1. + support[i][1];
      }
  std::vector<double> coefficients;
  s.multiplier.distribute(moments, contact, coefficients);
  const auto   lambda  = s.cell_values(coefficients);
  unsigned int n_right = 0;
  for (const auto &cell : s.dofs.active_cell_iterators())
    if (cell->center()[0] > 0.5)
      {
        ++n_right;
        for (const double v : lambda[cell->active_cell_index()])
          EXPECT_EQ(v, 0.) << "cell at " << cell->center();
      }
    else
      {
        double sum = 0;
        for (const double v : lambda[cell->active_cell_index()])
          sum += v;
        EXPECT_GT(sum, 0.) << "cell at " << cell->center();
      }
  EXPECT_EQ(n_right, 8u);
}


// lambda~ depends continuously on the moments: a parent of a hanging node
// whose moment is zero up to round-off, of either sign (the multiplier of
// a converged iterate at a node that has just left the contact set), gives
// its hanging nodes nothing, and the others' parts are as for a zero
// moment. (A parent with a moment of the other sign than the part it
// would give up used to give all of it, so that -1e-14 and +1e-14 made
// lambda~ differ by the hanging node's share; runs on one and on two
// threads then refined different cells.)
TEST(CellMultiplier, IsContinuousInTheMomentsAtHangingNodes)
{
  for (const unsigned int degree : {2u, 3u})
    {
      Setting        s(degree, true);
      TrilinosVector moments = constant_moments(s, 2.5), contact = s.vector();
      for (types::global_dof_index i = 0; i < s.dofs.n_dofs(); ++i)
        contact(i) = 1;
      // a parent of the first hanging node
      types::global_dof_index parent = numbers::invalid_dof_index;
      for (types::global_dof_index j = 0; j < s.dofs.n_dofs(); ++j)
        if (const auto *entries = s.no_moment.get_constraint_entries(j))
          {
            parent = entries->front().first;
            break;
          }
      ASSERT_NE(parent, numbers::invalid_dof_index);

      std::vector<std::vector<double>> lambda;
      for (const double round_off : {-1e-14, 0., 1e-14})
        {
          moments(parent) = round_off;
          std::vector<double> coefficients;
          s.multiplier.distribute(moments, contact, coefficients);
          lambda.push_back(coefficients);
        }
      for (std::size_t k = 0; k < lambda[1].size(); ++k)
        {
          EXPECT_NEAR(lambda[0][k], lambda[1][k], 1e-8)
            << "Q" << degree << ", coefficient " << k;
          EXPECT_NEAR(lambda[2][k], lambda[1][k], 1e-8)
            << "Q" << degree << ", coefficient " << k;
        }
    }
}
