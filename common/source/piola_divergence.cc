#include <deal.II/grid/cell_id.h>
#include <deal.II/grid/tria.h>

#include <vi/piola_divergence.h>

#include <cmath>
#include <optional>

namespace VI
{
  using namespace dealii;

  template <int dim>
  PiolaDivergence<dim>::PiolaDivergence(const FiniteElement<dim> &fe,
                                        const Quadrature<dim>    &quadrature)
      : reference(quadrature.size(), fe.n_dofs_per_cell())
      , reference_values(quadrature.size(), fe.n_dofs_per_cell())
      , piola(quadrature.size())
      , weights(quadrature.get_weights())
      , probe(fe.n_dofs_per_cell(), 0)
      , probe_value(fe.n_dofs_per_cell())
      , signs(fe.n_dofs_per_cell(), 1.)
      , scale(quadrature.size(), 0.)
  {
    AssertThrow(fe.n_components() == dim,
                ExcMessage("PiolaDivergence: a vector-valued element with "
                           "dim components is expected."));
    for (unsigned int i = 0; i < fe.n_dofs_per_cell(); ++i)
      {
        double largest = -1;
        for (unsigned int q = 0; q < quadrature.size(); ++q)
          {
            const Point<dim> &x = quadrature.point(q);
            Tensor<1, dim>    value;
            double            divergence = 0;
            for (unsigned int d = 0; d < dim; ++d)
              {
                value[d] = fe.shape_value_component(i, x, d);
                divergence += fe.shape_grad_component(i, x, d)[d];
              }
            reference(q, i)        = divergence;
            reference_values(q, i) = value;
            if (value.norm() > largest)
              {
                largest        = value.norm();
                probe[i]       = q;
                probe_value[i] = value;
              }
          }
        AssertThrow(largest > 0,
                    ExcMessage("PiolaDivergence: a shape function vanishes "
                               "at every quadrature point."));
      }
  }


  template <int dim>
  void
  PiolaDivergence<dim>::reinit(const FEValuesBase<dim> &values)
  {
    AssertDimension(values.n_quadrature_points, scale.size());
    AssertDimension(values.dofs_per_cell, signs.size());
    for (unsigned int q = 0; q < scale.size(); ++q)
      scale[q] = weights[q] / values.JxW(q);
    // The unsigned Piola image of tau^_i at its probe point against the
    // value FEValues computed: equal up to the sign s_i.
    for (unsigned int i = 0; i < signs.size(); ++i)
      {
        const unsigned int q       = probe[i];
        const auto        &J       = values.jacobian(q);
        double             product = 0;
        for (unsigned int d = 0; d < dim; ++d)
          {
            double mapped = 0;
            for (unsigned int e = 0; e < dim; ++e)
              mapped += J[d][e] * probe_value[i][e];
            product += mapped * values.shape_value_component(i, q, d);
          }
        signs[i] = product >= 0 ? 1. : -1.;
      }
  }


  template <int dim>
  void
  PiolaDivergence<dim>::reinit(const FEValuesBase<dim>            &geometry,
                               const ArrayView<const std::int8_t> &cell_signs)
  {
    AssertDimension(geometry.n_quadrature_points, scale.size());
    AssertDimension(cell_signs.size(), signs.size());
    for (unsigned int q = 0; q < scale.size(); ++q)
      {
        scale[q] = weights[q] / geometry.JxW(q);
        piola[q] = scale[q] * Tensor<2, dim>(geometry.jacobian(q));
      }
    for (unsigned int i = 0; i < signs.size(); ++i)
      signs[i] = cell_signs[i];
  }


  template <int dim>
  void
  PiolaDivergence<dim>::function_values_and_divergences(
    const ArrayView<const double> &coefficients,
    std::vector<Tensor<1, dim>>   &function_values,
    std::vector<double>           &divergences) const
  {
    AssertDimension(coefficients.size(), signs.size());
    function_values.resize(scale.size());
    divergences.resize(scale.size());
    for (unsigned int q = 0; q < scale.size(); ++q)
      {
        Tensor<1, dim> value;
        double         divergence = 0;
        for (unsigned int i = 0; i < signs.size(); ++i)
          {
            const double c = signs[i] * coefficients[i];
            value += c * reference_values(q, i);
            divergence += c * reference(q, i);
          }
        function_values[q] = piola[q] * value;
        divergences[q]     = divergence * scale[q];
      }
  }


  template <int dim>
  void
  PiolaDivergence<dim>::topological_signs(
    const typename Triangulation<dim>::cell_iterator &cell,
    const FiniteElement<dim>                         &fe,
    const ArrayView<std::int8_t>                     &cell_signs)
  {
    static_assert(dim == 2, "the sign rule is that of deal.II in 2d");
    AssertDimension(cell_signs.size(), fe.n_dofs_per_cell());
    std::fill(cell_signs.begin(), cell_signs.end(), 1);
    std::optional<CellId> id;
    for (const unsigned int f : cell->face_indices())
      if (!cell->at_boundary(f) && (cell->neighbor_face_no(f) + f) % 2 == 0)
        {
          if (!id)
            id = cell->id();
          if (*id < cell->neighbor(f)->id())
            for (unsigned int j = 0; j < fe.n_dofs_per_face(f); ++j)
              cell_signs[fe.face_to_cell_index(j, f)] = -1;
        }
  }


  template <int dim>
  void
  PiolaDivergence<dim>::function_divergences(
    const ArrayView<const double> &coefficients,
    std::vector<double>           &divergences) const
  {
    AssertDimension(coefficients.size(), signs.size());
    divergences.resize(scale.size());
    for (unsigned int q = 0; q < scale.size(); ++q)
      {
        double divergence = 0;
        for (unsigned int i = 0; i < signs.size(); ++i)
          divergence += signs[i] * coefficients[i] * reference(q, i);
        divergences[q] = divergence * scale[q];
      }
  }


  template class PiolaDivergence<2>;
} // namespace VI
