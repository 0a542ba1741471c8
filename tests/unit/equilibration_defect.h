// The check that the tests of the flux reconstructions (conforming and
// dG) share: the reconstructed flux is equilibrated, div sigma = f - r_h,
// in the moments of a discrete space on every cell.
#pragma once

#include <deal.II/base/function.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/vector.h>

#include <vi/flux_reconstruction.h>

namespace VITest
{
  /// What the flux must balance: the load f minus r_h, the representation
  /// of the discrete residual (the function r on dofs), integrated with
  /// `quadrature` on `mapping`.
  struct Residual
  {
    const dealii::Mapping<2>     &mapping;
    const dealii::Quadrature<2>  &quadrature;
    const dealii::DoFHandler<2>  &dofs;
    const dealii::Function<2>    &f;
    const dealii::Vector<double> &r;
  };

  /// Reconstruct sigma from `sources` and return the largest relative defect
  /// of its moments over the cells K and the shape functions q of `test_fe`:
  /// |(div sigma - (f - r_h), q)_K| / (|f - r_h|_K |q|_K). On non-affine
  /// cells div sigma is not in the mapped discrete space, so the moments,
  /// not the functions, must agree.
  double
  reconstructed_flux_defect(const VI::FluxReconstruction<2> &reconstruction,
                            const VI::FluxReconstruction<2>::Sources &sources,
                            const Residual                           &residual,
                            const dealii::FiniteElement<2>           &test_fe);
} // namespace VITest
