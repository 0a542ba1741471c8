// The interior penalty forms (consistency, symmetry, coercivity), the
// lifting of the jumps that makes the flux reconstruction of a dG function
// compatible, and the Oswald interpolation.
#include <deal.II/base/function.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/dg_reconstruction.h>
#include <vi/errors.h>
#include <vi/flux_reconstruction.h>
#include <vi/interior_penalty.h>

#include <gtest/gtest.h>

#include "equilibration_defect.h"

#include <algorithm>
#include <cmath>

using namespace dealii;

namespace
{
  /// A polynomial of degree p in each variable and its data -Lap u.
  class Polynomial : public Function<2>
  {
  public:
    explicit Polynomial(const unsigned int p)
        : p(p)
    {
    }

    double
    value(const Point<2> &x, const unsigned int = 0) const override
    {
      return (1. + x[0] + std::pow(x[0], p)) * (2. - std::pow(x[1], p));
    }

    double
    laplacian(const Point<2> &x, const unsigned int = 0) const override
    {
      if (p < 2)
        return 0.;
      const double d2x = p * (p - 1.) * std::pow(x[0], p - 2.);
      const double d2y = -double(p) * (p - 1.) * std::pow(x[1], p - 2.);
      return d2x * (2. - std::pow(x[1], p)) +
             (1. + x[0] + std::pow(x[0], p)) * d2y;
    }

  private:
    unsigned int p;
  };

  class MinusLaplacian : public Function<2>
  {
  public:
    explicit MinusLaplacian(const Function<2> &u)
        : u(u)
    {
    }
    double
    value(const Point<2> &x, const unsigned int = 0) const override
    {
      return -u.laplacian(x);
    }

  private:
    const Function<2> &u;
  };

  class Smooth : public Function<2>
  {
  public:
    double
    value(const Point<2> &x, const unsigned int = 0) const override
    {
      return std::sin(3. * x[0]) * std::cos(2. * x[1]) + x[0] * x[1];
    }
  };

  class Load : public Function<2>
  {
  public:
    double
    value(const Point<2> &x, const unsigned int = 0) const override
    {
      return 1. + 3. * x[0] * x[1] + std::sin(4. * x[0]);
    }
  };


  /// The dense dG matrix of A_h and the right-hand side (f, v) + G_h(v).
  struct DGSystem
  {
    FullMatrix<double> matrix;
    Vector<double>     rhs;
  };

  DGSystem
  assemble(const VI::InteriorPenalty &penalty,
           const Mapping<2>          &mapping,
           const DoFHandler<2>       &dofs,
           const Quadrature<2>       &quadrature,
           const Quadrature<1>       &face_quadrature,
           const Function<2>         &f,
           const Function<2>         &g)
  {
    const auto       &fe    = dofs.get_fe();
    const UpdateFlags flags = update_values | update_gradients |
                              update_quadrature_points | update_JxW_values |
                              update_normal_vectors;
    FEValues<2>          values(mapping, fe, quadrature, flags);
    FEFaceValues<2>      face_values(mapping, fe, face_quadrature, flags);
    FEInterfaceValues<2> interface(mapping, fe, face_quadrature, flags);

    DGSystem system;
    system.matrix.reinit(dofs.n_dofs(), dofs.n_dofs());
    system.rhs.reinit(dofs.n_dofs());
    const unsigned int                   n = fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> local(n);
    for (const auto &cell : dofs.active_cell_iterators())
      {
        values.reinit(cell);
        cell->get_dof_indices(local);
        FullMatrix<double> cell_matrix(n, n);
        Vector<double>     cell_rhs(n);
        VI::InteriorPenalty::add_cell_matrix(values, cell_matrix);
        for (const unsigned int q : values.quadrature_point_indices())
          for (unsigned int i = 0; i < n; ++i)
            cell_rhs(i) += f.value(values.quadrature_point(q)) *
                           values.shape_value(i, q) * values.JxW(q);
        for (const unsigned int face : cell->face_indices())
          {
            const double h_F =
              VI::InteriorPenalty::normal_extent<2>(cell, face);
            if (cell->at_boundary(face))
              {
                face_values.reinit(cell, face);
                std::vector<double> g_values(face_quadrature.size());
                g.value_list(face_values.get_quadrature_points(), g_values);
                penalty.add_boundary_matrix(face_values, h_F, cell_matrix);
                penalty.add_boundary_rhs(face_values, h_F, g_values, cell_rhs);
              }
            else if (!cell->neighbor(face)->has_children() &&
                     (cell->neighbor_is_coarser(face) ||
                      cell->index() < cell->neighbor(face)->index()))
              {
                // each interior face once, from the finer side at a
                // refinement edge
                const auto neighbor = cell->neighbor(face);
                const auto [neighbor_face, neighbor_subface] =
                  cell->neighbor_is_coarser(face) ?
                    cell->neighbor_of_coarser_neighbor(face) :
                    std::make_pair(cell->neighbor_of_neighbor(face),
                                   numbers::invalid_unsigned_int);
                interface.reinit(cell,
                                 face,
                                 numbers::invalid_unsigned_int,
                                 neighbor,
                                 neighbor_face,
                                 neighbor_subface);
                const auto face_dofs = interface.get_interface_dof_indices();
                FullMatrix<double> face_matrix(face_dofs.size(),
                                               face_dofs.size());
                penalty.add_face_matrix(interface, h_F, face_matrix);
                for (unsigned int i = 0; i < face_dofs.size(); ++i)
                  for (unsigned int j = 0; j < face_dofs.size(); ++j)
                    system.matrix(face_dofs[i], face_dofs[j]) +=
                      face_matrix(i, j);
              }
          }
        for (unsigned int i = 0; i < n; ++i)
          {
            system.rhs(local[i]) += cell_rhs(i);
            for (unsigned int j = 0; j < n; ++j)
              system.matrix(local[i], local[j]) += cell_matrix(i, j);
          }
      }
    return system;
  }


  VI::InteriorPenalty
  method(const std::string &name, const unsigned int p, const double C = 2.)
  {
    return VI::InteriorPenalty::from_name(name, C, p);
  }
} // namespace


TEST(InteriorPenalty, NamesSymmetryAndPenalty)
{
  EXPECT_EQ(VI::InteriorPenalty::names(), "sipg|nipg|iipg");
  EXPECT_EQ(method("sipg", 1).symmetry(), -1.);
  EXPECT_EQ(method("nipg", 1).symmetry(), 1.);
  EXPECT_EQ(method("iipg", 1).symmetry(), 0.);
  EXPECT_EQ(method("nipg", 3).label(), "NIPG");
  // gamma_F / h_F = C p (p + 1) / h_F
  EXPECT_DOUBLE_EQ(method("sipg", 3, 1.5).penalty(0.25), 1.5 * 12. / 0.25);
  EXPECT_THROW(method("ldg", 1), VI::InputError);
  EXPECT_THROW(method("sipg", 1, 0.), VI::InputError);
  EXPECT_THROW(method("sipg", 1, -1.), VI::InputError);
}


TEST(InteriorPenalty, NormalExtentIsTheCellWidthAcrossTheFace)
{
  Triangulation<2> tria;
  GridGenerator::subdivided_hyper_rectangle(tria,
                                            {4, 2},
                                            Point<2>(0, 0),
                                            Point<2>(2, 1));
  for (const auto &cell : tria.active_cell_iterators())
    for (const unsigned int f : cell->face_indices())
      // faces 0, 1 are x = const (width 0.5), faces 2, 3 y = const (0.5)
      EXPECT_NEAR((VI::InteriorPenalty::normal_extent<2>(cell, f)), 0.5, 1e-14);
  tria.clear();
  GridGenerator::subdivided_hyper_rectangle(tria,
                                            {1, 4},
                                            Point<2>(0, 0),
                                            Point<2>(1, 1));
  for (const auto &cell : tria.active_cell_iterators())
    {
      EXPECT_NEAR((VI::InteriorPenalty::normal_extent<2>(cell, 0)), 1., 1e-14);
      EXPECT_NEAR((VI::InteriorPenalty::normal_extent<2>(cell, 2)),
                  0.25,
                  1e-14);
    }
}


class InteriorPenaltyMethods
    : public ::testing::TestWithParam<std::tuple<std::string, unsigned int>>
{
};


// Consistency: a Q_p solution with weakly imposed data is reproduced
// exactly on a mesh of rectangles of different sizes, by all three methods.
TEST_P(InteriorPenaltyMethods, ReproducesQpSolutionsWithWeakDirichletData)
{
  const auto [name, p] = GetParam();
  Triangulation<2> tria;
  GridGenerator::subdivided_hyper_rectangle(tria,
                                            {{0.1, 0.3, 0.6}, {0.5, 0.2, 0.3}},
                                            Point<2>(0, 0),
                                            Point<2>(1, 1));
  MappingQ<2>             mapping(1);
  FE_DGQArbitraryNodes<2> fe(QGaussLobatto<1>(p + 1));
  DoFHandler<2>           dofs(tria);
  dofs.distribute_dofs(fe);
  const Polynomial     u(p);
  const MinusLaplacian f(u);
  DGSystem             system = assemble(
    method(name, p), mapping, dofs, QGauss<2>(p + 2), QGauss<1>(p + 2), f, u);
  Vector<double> solution(dofs.n_dofs()), exact(dofs.n_dofs());
  system.matrix.gauss_jordan();
  system.matrix.vmult(solution, system.rhs);
  VectorTools::interpolate(mapping, dofs, u, exact);
  solution -= exact;
  EXPECT_LT(solution.linfty_norm(), 1e-9 * exact.linfty_norm())
    << name << ", p = " << p;
}


// SIPG is symmetric; with the default penalty its matrix (with weak
// Dirichlet data) is positive definite. NIPG's symmetric part is positive
// definite for any penalty.
TEST_P(InteriorPenaltyMethods, StabilityOfTheDefaultPenalty)
{
  const auto [name, p] = GetParam();
  Triangulation<2> tria;
  GridGenerator::hyper_cube(tria);
  tria.refine_global(2);
  MappingQ<2>             mapping(1);
  FE_DGQArbitraryNodes<2> fe(QGaussLobatto<1>(p + 1));
  DoFHandler<2>           dofs(tria);
  dofs.distribute_dofs(fe);
  const Functions::ZeroFunction<2> zero;

  const auto smallest_eigenvalue_of_symmetric_part = [&](const double C) {
    DGSystem                 system = assemble(method(name, p, C),
                               mapping,
                               dofs,
                               QGauss<2>(p + 2),
                               QGauss<1>(p + 2),
                               zero,
                               zero);
    LAPACKFullMatrix<double> symmetric(dofs.n_dofs());
    for (unsigned int i = 0; i < dofs.n_dofs(); ++i)
      for (unsigned int j = 0; j < dofs.n_dofs(); ++j)
        symmetric(i, j) = 0.5 * (system.matrix(i, j) + system.matrix(j, i));
    symmetric.compute_eigenvalues();
    double smallest = std::numeric_limits<double>::max();
    for (unsigned int i = 0; i < dofs.n_dofs(); ++i)
      smallest = std::min(smallest, symmetric.eigenvalue(i).real());
    if (name == "sipg")
      {
        double asymmetry = 0;
        for (unsigned int i = 0; i < dofs.n_dofs(); ++i)
          for (unsigned int j = 0; j < dofs.n_dofs(); ++j)
            asymmetry =
              std::max(asymmetry,
                       std::abs(system.matrix(i, j) - system.matrix(j, i)));
        EXPECT_LT(asymmetry, 1e-10 * system.matrix.linfty_norm());
      }
    return smallest;
  };

  EXPECT_GT(smallest_eigenvalue_of_symmetric_part(
              VI::InteriorPenalty::default_penalty_constant),
            0.)
    << name << ", p = " << p;
  // A penalty far below the threshold C (p + 1) / p > 3/2: SIPG is
  // indefinite, NIPG still positive.
  const double small = smallest_eigenvalue_of_symmetric_part(0.05);
  if (name == "sipg")
    {
      EXPECT_LT(small, 0.) << "p = " << p;
    }
  if (name == "nipg")
    {
      EXPECT_GT(small, 0.) << "p = " << p;
    }
}


INSTANTIATE_TEST_SUITE_P(
  MethodsAndDegrees,
  InteriorPenaltyMethods,
  ::testing::Combine(::testing::Values("sipg", "nipg", "iipg"),
                     ::testing::Values(1u, 2u, 3u, 4u)),
  [](const auto &info) {
    return std::get<0>(info.param) + "_p" +
           std::to_string(std::get<1>(info.param));
  });


namespace
{
  /**
   * For a broken u_h that is not a dG solution (a smooth function with
   * cellwise perturbations, so that it jumps), with residual R_i = (f,
   * psi_i) + G_h(psi_i) - A_h(u_h, psi_i) and its representation r_h = M^{-1}
   * R (cellwise), reconstruct the flux from F = grad_h u_h + epsilon L(u_h)
   * (or without the lifting) and return the largest relative moment
   * (div sigma - (f - r_h), q)_K over the cells and q in Q_p(K).
   */
  double
  dg_equilibration_defect(const std::string &name,
                          const unsigned int p,
                          const std::string &mesh,
                          const bool         with_lifting)
  {
    Triangulation<2> tria;
    GridGenerator::hyper_cube(tria);
    tria.refine_global(3);
    if (mesh == "distorted")
      GridTools::distort_random(0.2, tria, true, 42);
    if (mesh == "locally-refined")
      // two levels of refinement towards the corner (0, 0): hanging nodes
      // on faces whose neighbours are refined once and twice
      for (const double radius : {0.5, 0.25})
        {
          for (const auto &cell : tria.active_cell_iterators())
            if (cell->center().norm() < radius)
              cell->set_refine_flag();
          tria.execute_coarsening_and_refinement();
        }
    MappingQ<2>             mapping(1);
    FE_DGQArbitraryNodes<2> fe(QGaussLobatto<1>(p + 1));
    DoFHandler<2>           dofs(tria);
    dofs.distribute_dofs(fe);
    FE_Q<2>       fe_continuous(p);
    DoFHandler<2> continuous(tria);
    continuous.distribute_dofs(fe_continuous);

    const auto      penalty = method(name, p);
    const Load      f;
    const Smooth    g;
    const QGauss<2> quadrature(VI::FluxReconstruction<2>::quadrature_points(p));
    const QGauss<1> face_quadrature(
      VI::FluxReconstruction<2>::quadrature_points(p));
    Vector<double> u(dofs.n_dofs());
    VectorTools::interpolate(mapping, dofs, g, u);
    std::vector<types::global_dof_index> local(fe.n_dofs_per_cell());
    for (const auto &cell : dofs.active_cell_iterators())
      {
        cell->get_dof_indices(local);
        for (unsigned int i = 0; i < local.size(); ++i)
          u(local[i]) += 0.01 * std::sin(cell->active_cell_index() + 0.3 * i);
      }

    DGSystem system =
      assemble(penalty, mapping, dofs, quadrature, face_quadrature, f, g);
    Vector<double> R(system.rhs), Au(dofs.n_dofs());
    system.matrix.vmult(Au, u);
    R -= Au; // R = F - A u
    // r_h = M_K^{-1} R_K with the mass matrix of the same quadrature.
    Vector<double>     r(dofs.n_dofs());
    FEValues<2>        values(mapping,
                       fe,
                       quadrature,
                       update_values | update_gradients |
                         update_quadrature_points | update_JxW_values);
    const unsigned int n = fe.n_dofs_per_cell();
    for (const auto &cell : dofs.active_cell_iterators())
      {
        values.reinit(cell);
        cell->get_dof_indices(local);
        FullMatrix<double> mass(n, n);
        for (const unsigned int q : values.quadrature_point_indices())
          for (unsigned int i = 0; i < n; ++i)
            for (unsigned int j = 0; j < n; ++j)
              mass(i, j) += values.shape_value(i, q) *
                            values.shape_value(j, q) * values.JxW(q);
        mass.gauss_jordan();
        Vector<double> R_K(n), r_K(n);
        for (unsigned int i = 0; i < n; ++i)
          R_K(i) = R(local[i]);
        mass.vmult(r_K, R_K);
        for (unsigned int i = 0; i < n; ++i)
          r(local[i]) = r_K(i);
      }

    const IndexSet                all = complete_index_set(dofs.n_dofs());
    TrilinosWrappers::MPI::Vector u_trilinos(all, MPI_COMM_SELF), lifting;
    for (unsigned int i = 0; i < dofs.n_dofs(); ++i)
      u_trilinos(i) = u(i);
    u_trilinos.compress(VectorOperation::insert);
    VI::JumpLifting<2> lift(mapping, p, quadrature, face_quadrature);
    lift.reinit(tria);
    lift.compute(dofs, u_trilinos, g, lifting);

    VI::FluxReconstruction<2> reconstruction(mapping, p);
    reconstruction.reinit(continuous);
    typename VI::FluxReconstruction<2>::Sources sources;
    sources.make_cell_values = [&]() {
      // per thread (the cells are evaluated concurrently)
      return [&,
              data_values_of =
                std::make_shared<FEValues<2>>(mapping,
                                              fe,
                                              reconstruction.get_quadrature(),
                                              update_values | update_gradients |
                                                update_quadrature_points),
              lifting_values_of =
                std::shared_ptr<FEValues<2>>(lift.make_cell_values()),
              r_values       = std::vector<double>(quadrature.size()),
              lifting_values = std::vector<Tensor<1, 2>>()](
               const auto &cell, auto &flux, auto &source) mutable {
        typename DoFHandler<2>::active_cell_iterator dof_cell(&tria,
                                                              cell->level(),
                                                              cell->index(),
                                                              &dofs);
        FEValues<2> &data_values = *data_values_of;
        data_values.reinit(dof_cell);
        data_values.get_function_gradients(u, flux[0]);
        lift.values(cell, lifting, *lifting_values_of, lifting_values);
        if (with_lifting)
          for (unsigned int q = 0; q < flux[0].size(); ++q)
            flux[0][q] += penalty.symmetry() * lifting_values[q];
        data_values.get_function_values(r, r_values);
        for (unsigned int q = 0; q < flux[0].size(); ++q)
          source[0][q] = f.value(data_values.quadrature_point(q)) - r_values[q];
      };
    };

    // The moments of div sigma - (f - r_h) against Q_p(K).
    return VITest::reconstructed_flux_defect(reconstruction,
                                             sources,
                                             {mapping, quadrature, dofs, f, r},
                                             fe);
  }
} // namespace


class DGFluxReconstruction
    : public ::testing::TestWithParam<
        std::tuple<std::string, unsigned int, std::string>>
{
};


// The patch problems are compatible for a dG function when the flux
// carries the lifting of the jumps (doc/step-membranes.md): div sigma =
// f - r_h in every cell's Q_p moments, also on distorted cells and on
// meshes with hanging nodes (the lifting then integrates over the
// subfaces the assembly integrates over).
TEST_P(DGFluxReconstruction, LiftingOfTheJumpsMakesThePatchProblemsCompatible)
{
  const auto [name, p, mesh] = GetParam();
  const double defect        = dg_equilibration_defect(name, p, mesh, true);
  EXPECT_TRUE(std::isfinite(defect));
  EXPECT_LT(defect, 1e-10) << name << ", p = " << p;
  // Without it, the symmetric and nonsymmetric methods (epsilon != 0) are
  // not in equilibrium; IIPG needs no lifting.
  const double without = dg_equilibration_defect(name, p, mesh, false);
  if (name == "iipg")
    EXPECT_LT(without, 1e-10);
  else
    EXPECT_GT(without, 1e-4);
}


INSTANTIATE_TEST_SUITE_P(
  MethodsDegreesMeshes,
  DGFluxReconstruction,
  ::testing::Combine(
    ::testing::Values("sipg", "nipg", "iipg"),
    ::testing::Values(1u, 2u),
    ::testing::Values("uniform", "distorted", "locally-refined")),
  [](const auto &info) {
    std::string mesh = std::get<2>(info.param);
    std::replace(mesh.begin(), mesh.end(), '-', '_');
    return std::get<0>(info.param) + "_p" +
           std::to_string(std::get<1>(info.param)) + "_" + mesh;
  });


namespace
{
  /// The spaces of the Oswald tests on `tria`: broken and continuous Q_p
  /// on the same nodes, a smooth continuous v (conforming at hanging
  /// nodes), its broken copy, and u (broken) and s (continuous) as the
  /// vectors oswald_interpolation() takes.
  struct OswaldSetting
  {
    OswaldSetting(const Triangulation<2> &tria, const unsigned int p)
        : fe(QGaussLobatto<1>(p + 1))
        , fe_continuous(p)
        , broken(tria)
        , continuous(tria)
    {
      broken.distribute_dofs(fe);
      continuous.distribute_dofs(fe_continuous);
      DoFTools::make_hanging_node_constraints(continuous, hanging_nodes);
      hanging_nodes.close();
      v.reinit(continuous.n_dofs());
      v_broken.reinit(broken.n_dofs());
      VectorTools::interpolate(mapping, continuous, Smooth(), v);
      hanging_nodes.distribute(v);
      FETools::interpolate(continuous, v, broken, v_broken);
      u.reinit(complete_index_set(broken.n_dofs()), MPI_COMM_SELF);
      s.reinit(complete_index_set(continuous.n_dofs()), MPI_COMM_SELF);
      set_u(0.);
    }

    /// u = the broken copy of v plus `perturbation` sin(i) at node i.
    void
    set_u(const double perturbation)
    {
      for (unsigned int i = 0; i < broken.n_dofs(); ++i)
        u(i) = v_broken(i) + perturbation * std::sin(i);
      u.compress(VectorOperation::insert);
    }

    MappingQ<2>                   mapping{1};
    FE_DGQArbitraryNodes<2>       fe;
    FE_Q<2>                       fe_continuous;
    DoFHandler<2>                 broken, continuous;
    AffineConstraints<double>     hanging_nodes;
    Vector<double>                v, v_broken;
    TrilinosWrappers::MPI::Vector u, s;
  };
} // namespace


// The Oswald interpolate of a continuous Q_p function is that function; the
// data g replace the boundary values.
TEST(OswaldInterpolation, IsTheIdentityOnContinuousFunctions)
{
  for (const unsigned int p : {1u, 2u, 3u})
    {
      Triangulation<2> tria;
      GridGenerator::hyper_cube(tria);
      tria.refine_global(2);
      GridTools::distort_random(0.2, tria, true, 7);
      OswaldSetting o(tria, p);
      VI::oswald_interpolation<2>(
        o.mapping, o.broken, o.u, o.continuous, nullptr, o.s);
      double difference = 0;
      for (unsigned int i = 0; i < o.continuous.n_dofs(); ++i)
        difference = std::max(difference, std::abs(o.s(i) - o.v(i)));
      EXPECT_LT(difference, 1e-13) << "p = " << p;

      const Functions::ConstantFunction<2> g(7.);
      VI::oswald_interpolation(o.mapping, o.broken, o.u, o.continuous, &g, o.s);
      const auto boundary = DoFTools::extract_boundary_dofs(o.continuous);
      for (unsigned int i = 0; i < o.continuous.n_dofs(); ++i)
        EXPECT_NEAR(o.s(i), boundary.is_element(i) ? 7. : o.v(i), 1e-13);
    }
}


// On a mesh with hanging nodes the Oswald interpolate is conforming: the
// average at a hanging node is replaced by the value of the coarse face,
// and a continuous function is still reproduced. Without the constraints
// it is not (the broken perturbation's averages at the hanging nodes stay).
TEST(OswaldInterpolation, IsConformingOnMeshesWithHangingNodes)
{
  for (const unsigned int p : {1u, 2u})
    {
      Triangulation<2> tria;
      GridGenerator::hyper_cube(tria);
      tria.refine_global(2);
      tria.begin_active()->set_refine_flag();
      tria.execute_coarsening_and_refinement();
      OswaldSetting o(tria, p);
      ASSERT_GT(o.hanging_nodes.n_constraints(), 0u);
      const auto max_constraint_violation = [&]() {
        double violation = 0;
        for (unsigned int i = 0; i < o.continuous.n_dofs(); ++i)
          if (o.hanging_nodes.is_constrained(i))
            {
              double value = 0;
              for (const auto &[j, w] :
                   *o.hanging_nodes.get_constraint_entries(i))
                value += w * o.s(j);
              violation = std::max(violation, std::abs(o.s(i) - value));
            }
        return violation;
      };
      // (with or without the constraints)
      const auto interpolate = [&](const bool conforming) {
        VI::oswald_interpolation<2>(o.mapping,
                                    o.broken,
                                    o.u,
                                    o.continuous,
                                    nullptr,
                                    o.s,
                                    nullptr,
                                    conforming ? &o.hanging_nodes : nullptr);
      };
      o.set_u(0.1); // (a broken function)
      interpolate(true);
      EXPECT_LT(max_constraint_violation(), 1e-14) << "p = " << p;
      interpolate(false);
      EXPECT_GT(max_constraint_violation(), 1e-3) << "p = " << p;

      o.set_u(0.);
      interpolate(true);
      for (unsigned int i = 0; i < o.continuous.n_dofs(); ++i)
        EXPECT_NEAR(o.s(i), o.v(i), 1e-13) << "p = " << p;
    }
}
