// The cellwise flux of step-hho's a posteriori estimate
// (step-hho/cell_flux.h): sigma in RT_p(K) with given normal traces phi on
// the faces, the divergence of a given source in Q_p (its mean is the sum of
// the boundary fluxes), and otherwise closest to -mu grad u. What must hold,
// on a square, a sheared cell and a trapezoid, p = 1, 2, 3:
//  - sigma.n = phi on every face, for phi of degree p - 1 along the face
//    (the numerical fluxes of HHO);
//  - (div sigma - source, q)_K = 0 for every q of Q_p, the constant
//    included (the data are compatible);
//  - a field tau of RT_p(K) is reproduced from its own normal traces,
//    divergence and target -tau: then nothing is left to minimise.
// Without the face step (the face degrees of freedom left at zero) both
// tests fail.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_raviart_thomas.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>

#include <gtest/gtest.h>

#include "../../step-hho/cell_flux.h"

#include <cmath>
#include <string>
#include <vector>

using namespace dealii;
using StepHHO::CellFlux;

namespace
{
  struct Setting
  {
    std::string           name;
    std::vector<Point<2>> vertices; // lexicographic order
  };

  const std::vector<Setting> cells = {
    {"square", {{0, 0}, {0.25, 0}, {0, 0.25}, {0.25, 0.25}}},
    {"sheared", {{0, 0}, {1, 0.2}, {0.4, 0.8}, {1.4, 1.0}}},
    {"trapezoid", {{0, 0}, {1, 0}, {0.2, 0.7}, {0.7, 0.9}}}};

  /// One cell with RT_p, the quadratures of the estimate and a CellFlux.
  struct OneCell
  {
    OneCell(const Setting &setting, const unsigned int p)
        : flux_fe(p)
        , mapping(1)
        , quadrature(p + 3 + (p + 3) % 2)
        , face_quadrature(p + 3 + (p + 3) % 2)
        , dofs(tria)
        , values(mapping,
                 flux_fe,
                 quadrature,
                 update_values | update_gradients | update_quadrature_points |
                   update_JxW_values)
        , face_values(mapping,
                      flux_fe,
                      face_quadrature,
                      update_values | update_quadrature_points |
                        update_normal_vectors | update_JxW_values)
        , legendre(p)
    {
      GridGenerator::general_cell(tria, setting.vertices);
      dofs.distribute_dofs(flux_fe);
      cell = dofs.begin_active();
      values.reinit(cell);
    }

    /// The normal traces of the RT function with coefficients c.
    std::vector<std::vector<double>>
    normal_traces(const Vector<double> &c)
    {
      const FEValuesExtractors::Vector flux(0);
      std::vector<std::vector<double>> phi(4);
      for (const unsigned int f : cell->face_indices())
        {
          face_values.reinit(cell, f);
          for (const unsigned int q : face_values.quadrature_point_indices())
            {
              double value = 0;
              for (unsigned int j = 0; j < c.size(); ++j)
                value += c(j) * (face_values[flux].value(j, q) *
                                 face_values.normal_vector(q));
              phi[f].push_back(value);
            }
        }
      return phi;
    }

    FE_RaviartThomas<2>                 flux_fe;
    MappingQ<2>                         mapping;
    QGauss<2>                           quadrature;
    QGauss<1>                           face_quadrature;
    Triangulation<2>                    tria;
    DoFHandler<2>                       dofs;
    DoFHandler<2>::active_cell_iterator cell;
    FEValues<2>                         values;
    FEFaceValues<2>                     face_values;
    FE_DGQLegendre<2>                   legendre;
  };
} // namespace


// Normal traces of degree p - 1 along each face (position along the face
// through x + 2 y), a source of degree p + 1 made compatible, an arbitrary
// target: sigma takes the traces and the divergence in Q_p exactly.
TEST(HHOCellFlux, TakesTheNormalTracesAndTheDivergence)
{
  const FEValuesExtractors::Vector flux(0);
  for (const Setting &setting : cells)
    for (unsigned int p = 1; p <= 3; ++p)
      {
        SCOPED_TRACE(setting.name + ", p = " + std::to_string(p));
        OneCell                          one(setting, p);
        std::vector<std::vector<double>> phi(4);
        double                           boundary_flux = 0;
        for (const unsigned int f : one.cell->face_indices())
          {
            one.face_values.reinit(one.cell, f);
            for (const unsigned int q :
                 one.face_values.quadrature_point_indices())
              {
                const Point<2> &x = one.face_values.quadrature_point(q);
                const double    t = x[0] + 2 * x[1];
                phi[f].push_back((f + 1.) * (1. + (p > 1 ? 0.7 * t : 0.) +
                                             (p > 2 ? -0.3 * t * t : 0.)));
                boundary_flux += phi[f].back() * one.face_values.JxW(q);
              }
          }
        const unsigned int        n_q = one.quadrature.size();
        std::vector<double>       source(n_q);
        std::vector<Tensor<1, 2>> target(n_q);
        double                    integral = 0, area = 0;
        for (unsigned int q = 0; q < n_q; ++q)
          {
            const Point<2> &x = one.values.quadrature_point(q);
            source[q]         = std::sin(2. * x[0]) + x[1] * x[1] * x[0];
            target[q]         = Tensor<1, 2>({1. + x[1], x[0] * x[0]});
            integral += source[q] * one.values.JxW(q);
            area += one.values.JxW(q);
          }
        for (double &s : source)
          s += (boundary_flux - integral) / area; // compatibility

        CellFlux<2> cell_flux(
          one.mapping, one.flux_fe, one.quadrature, one.face_quadrature, p);
        const Vector<double> sigma =
          cell_flux.compute(one.cell, phi, target, source);

        const auto traces = one.normal_traces(sigma);
        for (unsigned int f = 0; f < 4; ++f)
          for (unsigned int q = 0; q < phi[f].size(); ++q)
            EXPECT_NEAR(traces[f][q], phi[f][q], 1e-11 * (f + 1.));
        for (unsigned int m = 0; m < one.legendre.n_dofs_per_cell(); ++m)
          {
            double defect = 0, scale = 0;
            for (unsigned int q = 0; q < n_q; ++q)
              {
                double divergence = 0;
                for (unsigned int j = 0; j < sigma.size(); ++j)
                  divergence += sigma(j) * one.values[flux].divergence(j, q);
                const double q_m = one.legendre.shape_value(
                  m, one.values.get_quadrature().point(q));
                defect += (divergence - source[q]) * q_m * one.values.JxW(q);
                scale += std::abs(source[q] * q_m) * one.values.JxW(q);
              }
            EXPECT_LT(std::abs(defect), 1e-11 * scale) << "q_" << m;
          }
      }
}


// A field tau of RT_p(K) given its own traces, divergence and the target
// -tau is the minimiser: the coefficients come back.
TEST(HHOCellFlux, ReproducesARaviartThomasField)
{
  const FEValuesExtractors::Vector flux(0);
  for (const Setting &setting : cells)
    for (unsigned int p = 1; p <= 3; ++p)
      {
        SCOPED_TRACE(setting.name + ", p = " + std::to_string(p));
        OneCell        one(setting, p);
        Vector<double> tau(one.flux_fe.n_dofs_per_cell());
        for (unsigned int j = 0; j < tau.size(); ++j)
          tau(j) = std::cos(1. + 3. * j);
        const unsigned int        n_q = one.quadrature.size();
        std::vector<double>       divergence(n_q, 0.);
        std::vector<Tensor<1, 2>> minus_tau(n_q);
        for (unsigned int q = 0; q < n_q; ++q)
          for (unsigned int j = 0; j < tau.size(); ++j)
            {
              divergence[q] += tau(j) * one.values[flux].divergence(j, q);
              minus_tau[q] -= tau(j) * one.values[flux].value(j, q);
            }
        CellFlux<2> cell_flux(
          one.mapping, one.flux_fe, one.quadrature, one.face_quadrature, p);
        const Vector<double> sigma = cell_flux.compute(one.cell,
                                                       one.normal_traces(tau),
                                                       minus_tau,
                                                       divergence);
        for (unsigned int j = 0; j < tau.size(); ++j)
          EXPECT_NEAR(sigma(j), tau(j), 1e-10) << "coefficient " << j;
      }
}
