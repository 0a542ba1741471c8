// The transmitted load of the estimate (VI::TransmittedLoad): the moments G
// it takes from lambda_h are those of g 1_J against every conforming vertex
// hat, also on meshes with hanging nodes and for Q2 (so that lambda~ = g 1_J
// + the multiplier of m - G keeps the moments the patch problems need), and
// J holds the contact cells, the cut cells where the data jump, and no cell
// without a node in contact (with BoundaryCells::all, every cell with one).
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

#include <vi/transmitted_load.h>

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace
{
  using namespace dealii;
  using TrilinosVector = TrilinosWrappers::MPI::Vector;

  // Q_p on the unit square refined twice, one cell once more (hanging
  // nodes), Dirichlet nodes on the boundary; loads f1, f2 that jump across
  // a circle, a contact set inside it and a gap outside.
  struct Setting
  {
    explicit Setting(const unsigned int degree)
        : fe(degree)
        , dofs(tria)
        , quadrature(degree + 3)
    {
      GridGenerator::hyper_cube(tria);
      tria.refine_global(3);
      for (const auto &cell : tria.active_cell_iterators())
        if (cell->center().distance(Point<2>(0.5, 0.5)) < 0.2)
          cell->set_refine_flag();
      tria.execute_coarsening_and_refinement();
      dofs.distribute_dofs(fe);
      DoFTools::make_hanging_node_constraints(dofs, no_moment);
      VectorTools::interpolate_boundary_values(dofs,
                                               0,
                                               Functions::ZeroFunction<2>(),
                                               no_moment);
      no_moment.close();
      load.reinit(mapping, dofs, no_moment, quadrature, 1. / numbers::PI);

      FEValues<2> values(mapping, fe, quadrature, update_quadrature_points);
      for (const auto &cell : dofs.active_cell_iterators())
        {
          values.reinit(cell);
          for (const Point<2> &x : values.get_quadrature_points())
            {
              const bool inside = x.distance(Point<2>(0.45, 0.5)) < 0.3;
              f1.push_back(inside ? -2. : 0.3 * x[0]);
              f2.push_back(inside ? 2. + x[1] : 0.);
            }
        }

      const auto            all = complete_index_set(dofs.n_dofs());
      std::vector<Point<2>> support(dofs.n_dofs());
      DoFTools::map_dofs_to_support_points(mapping, dofs, support);
      contact.reinit(all, MPI_COMM_WORLD);
      s1.reinit(all, MPI_COMM_WORLD);
      s2.reinit(all, MPI_COMM_WORLD);
      for (types::global_dof_index i = 0; i < dofs.n_dofs(); ++i)
        {
          const double r = support[i].distance(Point<2>(0.45, 0.5));
          contact(i)     = r < 0.25 ? 1. : 0.;
          s1(i)          = r < 0.25 ? 0. : std::pow(r - 0.25, 2);
          s2(i)          = 0.;
        }
      no_moment.distribute(s1);
    }

    // The nodes of a cell that carry a moment, and those of them in contact.
    std::pair<unsigned int, unsigned int>
    free_and_contact_nodes(
      const DoFHandler<2>::active_cell_iterator &cell) const
    {
      std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
      cell->get_dof_indices(dofs);
      unsigned int n_free = 0, n_in_contact = 0;
      for (const auto i : dofs)
        if (!no_moment.is_constrained(i))
          {
            ++n_free;
            n_in_contact += contact(i) > 0;
          }
      return {n_free, n_in_contact};
    }

    // g at point q of the cell with active index `index`.
    double
    g(const double       mu1,
      const double       mu2,
      const unsigned int index,
      const unsigned int q) const
    {
      const unsigned int n_q = quadrature.size();
      return VI::TransmittedLoad<2>::value(mu1,
                                           mu2,
                                           f1[index * n_q + q],
                                           f2[index * n_q + q]);
    }

    Triangulation<2>          tria;
    FE_Q<2>                   fe;
    DoFHandler<2>             dofs;
    QGauss<2>                 quadrature;
    MappingQ<2>               mapping{1};
    AffineConstraints<double> no_moment;
    VI::TransmittedLoad<2>    load;
    std::vector<double>       f1, f2;
    TrilinosVector            contact, s1, s2;
  };
} // namespace


// For every conforming vertex hat psi_b, sum_i G_i psi_b(x_i) over the nodes
// that carry a moment equals (g 1_J, psi_b).
TEST(TransmittedLoad, TakesTheMomentsOfTheLoadOnJAgainstTheVertexHats)
{
  for (const unsigned int degree : {1u, 2u})
    for (const double mu1 : {1e-6, 1., 1e3})
      {
        Setting                       s(degree);
        const double                  mu2 = 1.;
        VI::TransmittedLoad<2>::Split split;
        s.load.split(mu1, mu2, s.f1, s.f2, s.contact, s.s1, s.s2, split);
        const unsigned int n_q          = s.quadrature.size();
        unsigned int       n_load_cells = 0;
        for (unsigned int c = 0; c < s.tria.n_active_cells(); ++c)
          n_load_cells += split.values[c * n_q] != 0.;
        EXPECT_GT(n_load_cells, 10u);

        const FE_Q<2>             q1(1);
        DoFHandler<2>             hats(s.tria);
        AffineConstraints<double> hat_constraints;
        hats.distribute_dofs(q1);
        DoFTools::make_hanging_node_constraints(hats, hat_constraints);
        hat_constraints.close();
        std::vector<Point<2>> hat_support(hats.n_dofs());
        DoFTools::map_dofs_to_support_points(s.mapping, hats, hat_support);
        FEValues<2>                          at_points(s.mapping,
                              q1,
                              s.quadrature,
                              update_values | update_JxW_values);
        FEValues<2>                          at_nodes(s.mapping,
                             q1,
                             Quadrature<2>(s.fe.get_unit_support_points()),
                             update_values);
        std::vector<types::global_dof_index> node_dofs(s.fe.n_dofs_per_cell());
        std::vector<double> psi_q(n_q), psi_node(s.fe.n_dofs_per_cell());
        unsigned int        n_checked = 0;
        for (types::global_dof_index b = 0; b < hats.n_dofs(); ++b)
          {
            if (hat_constraints.is_constrained(b))
              continue;
            dealii::Vector<double> psi(hats.n_dofs());
            psi(b) = 1;
            hat_constraints.distribute(psi);

            double            integral = 0, functional = 0, size = 0;
            std::vector<bool> counted(s.dofs.n_dofs(), false);
            auto              node_cell = s.dofs.begin_active();
            for (const auto &cell : hats.active_cell_iterators())
              {
                const auto index = cell->active_cell_index();
                at_points.reinit(cell);
                at_points.get_function_values(psi, psi_q);
                for (unsigned int q = 0; q < n_q; ++q)
                  {
                    const double g = s.g(mu1, mu2, index, q);
                    size += std::abs(g) * psi_q[q] * at_points.JxW(q);
                    integral += split.values[index * n_q + q] * psi_q[q] *
                                at_points.JxW(q);
                  }
                at_nodes.reinit(cell);
                at_nodes.get_function_values(psi, psi_node);
                node_cell->get_dof_indices(node_dofs);
                for (unsigned int i = 0; i < node_dofs.size(); ++i)
                  if (!counted[node_dofs[i]] &&
                      !s.no_moment.is_constrained(node_dofs[i]))
                    {
                      counted[node_dofs[i]] = true;
                      functional +=
                        split.node_moments(node_dofs[i]) * psi_node[i];
                    }
                ++node_cell;
              }
            // (the hats of boundary vertices carry no moment: their patch
            // problems need none)
            const Point<2> &x = hat_support[b];
            if (x[0] == 0. || x[0] == 1. || x[1] == 0. || x[1] == 1.)
              continue;
            EXPECT_NEAR(integral, functional, 1e-13 * (1. + size))
              << "Q" << degree << ", mu1 = " << mu1 << ", hat " << b;
            ++n_checked;
          }
        EXPECT_GT(n_checked, 40u);
      }
}


// g 1_J is g on every contact cell and zero on every cell without a node in
// contact; with mu1 << mu2, where the data jump across the circle, J also
// takes cells with a gap.
TEST(TransmittedLoad, TakesTheContactCellsAndTheCutCellsWhereTheDataJump)
{
  Setting                       s(1);
  const double                  mu1 = 1e-6, mu2 = 1.;
  VI::TransmittedLoad<2>::Split split;
  s.load.split(mu1, mu2, s.f1, s.f2, s.contact, s.s1, s.s2, split);
  const unsigned int n_q             = s.quadrature.size();
  unsigned int       n_contact_cells = 0, n_cut_cells_taken = 0;
  for (const auto &cell : s.dofs.active_cell_iterators())
    {
      const auto [n_free, n_in_contact] = s.free_and_contact_nodes(cell);
      const auto index                  = cell->active_cell_index();
      for (unsigned int q = 0; q < n_q; ++q)
        {
          const double g    = s.g(mu1, mu2, index, q);
          const double in_j = split.values[index * n_q + q];
          if (n_in_contact == 0)
            EXPECT_EQ(in_j, 0.);
          else if (n_in_contact == n_free)
            EXPECT_EQ(in_j, g);
          else
            EXPECT_TRUE(in_j == g || in_j == 0.);
        }
      n_contact_cells += n_in_contact > 0 && n_in_contact == n_free;
      n_cut_cells_taken += n_in_contact > 0 && n_in_contact < n_free &&
                           split.values[index * n_q] != 0.;
    }
  EXPECT_GT(n_contact_cells, 10u);
  EXPECT_GT(n_cut_cells_taken, 0u);
}


// With BoundaryCells::all (step-parabolic) g 1_J is g on every cell with a
// node in contact and zero elsewhere; the cost rule of the steady problems
// leaves some of those cells out on the same data.
TEST(TransmittedLoad, TakesEveryCellAtTheContactSetWhenAskedTo)
{
  Setting                       s(1);
  const double                  mu1 = 1e-6, mu2 = 1.;
  VI::TransmittedLoad<2>::Split by_cost, all;
  s.load.split(mu1, mu2, s.f1, s.f2, s.contact, s.s1, s.s2, by_cost);
  s.load.reinit(s.mapping,
                s.dofs,
                s.no_moment,
                s.quadrature,
                1. / numbers::PI,
                VI::TransmittedLoad<2>::BoundaryCells::all);
  s.load.split(mu1, mu2, s.f1, s.f2, s.contact, s.s1, s.s2, all);

  const unsigned int n_q                = s.quadrature.size();
  unsigned int       n_left_out_by_cost = 0;
  for (const auto &cell : s.dofs.active_cell_iterators())
    {
      const unsigned int n_in_contact = s.free_and_contact_nodes(cell).second;
      const auto         index        = cell->active_cell_index();
      for (unsigned int q = 0; q < n_q; ++q)
        EXPECT_EQ(all.values[index * n_q + q],
                  n_in_contact > 0 ? s.g(mu1, mu2, index, q) : 0.);
      n_left_out_by_cost += n_in_contact > 0 &&
                            by_cost.values[index * n_q] == 0. &&
                            all.values[index * n_q] != 0.;
    }
  EXPECT_GT(n_left_out_by_cost, 0u);
}
