#include "equilibration_defect.h"

#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace dealii;

namespace VITest
{
  double
  reconstructed_flux_defect(const VI::FluxReconstruction<2> &reconstruction,
                            const VI::FluxReconstruction<2>::Sources &sources,
                            const Residual                           &residual,
                            const FiniteElement<2>                   &test_fe)
  {
    TrilinosWrappers::MPI::Vector sigma;
    reconstruction.reconstruct(sources, {&sigma});

    const Quadrature<2> &quadrature = residual.quadrature;
    const DoFHandler<2> &dofs       = residual.dofs;
    const DoFHandler<2> &flux_dofs  = reconstruction.get_dof_handler();
    FEValues<2>          values(residual.mapping,
                       dofs.get_fe(),
                       quadrature,
                       update_values | update_quadrature_points |
                         update_JxW_values);
    FEValues<2>          test_values(residual.mapping,
                            test_fe,
                            quadrature,
                            update_values);
    FEValues<2>          sigma_values(residual.mapping,
                             flux_dofs.get_fe(),
                             quadrature,
                             update_gradients);
    const FEValuesExtractors::Vector sigma_extractor(0);
    std::vector<double>              divergence(quadrature.size()),
      r_at_q(quadrature.size()), target(quadrature.size());
    double defect = 0;
    for (const auto &cell : dofs.active_cell_iterators())
      {
        values.reinit(cell);
        test_values.reinit(cell);
        sigma_values.reinit(typename DoFHandler<2>::active_cell_iterator(
          &dofs.get_triangulation(), cell->level(), cell->index(), &flux_dofs));
        sigma_values[sigma_extractor].get_function_divergences(sigma,
                                                               divergence);
        values.get_function_values(residual.r, r_at_q);

        double size = 0; // |f - r_h|_K^2
        for (const unsigned int q : values.quadrature_point_indices())
          {
            target[q] =
              residual.f.value(values.quadrature_point(q)) - r_at_q[q];
            size += std::pow(target[q], 2) * values.JxW(q);
          }
        for (unsigned int i = 0; i < test_fe.n_dofs_per_cell(); ++i)
          {
            double moment = 0, q_norm = 0;
            for (const unsigned int q : values.quadrature_point_indices())
              {
                moment += (divergence[q] - target[q]) *
                          test_values.shape_value(i, q) * values.JxW(q);
                q_norm +=
                  std::pow(test_values.shape_value(i, q), 2) * values.JxW(q);
              }
            defect =
              std::max(defect, std::abs(moment) / std::sqrt(size * q_norm));
          }
      }
    return defect;
  }
} // namespace VITest
