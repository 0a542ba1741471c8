// Divergences of Raviart-Thomas functions from the reference divergences
// and the signs read off the values: the same as FEValues' divergences
// (from the full Piola gradients) on curved, distorted cells whose
// interior faces are seen with both orientations, and the divergence
// moments (div tau_i, q_k)_K independent of the geometry.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_raviart_thomas.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>

#include <vi/piola_divergence.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace dealii;

namespace
{
  /// RT_degree on the disk of five cells, refined twice and distorted (with
  /// `hanging`: its right part refined twice more), and the Gauss rule of
  /// degree + 3 points per direction. The disk has interior faces with
  /// neighbours on faces 0 or 1 as well as 2 or 3, so both signs occur; the
  /// distortion makes the cells non-affine on top of the curved boundary.
  struct RaviartThomasOnDisk
  {
    RaviartThomasOnDisk(const unsigned int degree, const bool hanging)
        : fe(degree)
        , quadrature(degree + 3)
    {
      GridGenerator::hyper_ball(tria);
      tria.refine_global(2);
      GridTools::distort_random(0.2, tria, /*keep_boundary=*/true, 7);
      if (hanging)
        for (unsigned int step = 0; step < 2; ++step)
          {
            for (const auto &cell : tria.active_cell_iterators())
              if (cell->center()[0] > 0.1)
                cell->set_refine_flag();
            tria.execute_coarsening_and_refinement();
          }
      dof_handler.reinit(tria);
      dof_handler.distribute_dofs(fe);
    }

    Triangulation<2>          tria;
    const FE_RaviartThomas<2> fe;
    const QGauss<2>           quadrature;
    DoFHandler<2>             dof_handler;
  };


  void
  compare_with_fevalues(const unsigned int degree)
  {
    const RaviartThomasOnDisk disk(degree, false);
    const auto               &fe         = disk.fe;
    const auto               &quadrature = disk.quadrature;
    const MappingQ<2>         mapping(3);
    const FE_DGQ<2>           fe_q(degree);

    FEValues<2>                      values(mapping,
                       fe,
                       quadrature,
                       VI::PiolaDivergence<2>::update_flags() |
                         update_gradients);
    VI::PiolaDivergence<2>           divergence(fe, quadrature);
    const FEValuesExtractors::Vector flux(0);

    unsigned int        n_negative = 0;
    double              largest = 0, difference = 0, moment_difference = 0;
    std::vector<double> coefficients(fe.n_dofs_per_cell()),
      expected(quadrature.size()), computed;
    for (const auto &cell : disk.dof_handler.active_cell_iterators())
      {
        values.reinit(cell);
        divergence.reinit(values);
        for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
          {
            n_negative += divergence.sign(i) < 0;
            for (unsigned int q = 0; q < quadrature.size(); ++q)
              {
                const double d = values[flux].divergence(i, q);
                largest        = std::max(largest, std::abs(d));
                difference =
                  std::max(difference,
                           std::abs(d - divergence.shape_divergence(i, q)));
              }
            // (div tau_i, q_k)_K = s_i (div^ tau^_i, q^_k)
            for (unsigned int k = 0; k < fe_q.n_dofs_per_cell(); ++k)
              {
                double physical = 0, reference = 0;
                for (unsigned int q = 0; q < quadrature.size(); ++q)
                  {
                    const double q_k = fe_q.shape_value(k, quadrature.point(q));
                    physical +=
                      values[flux].divergence(i, q) * q_k * values.JxW(q);
                    reference += divergence.reference_divergence(i, q) * q_k *
                                 quadrature.weight(q);
                  }
                moment_difference =
                  std::max(moment_difference,
                           std::abs(physical - divergence.sign(i) * reference));
              }
          }
        // a combination
        for (unsigned int i = 0; i < coefficients.size(); ++i)
          coefficients[i] = std::cos(1. + i + cell->active_cell_index());
        std::fill(expected.begin(), expected.end(), 0.);
        for (unsigned int q = 0; q < quadrature.size(); ++q)
          for (unsigned int i = 0; i < coefficients.size(); ++i)
            expected[q] += coefficients[i] * values[flux].divergence(i, q);
        divergence.function_divergences(make_array_view(coefficients),
                                        computed);
        for (unsigned int q = 0; q < quadrature.size(); ++q)
          difference =
            std::max(difference, std::abs(expected[q] - computed[q]));
      }
    EXPECT_GT(n_negative, 0u) << "the mesh should exercise both signs";
    EXPECT_LT(difference, 1e-10 * largest);
    EXPECT_LT(moment_difference, 1e-10 * largest);
  }
} // namespace


TEST(PiolaDivergence, AgreesWithFEValuesForRT1)
{
  compare_with_fevalues(1);
}

TEST(PiolaDivergence, AgreesWithFEValuesForRT2)
{
  compare_with_fevalues(2);
}


// The signs from the mesh alone (PiolaDivergence::topological_signs) are
// those FEValues applies, and the values from the reference functions with
// those signs and the Jacobians of another element's FEValues are FEValues'
// values: on the curved, distorted disk and on a mesh with hanging nodes
// (coarser and finer neighbours), for RT_1 and RT_2.
TEST(PiolaDivergence, SignsFromTheMeshAndValuesFromTheReference)
{
  for (const bool hanging : {false, true})
    for (const unsigned int degree : {1u, 2u})
      {
        const RaviartThomasOnDisk disk(degree, hanging);
        const auto               &fe         = disk.fe;
        const auto               &quadrature = disk.quadrature;
        const MappingQ<2>         mapping(2);
        const FE_DGQ<2>           fe_geometry(1);
        FEValues<2>               values(mapping,
                           fe,
                           quadrature,
                           VI::PiolaDivergence<2>::update_flags());
        FEValues<2>               geometry(mapping,
                             fe_geometry,
                             quadrature,
                             update_jacobians | update_JxW_values);
        VI::PiolaDivergence<2>    from_values(fe, quadrature),
          from_reference(fe, quadrature);
        const FEValuesExtractors::Vector flux(0);
        std::vector<std::int8_t>         signs(fe.n_dofs_per_cell());
        std::vector<double>              coefficients(fe.n_dofs_per_cell());
        std::vector<Tensor<1, 2>>        expected(quadrature.size()), computed;
        std::vector<double>              divergences;
        unsigned int                     n_negative = 0, n_differ = 0;
        double                           difference = 0, largest = 0;
        for (const auto &cell : disk.dof_handler.active_cell_iterators())
          {
            values.reinit(cell);
            from_values.reinit(values);
            VI::PiolaDivergence<2>::topological_signs(cell,
                                                      fe,
                                                      make_array_view(signs));
            for (unsigned int i = 0; i < signs.size(); ++i)
              {
                n_negative += signs[i] < 0;
                n_differ += signs[i] != from_values.sign(i);
              }
            geometry.reinit(cell);
            from_reference.reinit(geometry, make_array_view(signs));
            for (unsigned int i = 0; i < coefficients.size(); ++i)
              coefficients[i] = std::sin(2. + i + cell->active_cell_index());
            values[flux].get_function_values_from_local_dof_values(coefficients,
                                                                   expected);
            from_reference.function_values_and_divergences(
              make_array_view(coefficients), computed, divergences);
            for (unsigned int q = 0; q < quadrature.size(); ++q)
              {
                largest = std::max(largest, expected[q].norm());
                difference =
                  std::max(difference, (expected[q] - computed[q]).norm());
              }
          }
        EXPECT_GT(n_negative, 0u) << "the mesh should exercise both signs";
        EXPECT_EQ(n_differ, 0u)
          << "p = " << degree << (hanging ? ", hanging nodes" : "");
        EXPECT_LT(difference, 1e-10 * largest);
      }
}
