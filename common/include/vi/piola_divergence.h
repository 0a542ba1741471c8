#pragma once

#include <deal.II/base/array_view.h>
#include <deal.II/base/quadrature.h>
#include <deal.II/base/table.h>
#include <deal.II/base/tensor.h>
#include <deal.II/fe/fe.h>
#include <deal.II/fe/fe_update_flags.h>
#include <deal.II/fe/fe_values.h>

#include <cstdint>
#include <vector>

namespace VI
{
  /**
   * Divergences of Raviart-Thomas functions without their gradients.
   *
   * FE_RaviartThomas maps a reference function tau^ by the contravariant
   * Piola transform, tau = s J tau^ / det J, with s = +1 or -1 (deal.II
   * flips the face functions on one side of every interior face so that
   * normal components agree). Then div tau = s div^ tau^ / det J: at a
   * quadrature point, div tau_i = s_i div^ tau^_i(x^_q) w_q / JxW_q, and
   * (div tau_i, q)_K = s_i (div^ tau^_i, q^) on the reference cell for
   * q = q^ o F^-1: the divergence block of a mixed method does not depend
   * on the geometry. FEValues computes divergences from the full gradients,
   * which on curved cells need the derivatives of the Jacobian; here the
   * reference divergences are tabulated once and a cell needs only the
   * values FEValues computes anyway, from which the signs s_i are read.
   *
   * Where the signs are known (FluxReconstruction reads them once per
   * mesh), the values need no Raviart-Thomas FEValues either: tau_i(x_q) =
   * s_i J_q tau^_i(x^_q) / det J_q from the tabulated reference values and
   * the Jacobians of any FEValues on the same quadrature (reinit() with the
   * signs, then function_values_and_divergences() with the coefficients).
   */
  template <int dim>
  class PiolaDivergence
  {
  public:
    /// What the FEValues handed to reinit() must compute.
    static dealii::UpdateFlags
    update_flags()
    {
      return dealii::update_values | dealii::update_jacobians |
             dealii::update_JxW_values;
    }

    PiolaDivergence(const dealii::FiniteElement<dim> &fe,
                    const dealii::Quadrature<dim>    &quadrature);

    /// Signs and 1 / det J of the cell of `values` (of the element and
    /// quadrature of the constructor, with update_flags()).
    void
    reinit(const dealii::FEValuesBase<dim> &values);

    /// The signs s_i of the Raviart-Thomas element `fe` on `cell` from the
    /// mesh alone, by the rule of deal.II 9.4 in 2d: the functions of an
    /// interior face f are flipped when the neighbour sees the face with the
    /// same parity of its number (nn + f even) and the cell precedes the
    /// neighbour in CellId order. The unit test checks it against the signs
    /// read off FEValues on curved, distorted and locally refined meshes, so
    /// that a change of deal.II's convention is caught.
    static void
    topological_signs(
      const typename dealii::Triangulation<dim>::cell_iterator &cell,
      const dealii::FiniteElement<dim>                         &fe,
      const dealii::ArrayView<std::int8_t>                     &cell_signs);

    /// The cell of `geometry` (any FEValues on the quadrature of the
    /// constructor with update_jacobians and update_JxW_values) with the
    /// given signs s_i, for function_values_and_divergences() from
    /// coefficients.
    void
    reinit(const dealii::FEValuesBase<dim>            &geometry,
           const dealii::ArrayView<const std::int8_t> &cell_signs);

    /// s_i of the current cell.
    double
    sign(const unsigned int i) const
    {
      return signs[i];
    }

    /// div tau_i at quadrature point q of the current cell.
    double
    shape_divergence(const unsigned int i, const unsigned int q) const
    {
      return signs[i] * reference(q, i) * scale[q];
    }

    /// (div^ tau^_i)(x^_q) on the reference cell.
    double
    reference_divergence(const unsigned int i, const unsigned int q) const
    {
      return reference(q, i);
    }

    /// div (sum_i c_i tau_i) at the quadrature points of the current cell.
    void
    function_divergences(const dealii::ArrayView<const double> &coefficients,
                         std::vector<double> &divergences) const;

    /// Values and divergences at the quadrature points of the current cell
    /// (that of `values`, reinit()ed) of the function `vector` of a
    /// DoFHandler with this element: its cell coefficients are read once
    /// into `coefficients` (sized to the element's dofs).
    template <class CellIterator, class VectorType>
    void
    function_values_and_divergences(
      const dealii::FEValuesBase<dim>     &values,
      const CellIterator                  &cell,
      const VectorType                    &vector,
      std::vector<double>                 &coefficients,
      std::vector<dealii::Tensor<1, dim>> &function_values,
      std::vector<double>                 &divergences) const
    {
      cell->get_dof_values(vector, coefficients.begin(), coefficients.end());
      values[dealii::FEValuesExtractors::Vector(0)]
        .get_function_values_from_local_dof_values(coefficients,
                                                   function_values);
      function_divergences(dealii::make_array_view(coefficients), divergences);
    }

    /// Values and divergences of sum_i c_i tau_i at the quadrature points of
    /// the current cell, which must have been set by reinit() with signs.
    void
    function_values_and_divergences(
      const dealii::ArrayView<const double> &coefficients,
      std::vector<dealii::Tensor<1, dim>>   &function_values,
      std::vector<double>                   &divergences) const;

  private:
    dealii::Table<2, double> reference; ///< [q][i]
    /// tau^_i(x^_q), [q][i], and J_q / det J_q of the current cell (after
    /// reinit() with signs)
    dealii::Table<2, dealii::Tensor<1, dim>> reference_values;
    std::vector<dealii::Tensor<2, dim>>      piola;
    std::vector<double>                      weights;
    /// for each i, a quadrature point where tau^_i is largest, and its value
    std::vector<unsigned int>           probe;
    std::vector<dealii::Tensor<1, dim>> probe_value;
    std::vector<double>                 signs, scale;
  };
} // namespace VI
