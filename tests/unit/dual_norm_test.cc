// The equilibrated bound of the dual norm ||m||_{-1} of a cellwise constant
// function: guaranteed (never below the exact value, nor below the Galerkin
// value, which is a lower bound), sharp for a smooth m, and far below the
// Friedrichs bound C_F |m| for an m on a thin band.
#include <deal.II/base/multithread_info.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/precondition.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/dual_norm.h>
#include <vi/flux_reconstruction.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace dealii;

namespace
{
  /// Friedrichs constant of the unit square, 1 / (sqrt(2) pi).
  const double friedrichs = 1. / (std::sqrt(2.) * numbers::PI);

  /// ||1||_{-1}^2 on the unit square = (1, z), -Lap z = 1, z = 0 on the
  /// boundary: 64 / pi^6 sum over odd j, k of 1 / (j^2 k^2 (j^2 + k^2)).
  double
  torsion_dual_norm()
  {
    double sum = 0;
    for (int j = 1; j < 2000; j += 2)
      for (int k = 1; k < 2000; k += 2)
        sum += 1. / (double(j) * j * k * k * (j * j + k * k));
    return std::sqrt(64. / std::pow(numbers::PI, 6) * sum);
  }

  /// The Galerkin value ||grad z_h||, z_h in Q1 with zero boundary values:
  /// a lower bound of ||m||_{-1}.
  double
  galerkin_dual_norm(const Triangulation<2> &tria, const std::vector<double> &m)
  {
    FE_Q<2>       fe(1);
    DoFHandler<2> dofs(tria);
    dofs.distribute_dofs(fe);
    AffineConstraints<double> constraints;
    DoFTools::make_hanging_node_constraints(dofs, constraints);
    DoFTools::make_zero_boundary_constraints(dofs, constraints);
    constraints.close();
    DynamicSparsityPattern pattern(dofs.n_dofs());
    DoFTools::make_sparsity_pattern(dofs, pattern, constraints, false);
    SparsityPattern sparsity;
    sparsity.copy_from(pattern);
    SparseMatrix<double>                 matrix(sparsity);
    Vector<double>                       load(dofs.n_dofs()), z(dofs.n_dofs());
    FEValues<2>                          values(fe,
                       QGauss<2>(3),
                       update_values | update_gradients | update_JxW_values);
    FullMatrix<double>                   cell_matrix(4, 4);
    Vector<double>                       cell_load(4);
    std::vector<types::global_dof_index> indices(4);
    for (const auto &cell : dofs.active_cell_iterators())
      {
        values.reinit(cell);
        cell_matrix = 0;
        cell_load   = 0;
        for (const unsigned int q : values.quadrature_point_indices())
          for (unsigned int i = 0; i < 4; ++i)
            {
              for (unsigned int j = 0; j < 4; ++j)
                cell_matrix(i, j) += values.shape_grad(i, q) *
                                     values.shape_grad(j, q) * values.JxW(q);
              cell_load(i) += m[cell->active_cell_index()] *
                              values.shape_value(i, q) * values.JxW(q);
            }
        cell->get_dof_indices(indices);
        constraints.distribute_local_to_global(
          cell_matrix, cell_load, indices, matrix, load);
      }
    SolverControl            control(10000, 1e-13 * load.l2_norm());
    SolverCG<Vector<double>> cg(control);
    cg.solve(matrix, z, load, PreconditionIdentity());
    return std::sqrt(load * z);
  }

  double
  equilibrated_dual_norm(const Triangulation<2>    &tria,
                         const unsigned int         degree,
                         const std::vector<double> &m)
  {
    MappingQ<2>   mapping(1);
    FE_Q<2>       fe(degree);
    DoFHandler<2> potential(tria);
    potential.distribute_dofs(fe);
    VI::FluxReconstruction<2> reconstruction(mapping, degree);
    reconstruction.reinit(potential);
    VI::DualNormBound<2> dual_norm(mapping, reconstruction, friedrichs);
    dual_norm.reinit(tria);
    return dual_norm.bound(m);
  }
} // namespace


TEST(DualNormBound, ConstantOnTheSquareIsSharpAndGuaranteed)
{
  const double exact = torsion_dual_norm();
  EXPECT_NEAR(exact, 0.18747, 1e-5);
  for (const unsigned int degree : {1u, 2u})
    {
      Triangulation<2> tria;
      GridGenerator::hyper_cube(tria);
      tria.refine_global(5);
      // and hanging nodes towards the corner (0, 0)
      for (unsigned int step = 0; step < 2; ++step)
        {
          for (const auto &cell : tria.active_cell_iterators())
            if (cell->center().norm() < 0.3)
              cell->set_refine_flag();
          tria.execute_coarsening_and_refinement();
        }
      const std::vector<double> m(tria.n_active_cells(), 1.);
      const double              bound = equilibrated_dual_norm(tria, degree, m);
      SCOPED_TRACE("degree " + std::to_string(degree));
      EXPECT_GE(bound, exact);
      EXPECT_LE(bound, 1.001 * exact);
      EXPECT_LT(bound, friedrichs); // C_F |m| with |m| = 1
    }
}


TEST(DualNormBound, ThinBandIsFarBelowFriedrichs)
{
  // m = -1 on the two columns of cells at x = 1/2 (a band of width 2h),
  // the shape of the undershoots of a Newton iterate.
  Triangulation<2> tria;
  GridGenerator::hyper_cube(tria);
  tria.refine_global(6);
  const double        h = 1. / 64;
  std::vector<double> m(tria.n_active_cells(), 0.);
  double              m_squared = 0;
  for (const auto &cell : tria.active_cell_iterators())
    if (std::abs(cell->center()[0] - 0.5) < h)
      {
        m[cell->active_cell_index()] = -1.;
        m_squared += cell->measure();
      }
  const double bound    = equilibrated_dual_norm(tria, 1, m);
  const double galerkin = galerkin_dual_norm(tria, m);
  EXPECT_GE(bound, galerkin);
  EXPECT_LE(bound, 1.05 * galerkin);
  EXPECT_LT(bound, 0.5 * friedrichs * std::sqrt(m_squared));
}


TEST(DualNormBound, ZeroIsZero)
{
  Triangulation<2> tria;
  GridGenerator::hyper_cube(tria);
  tria.refine_global(3);
  EXPECT_EQ(equilibrated_dual_norm(tria, 1, std::vector<double>(64, 0.)), 0.);
}


TEST(DualNormBound, DoesNotDependOnTheNumberOfThreads)
{
  // The cell loops run on the threads; their sums are added in the order
  // of the cells, so the bound is the same to the last bit. m varies from
  // cell to cell, so that a different order of the sums would show. (The
  // mesh is distorted: on one thread deal.II's FEValues reuses the
  // geometry of a cell for the next one if it is a translate, which moves
  // the last bits of JxW.)
  Triangulation<2> tria;
  GridGenerator::hyper_cube(tria);
  tria.refine_global(6);
  GridTools::distort_random(0.2, tria, /*keep_boundary=*/true, /*seed=*/7);
  std::vector<double> m(tria.n_active_cells());
  for (const auto &cell : tria.active_cell_iterators())
    m[cell->active_cell_index()] =
      std::sin(7. * cell->center()[0]) * std::cos(3. * cell->center()[1]);
  double bounds[2];
  for (const unsigned int threads : {1u, 4u})
    {
      MultithreadInfo::set_thread_limit(threads);
      bounds[threads == 4] = equilibrated_dual_norm(tria, 1, m);
    }
  MultithreadInfo::set_thread_limit();
  EXPECT_GT(bounds[0], 0.);
  EXPECT_EQ(bounds[0], bounds[1]);
}


TEST(DualNormBound, SeveralSourcesShareOneReconstruction)
{
  // bounds_at_points() equilibrates several sources with one reconstruction
  // (a field each, a Poisson solve each): each bound is the one of its
  // source alone, and a vanishing source gets 0 without a field. Sources of
  // different shapes (smooth, a band, zero) on a Q2 mesh with hanging
  // nodes, given at the reconstruction's points.
  Triangulation<2> tria;
  GridGenerator::hyper_cube(tria);
  tria.refine_global(4);
  for (const auto &cell : tria.active_cell_iterators())
    if (cell->center()[0] < 0.3)
      cell->set_refine_flag();
  tria.execute_coarsening_and_refinement();
  MappingQ<2>   mapping(1);
  FE_Q<2>       fe(2);
  DoFHandler<2> potential(tria);
  potential.distribute_dofs(fe);
  VI::FluxReconstruction<2> reconstruction(mapping, 2);
  reconstruction.reinit(potential);
  VI::DualNormBound<2> dual_norm(mapping, reconstruction, friedrichs);
  dual_norm.reinit(tria);

  const Quadrature<2> &quadrature = reconstruction.get_quadrature();
  FEValues<2>         values(mapping, fe, quadrature, update_quadrature_points);
  const unsigned int  n_q = quadrature.size();
  std::vector<double> smooth(tria.n_active_cells() * n_q), band(smooth.size()),
    zero(smooth.size(), 0.);
  for (const auto &cell : potential.active_cell_iterators())
    {
      values.reinit(cell);
      for (unsigned int q = 0; q < n_q; ++q)
        {
          const Point<2> &x = values.quadrature_point(q);
          const auto      k = cell->active_cell_index() * n_q + q;
          smooth[k]         = x[0] * x[1] - 0.3 * x[1] * x[1];
          band[k] = std::abs(cell->center()[1] - 0.5) < 0.07 ? -1. : 0.;
        }
    }
  const std::vector<double> together =
    dual_norm.bounds_at_points({&smooth, &zero, &band});
  ASSERT_EQ(together.size(), 3u);
  EXPECT_GT(together[0], 0.);
  EXPECT_EQ(together[1], 0.);
  EXPECT_GT(together[2], 0.);
  EXPECT_DOUBLE_EQ(together[0], dual_norm.bounds_at_points({&smooth})[0]);
  EXPECT_DOUBLE_EQ(together[2], dual_norm.bounds_at_points({&band})[0]);
}
