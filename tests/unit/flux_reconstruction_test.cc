// The equilibrated flux of the vertex patches: div sigma equals the
// projection of the prescribed right-hand side on every cell, to round-off,
// when the data satisfy the discrete equations up to the residual r_h that
// enters the patch problems (as the algebraic residual of an iterate does).
#include <deal.II/base/function.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_dgq.h>
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
#include <deal.II/numerics/vector_tools.h>

#include <vi/flux_reconstruction.h>

#include <gtest/gtest.h>

#include "equilibration_defect.h"

#include <cmath>
#include <memory>
#include <set>

using namespace dealii;

namespace
{
  /// A smooth load and a potential u_h that is NOT a discrete solution, so
  /// that the residual r_h is far from zero.
  class Load : public Function<2>
  {
  public:
    double
    value(const Point<2> &p, const unsigned int = 0) const override
    {
      return 1. + 3. * p[0] * p[1] + std::sin(4. * p[0]);
    }
  };

  class Potential : public Function<2>
  {
  public:
    double
    value(const Point<2> &p, const unsigned int = 0) const override
    {
      return std::sin(3. * p[0]) * std::cos(2. * p[1]) + p[0] * p[1];
    }
  };


  /// The unit square with 8 x 8 cells (boundary ids 0, 1 at x = 0, 1 and
  /// 2, 3 at y = 0, 1), randomly distorted or not, and
  /// with two more levels towards the corner (0, 0) or not (hanging nodes,
  /// and patches with cells of three sizes).
  void
  make_mesh(Triangulation<2> &tria, const bool distorted, const bool hanging)
  {
    GridGenerator::hyper_cube(tria, 0., 1., /*colorize=*/true);
    tria.refine_global(3);
    if (distorted)
      GridTools::distort_random(0.2, tria, true, 42);
    if (hanging)
      for (unsigned int step = 0; step < 2; ++step)
        {
          for (const auto &cell : tria.active_cell_iterators())
            if (cell->center().norm() < 0.45)
              cell->set_refine_flag();
          tria.execute_coarsening_and_refinement();
        }
  }


  /// Q_p on the mesh of make_mesh(), refined `refinements` times more,
  /// with its DoFs, and the mapping the tests use.
  struct ConformingSpace
  {
    ConformingSpace(const unsigned int degree,
                    const bool         distorted,
                    const bool         hanging,
                    const unsigned int refinements = 0)
        : mapping(1)
        , fe(degree)
    {
      make_mesh(tria, distorted, hanging);
      tria.refine_global(refinements);
      dofs.reinit(tria);
      dofs.distribute_dofs(fe);
    }

    Triangulation<2> tria;
    MappingQ<2>      mapping;
    FE_Q<2>          fe;
    DoFHandler<2>    dofs;
  };


  /// The data of a reconstruction from u_h on `dofs`: the flux grad u_h and
  /// the source f - r_h, with r_h the function *r on `dofs` (f alone
  /// without r), at the points of `quadrature`. Each thread makes its own
  /// FEValues (the cells are evaluated concurrently).
  VI::FluxReconstruction<2>::Sources
  gradient_sources(const Mapping<2>     &mapping,
                   const DoFHandler<2>  &dofs,
                   const Quadrature<2>  &quadrature,
                   const Vector<double> &u,
                   const Function<2>    &f,
                   const Vector<double> *r = nullptr)
  {
    VI::FluxReconstruction<2>::Sources sources;
    sources.make_cell_values = [&mapping, &dofs, &quadrature, &u, &f, r]() {
      const auto values =
        std::make_shared<FEValues<2>>(mapping,
                                      dofs.get_fe(),
                                      quadrature,
                                      update_values | update_gradients |
                                        update_quadrature_points);
      const auto r_values =
        std::make_shared<std::vector<double>>(quadrature.size());
      return [&dofs, &u, &f, r, values, r_values](const auto &cell,
                                                  auto       &flux,
                                                  auto       &source) {
        values->reinit(typename DoFHandler<2>::active_cell_iterator(
          &dofs.get_triangulation(), cell->level(), cell->index(), &dofs));
        values->get_function_gradients(u, flux[0]);
        if (r != nullptr)
          values->get_function_values(*r, *r_values);
        for (unsigned int q = 0; q < source[0].size(); ++q)
          source[0][q] = f.value(values->quadrature_point(q)) -
                         (r != nullptr ? (*r_values)[q] : 0.);
      };
    };
    return sources;
  }


  /// max |sigma . n| on the faces of `sides` over max |sigma|, at the
  /// Gauss points of the faces.
  double
  largest_normal_flux(const VI::FluxReconstruction<2>          &reconstruction,
                      const VI::FluxReconstruction<2>::Sources &sources,
                      const std::set<types::boundary_id>       &sides)
  {
    TrilinosWrappers::MPI::Vector sigma;
    reconstruction.reconstruct(sources, {&sigma});
    const DoFHandler<2> &flux_dofs = reconstruction.get_dof_handler();
    const MappingQ<2>    mapping(1);
    FEFaceValues<2>      face_values(mapping,
                                flux_dofs.get_fe(),
                                QGauss<1>(4),
                                update_values | update_normal_vectors);
    const FEValuesExtractors::Vector sigma_extractor(0);
    std::vector<Tensor<1, 2>>        values(face_values.n_quadrature_points);
    double                           normal = 0, largest = 0;
    for (const auto &cell : flux_dofs.active_cell_iterators())
      for (const unsigned int f : cell->face_indices())
        {
          face_values.reinit(cell, f);
          face_values[sigma_extractor].get_function_values(sigma, values);
          for (unsigned int q = 0; q < values.size(); ++q)
            {
              largest = std::max(largest, values[q].norm());
              if (cell->face(f)->at_boundary() &&
                  sides.count(cell->face(f)->boundary_id()))
                normal =
                  std::max(normal,
                           std::abs(values[q] * face_values.normal_vector(q)));
            }
        }
    return normal / largest;
  }


  /**
   * For degree p: build u_h, the residual vector R_i = (f, psi_i) -
   * (grad u_h, grad psi_i) on interior nodes, its representation r_h
   * ((r_h, psi_i) = R_i: lumped for p = 1, consistent for p >= 2), the flux
   * in RT_k (k = p or p - 1), and return the largest relative moment
   * (div sigma - (f - r_h), q)_K over cells K and q in Q_k(K). On the sides
   * `free_sides` u_h is free (its nodes carry a residual) and sigma . n = 0;
   * `normal_flux`, if given, receives the largest |sigma . n| there
   * relative to the largest |sigma|.
   */
  double
  equilibration_defect(const unsigned int                  degree,
                       const unsigned int                  flux_degree,
                       const bool                          distorted,
                       const bool                          hanging,
                       const std::set<types::boundary_id> &free_sides = {},
                       double *normal_flux                            = nullptr)
  {
    const ConformingSpace     space(degree, distorted, hanging);
    const Mapping<2>         &mapping = space.mapping;
    const DoFHandler<2>      &dofs    = space.dofs;
    AffineConstraints<double> hanging_nodes;
    DoFTools::make_hanging_node_constraints(dofs, hanging_nodes);
    hanging_nodes.close();
    // The residual lives on the regular nodes off the clamped sides.
    AffineConstraints<double> constraints;
    constraints.merge(hanging_nodes);
    for (const types::boundary_id side : {0, 1, 2, 3})
      if (free_sides.count(side) == 0)
        DoFTools::make_zero_boundary_constraints(dofs, side, constraints);
    constraints.close();

    Vector<double> u(dofs.n_dofs());
    VectorTools::interpolate(mapping, dofs, Potential(), u);
    hanging_nodes.distribute(u);
    const Load f;

    // The residual must be integrated with the rule of the reconstruction
    // (otherwise the patch problems are only compatible up to the
    // difference of the two quadratures on non-affine cells).
    const QGauss<2> quadrature(
      VI::FluxReconstruction<2>::quadrature_points(degree, flux_degree));
    FEValues<2>            values(mapping,
                       space.fe,
                       quadrature,
                       update_values | update_gradients |
                         update_quadrature_points | update_JxW_values);
    Vector<double>         R(dofs.n_dofs()), lumped(dofs.n_dofs());
    DynamicSparsityPattern dsp(dofs.n_dofs());
    DoFTools::make_sparsity_pattern(dofs, dsp, hanging_nodes, false);
    SparsityPattern sparsity;
    sparsity.copy_from(dsp);
    SparseMatrix<double>                 mass(sparsity);
    std::vector<types::global_dof_index> local(space.fe.n_dofs_per_cell());
    std::vector<Tensor<1, 2>>            grad_u(quadrature.size());
    Vector<double>                       cell_R(space.fe.n_dofs_per_cell()),
      cell_lumped(space.fe.n_dofs_per_cell());
    FullMatrix<double> cell_mass(space.fe.n_dofs_per_cell());
    for (const auto &cell : dofs.active_cell_iterators())
      {
        values.reinit(cell);
        cell->get_dof_indices(local);
        values.get_function_gradients(u, grad_u);
        cell_R      = 0;
        cell_lumped = 0;
        cell_mass   = 0;
        for (const unsigned int q : values.quadrature_point_indices())
          for (const unsigned int i : values.dof_indices())
            {
              const double dx = values.JxW(q);
              cell_R(i) += (f.value(values.quadrature_point(q)) *
                              values.shape_value(i, q) -
                            grad_u[q] * values.shape_grad(i, q)) *
                           dx;
              cell_lumped(i) += values.shape_value(i, q) * dx;
              for (const unsigned int j : values.dof_indices())
                cell_mass(i, j) +=
                  values.shape_value(i, q) * values.shape_value(j, q) * dx;
            }
        // The residual of the conforming test functions (constrained rows
        // zero), the masses of the conforming hats.
        constraints.distribute_local_to_global(cell_R, local, R);
        hanging_nodes.distribute_local_to_global(cell_lumped, local, lumped);
        hanging_nodes.distribute_local_to_global(cell_mass, local, mass);
      }

    // r_h: for p = 1 the constants r_a = R_a / (psi_a, 1) on the patches;
    // for p >= 2 the function M^{-1} R.
    Vector<double> r(dofs.n_dofs());
    if (degree > 1)
      {
        SolverControl            control(2000, 1e-15 * R.l2_norm());
        SolverCG<Vector<double>> cg(control);
        cg.solve(mass, r, R, PreconditionIdentity());
      }
    else
      // p = 1: the nodal values r_a of the regular vertices; at hanging
      // vertices the constraint interpolates them (sum_a r_a psi_a).
      for (unsigned int i = 0; i < dofs.n_dofs(); ++i)
        if (!constraints.is_constrained(i))
          r(i) = R(i) / lumped(i);
    hanging_nodes.distribute(r);
    std::vector<double> vertex_residual(space.tria.n_vertices(), 0.);
    if (degree == 1)
      for (const auto &cell : dofs.active_cell_iterators())
        for (const unsigned int v : cell->vertex_indices())
          vertex_residual[cell->vertex_index(v)] =
            r(cell->vertex_dof_index(v, 0));

    VI::FluxReconstruction<2> reconstruction(mapping, flux_degree, degree);
    EXPECT_EQ(reconstruction.get_quadrature().size(), quadrature.size());
    reconstruction.reinit(dofs, free_sides);
    // p >= 2: the source f - r_h; p = 1: f, and -r_a on the patches.
    auto sources = gradient_sources(mapping,
                                    dofs,
                                    reconstruction.get_quadrature(),
                                    u,
                                    f,
                                    degree > 1 ? &r : nullptr);
    if (degree == 1)
      sources.vertex_source = [&](const unsigned int a, const unsigned int) {
        return -vertex_residual[a];
      };

    if (normal_flux != nullptr)
      *normal_flux = largest_normal_flux(reconstruction, sources, free_sides);
    // Compare div sigma with the target f - r_h (p >= 2) or
    // f - sum_a r_a psi_a (p = 1: r_h is the Q1 function r), in the moments
    // of Q_k.
    return VITest::reconstructed_flux_defect(reconstruction,
                                             sources,
                                             {mapping, quadrature, dofs, f, r},
                                             FE_DGQ<2>(flux_degree));
  }
} // namespace


class FluxReconstructionTest
    : public ::testing::TestWithParam<std::tuple<unsigned int, bool, bool>>
{
};


TEST_P(FluxReconstructionTest, DivergenceEqualsTheProjectedSourceOnEveryCell)
{
  const auto [degree, distorted, hanging] = GetParam();
  const double defect =
    equilibration_defect(degree, degree, distorted, hanging);
  EXPECT_TRUE(std::isfinite(defect)) << "a patch problem was not solvable";
  EXPECT_LT(defect, 1e-10) << "p = " << degree;
}


// Estimators/Flux degree = p-1: fluxes in RT_(p-1) for Q_p data, on the
// quadrature of Q_p, are equilibrated in the moments of Q_(p-1) (for p = 1
// the cell means).
TEST_P(FluxReconstructionTest, LowerDegreeFluxesAreEquilibratedInTheirMoments)
{
  const auto [degree, distorted, hanging] = GetParam();
  const double defect =
    equilibration_defect(degree, degree - 1, distorted, hanging);
  EXPECT_TRUE(std::isfinite(defect)) << "a patch problem was not solvable";
  EXPECT_LT(defect, 1e-10) << "p = " << degree << ", RT_" << degree - 1;
}


// The rule's size: p + 3 points per direction with RT_p, p + 1 with
// RT_(p-1), both rounded up to even (no point on a midline).
TEST(FluxReconstructionQuadrature, PointsFollowTheDegrees)
{
  using FR = VI::FluxReconstruction<2>;
  EXPECT_EQ(FR::quadrature_points(1), 4u);
  EXPECT_EQ(FR::quadrature_points(1, 1), 4u);
  EXPECT_EQ(FR::quadrature_points(2), 6u);
  EXPECT_EQ(FR::quadrature_points(3, 3), 6u);
  EXPECT_EQ(FR::quadrature_points(1, 0), 2u);
  EXPECT_EQ(FR::quadrature_points(2, 1), 4u);
  EXPECT_EQ(FR::quadrature_points(3, 2), 4u);
}


// Free sides (x = 1 and y = 0): their nodes are unknowns whose residual the
// fluxes balance, so the patches of their vertices are closed by
// sigma . n = 0 there and solvable like interior ones; the flux is
// equilibrated on every cell and has no normal component on those sides.
TEST_P(FluxReconstructionTest, FreeSidesCarryNoNormalFlux)
{
  const auto [degree, distorted, hanging] = GetParam();
  double       normal_flux                = 1;
  const double defect                     = equilibration_defect(
    degree, degree, distorted, hanging, {1, 2}, &normal_flux);
  EXPECT_TRUE(std::isfinite(defect)) << "a patch problem was not solvable";
  EXPECT_LT(defect, 1e-10) << "p = " << degree;
  EXPECT_LT(normal_flux, 1e-12) << "p = " << degree;
}


INSTANTIATE_TEST_SUITE_P(Degrees,
                         FluxReconstructionTest,
                         ::testing::Combine(::testing::Values(1u, 2u, 3u),
                                            ::testing::Bool(),
                                            ::testing::Bool()),
                         [](const auto &info) {
                           return "p" +
                                  std::to_string(std::get<0>(info.param)) +
                                  (std::get<1>(info.param) ? "_distorted" :
                                                             "_uniform") +
                                  (std::get<2>(info.param) ? "_hanging_nodes" :
                                                             "");
                         });


// The patch energy is that of the parallelogram with each cell's mean
// Jacobian, with the right-hand side in the same metric: a flux that lies
// in RT_p of every patch must come out unchanged. For a constant F = c and
// no source, psi_a c is such a flux (also on bilinear cells, where its
// Piola pull-back adj(J) c psi^_a is in RT_p of the reference cell), so
// sigma = -c to round-off on distorted meshes, with or without hanging
// nodes. A right-hand side in the true L2 metric against the approximate
// energy would miss it on non-affine cells. The first reconstruction on a
// mesh computes the patches' energy products from the cells' metrics, the
// second keeps them: both are checked.
TEST_P(FluxReconstructionTest, ReproducesAConstantFluxOnDistortedMeshes)
{
  const auto [degree, distorted, hanging] = GetParam();
  const ConformingSpace space(degree, distorted, hanging);

  const Tensor<1, 2>        c({0.3, -1.2});
  VI::FluxReconstruction<2> reconstruction(space.mapping, degree);
  reconstruction.reinit(space.dofs);
  typename VI::FluxReconstruction<2>::Sources sources;
  sources.make_cell_values = [&]() {
    return [&](const auto &, auto &flux, auto &source) {
      std::fill(flux[0].begin(), flux[0].end(), c);
      std::fill(source[0].begin(), source[0].end(), 0.);
    };
  };
  for (const unsigned int call : {1u, 2u})
    {
      TrilinosWrappers::MPI::Vector sigma;
      reconstruction.reconstruct(sources, {&sigma});

      FEValues<2>                      sigma_values(space.mapping,
                               reconstruction.get_dof_handler().get_fe(),
                               reconstruction.get_quadrature(),
                               update_values);
      const FEValuesExtractors::Vector sigma_extractor(0);
      std::vector<Tensor<1, 2>> values(reconstruction.get_quadrature().size());
      double                    largest = 0;
      for (const auto &cell :
           reconstruction.get_dof_handler().active_cell_iterators())
        {
          sigma_values.reinit(cell);
          sigma_values[sigma_extractor].get_function_values(sigma, values);
          for (const auto &value : values)
            largest = std::max(largest, (value + c).norm() / c.norm());
        }
      EXPECT_LT(largest, 1e-10) << "p = " << degree << ", call " << call;
    }
}


// The patches are set up in chunks, and the cells' right-hand sides and the
// patch problems computed, on the threads of MultithreadInfo; all is
// gathered or summed in a fixed order: the flux must be the same to the last
// bit with one thread and with four (more than the cores of most test
// machines, so that cells and chunks finish out of order).
TEST(FluxReconstruction, DoesNotDependOnTheNumberOfThreads)
{
  for (const unsigned int degree : {1u, 2u})
    {
      // many chunks of cells and patches per thread: refined 3 times more
      const ConformingSpace space(degree,
                                  /*distorted=*/true,
                                  /*hanging=*/true,
                                  /*refinements=*/3);
      const Mapping<2>     &mapping = space.mapping;
      const DoFHandler<2>  &dofs    = space.dofs;
      Vector<double>        u(dofs.n_dofs());
      VectorTools::interpolate(mapping, dofs, Potential(), u);
      const Load f;

      VI::FluxReconstruction<2> serial_setup(mapping, degree),
        threaded_setup(mapping, degree);
      auto sources =
        gradient_sources(mapping, dofs, serial_setup.get_quadrature(), u, f);
      // the vertex constants vary, so that every patch has its own data
      sources.vertex_source = [&](const unsigned int a, const unsigned int) {
        return std::sin(double(a));
      };

      TrilinosWrappers::MPI::Vector one_thread, four_threads, kept_products;
      MultithreadInfo::set_thread_limit(1);
      serial_setup.reinit(dofs);
      serial_setup.reconstruct(sources, {&one_thread});
      // (the second call on a mesh keeps the patches' energy products)
      serial_setup.reconstruct(sources, {&kept_products});
      MultithreadInfo::set_thread_limit(4);
      threaded_setup.reinit(dofs);
      threaded_setup.reconstruct(sources, {&four_threads});
      MultithreadInfo::set_thread_limit();
      // several chunks of patches per thread
      EXPECT_GT(threaded_setup.statistics().first, 8 * 1024u);
      EXPECT_EQ(threaded_setup.statistics(), serial_setup.statistics());

      ASSERT_EQ(one_thread.size(), four_threads.size());
      unsigned int n_different = 0;
      for (const auto i : one_thread.locally_owned_elements())
        n_different += (one_thread(i) != four_threads(i));
      EXPECT_EQ(n_different, 0u) << "p = " << degree;
      EXPECT_GT(one_thread.l2_norm(), 0.);
      kept_products -= one_thread;
      EXPECT_LT(kept_products.linfty_norm(), 1e-12 * one_thread.linfty_norm())
        << "p = " << degree;
    }
}
