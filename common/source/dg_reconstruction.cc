#include <deal.II/base/exceptions.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/dg_reconstruction.h>
#include <vi/domain.h>
#include <vi/interior_penalty.h>
#include <vi/same_cell.h>

#include <map>

namespace VI
{
  using namespace dealii;

  template <int dim>
  JumpLifting<dim>::JumpLifting(const Mapping<dim>        &mapping,
                                const unsigned int         degree,
                                const Quadrature<dim>     &cell_quadrature,
                                const Quadrature<dim - 1> &face_quadrature)
      : mapping(mapping)
      , fe(FE_DGQ<dim>(degree), dim)
      , cell_quadrature(cell_quadrature)
      , face_quadrature(face_quadrature)
  {
  }


  template <int dim>
  void
  JumpLifting<dim>::reinit(const Triangulation<dim> &triangulation)
  {
    dof_handler.reinit(triangulation);
    dof_handler.distribute_dofs(fe);
    owned_dofs = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);
  }


  template <int dim>
  std::unique_ptr<FEValues<dim>>
  JumpLifting<dim>::make_cell_values() const
  {
    return std::make_unique<FEValues<dim>>(
      mapping, fe, cell_quadrature, update_values | update_inverse_jacobians);
  }


  template <int dim>
  const DoFHandler<dim> &
  JumpLifting<dim>::get_dof_handler() const
  {
    return dof_handler;
  }


  template <int dim>
  void
  JumpLifting<dim>::compute(const DoFHandler<dim> &broken,
                            const Vector          &u,
                            const Function<dim>   &g,
                            Vector                &lifting,
                            const Domain          *domain) const
  {
    const unsigned int   n = fe.n_dofs_per_cell();
    FEValues<dim>        values(mapping,
                         fe,
                         cell_quadrature,
                         update_values | update_inverse_jacobians |
                           update_JxW_values);
    FEFaceValues<dim>    face_values(mapping,
                                  fe,
                                  face_quadrature,
                                  update_values | update_inverse_jacobians |
                                    update_normal_vectors | update_JxW_values |
                                    update_quadrature_points);
    FESubfaceValues<dim> subface_values(mapping,
                                        fe,
                                        face_quadrature,
                                        update_values |
                                          update_inverse_jacobians |
                                          update_normal_vectors |
                                          update_JxW_values);
    // u_h on both sides of a face, at the same points in the same order.
    FEInterfaceValues<dim> interface(mapping,
                                     broken.get_fe(),
                                     face_quadrature,
                                     update_values);
    FEFaceValues<dim>      boundary_values(mapping,
                                      broken.get_fe(),
                                      face_quadrature,
                                      update_values);

    const unsigned int                   n_face_q = face_quadrature.size();
    std::vector<double>                  here(n_face_q), there(n_face_q);
    FullMatrix<double>                   gram(n, n);
    dealii::Vector<double>               rhs(n), coefficients(n);
    std::vector<types::global_dof_index> dofs(n);

    Vector owned(owned_dofs, dof_handler.get_communicator());
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        if (!cell->is_locally_owned())
          continue;
        const auto broken_cell = same_cell(cell, broken);

        // Gram matrix of V(K): tau_i = J^{-T} e_{c_i} phi_i.
        values.reinit(cell);
        gram = 0;
        for (const unsigned int q : values.quadrature_point_indices())
          {
            const auto  &inverse = values.inverse_jacobian(q);
            const double dx      = values.JxW(q);
            for (unsigned int i = 0; i < n; ++i)
              {
                const unsigned int ci  = fe.system_to_component_index(i).first;
                const double       phi = values.shape_value(i, q) * dx;
                for (unsigned int j = 0; j < n; ++j)
                  {
                    const unsigned int cj =
                      fe.system_to_component_index(j).first;
                    double metric = 0;
                    for (unsigned int d = 0; d < dim; ++d)
                      metric += inverse[ci][d] * inverse[cj][d];
                    gram(i, j) += phi * values.shape_value(j, q) * metric;
                  }
              }
          }

        // The face terms w_F (tau . n, [[u_h]])_F, on the subfaces where
        // the neighbour is refined (the faces of the assembly).
        rhs                       = 0;
        const auto add_face_terms = [&](const FEFaceValuesBase<dim> &face,
                                        const double                 weight) {
          for (unsigned int q = 0; q < n_face_q; ++q)
            {
              const auto           &inverse = face.inverse_jacobian(q);
              const Tensor<1, dim> &normal  = face.normal_vector(q);
              const double          jump_dx =
                weight * (here[q] - there[q]) * face.JxW(q);
              for (unsigned int i = 0; i < n; ++i)
                {
                  const unsigned int ci = fe.system_to_component_index(i).first;
                  double             tau_n = 0;
                  for (unsigned int d = 0; d < dim; ++d)
                    tau_n += inverse[ci][d] * normal[d];
                  rhs(i) += face.shape_value(i, q) * tau_n * jump_dx;
                }
            }
        };
        for (const unsigned int f : cell->face_indices())
          if (cell->at_boundary(f))
            {
              if (domain && !domain->is_clamped(cell->face(f)->boundary_id()))
                continue; // (free: no jump to lift)
              boundary_values.reinit(broken_cell, f);
              boundary_values.get_function_values(u, here);
              face_values.reinit(cell, f);
              for (unsigned int q = 0; q < n_face_q; ++q)
                there[q] = g.value(face_values.quadrature_point(q));
              add_face_terms(face_values, 1.);
            }
          else
            InteriorPenalty::for_each_face_part<dim>(
              interface, broken_cell, f, [&](const unsigned int subface) {
                interface.get_fe_face_values(0).get_function_values(u, here);
                interface.get_fe_face_values(1).get_function_values(u, there);
                if (subface == numbers::invalid_unsigned_int)
                  {
                    face_values.reinit(cell, f);
                    add_face_terms(face_values, 0.5);
                  }
                else
                  {
                    subface_values.reinit(cell, f, subface);
                    add_face_terms(subface_values, 0.5);
                  }
              });

        gram.gauss_jordan();
        gram.vmult(coefficients, rhs);
        cell->get_dof_indices(dofs);
        for (unsigned int i = 0; i < n; ++i)
          owned(dofs[i]) = coefficients(i);
      }
    owned.compress(VectorOperation::insert);
    lifting.reinit(owned_dofs, relevant_dofs, dof_handler.get_communicator());
    lifting = owned;
  }


  template <int dim>
  void
  JumpLifting<dim>::values(const CellIterator          &cell,
                           const Vector                &lifting,
                           FEValues<dim>               &cell_values,
                           std::vector<Tensor<1, dim>> &result) const
  {
    const auto dof_cell = same_cell(cell, dof_handler);
    cell_values.reinit(dof_cell);
    std::vector<dealii::Vector<double>> reference(cell_quadrature.size(),
                                                  dealii::Vector<double>(dim));
    cell_values.get_function_values(lifting, reference);
    result.resize(cell_quadrature.size());
    for (unsigned int q = 0; q < cell_quadrature.size(); ++q)
      {
        const auto &inverse = cell_values.inverse_jacobian(q);
        result[q]           = Tensor<1, dim>();
        for (unsigned int d = 0; d < dim; ++d)
          for (unsigned int e = 0; e < dim; ++e)
            result[q][d] += inverse[e][d] * reference[q](e);
      }
  }


  template <int dim>
  void
  oswald_interpolation(const Mapping<dim>                  &mapping,
                       const DoFHandler<dim>               &broken,
                       const TrilinosWrappers::MPI::Vector &u,
                       const DoFHandler<dim>               &continuous,
                       const Function<dim>                 *g,
                       TrilinosWrappers::MPI::Vector       &s,
                       const Domain                        *domain,
                       const AffineConstraints<double>     *hanging_nodes)
  {
    const auto &fe_broken     = broken.get_fe();
    const auto &fe_continuous = continuous.get_fe();
    const auto &points_broken = fe_broken.get_unit_support_points();
    const auto &points_cont   = fe_continuous.get_unit_support_points();
    AssertThrow(points_broken.size() == points_cont.size(),
                ExcMessage("The broken and continuous elements must have the "
                           "same nodes."));
    // Local node of the continuous element -> local node of the broken one.
    std::vector<unsigned int> match(points_cont.size(),
                                    numbers::invalid_unsigned_int);
    for (unsigned int j = 0; j < points_cont.size(); ++j)
      for (unsigned int k = 0; k < points_broken.size(); ++k)
        if (points_cont[j].distance(points_broken[k]) < 1e-10)
          match[j] = k;
    for (const unsigned int k : match)
      AssertThrow(k != numbers::invalid_unsigned_int,
                  ExcMessage("The broken and continuous elements must have "
                             "the same nodes."));

    const IndexSet           &owned = continuous.locally_owned_dofs();
    std::vector<double>       sum(owned.n_elements(), 0.);
    std::vector<unsigned int> count(owned.n_elements(), 0);
    std::vector<types::global_dof_index> cont_dofs(points_cont.size()),
      broken_dofs(points_broken.size());
    for (const auto &cell : continuous.active_cell_iterators())
      {
        if (cell->is_artificial())
          continue;
        const auto broken_cell = same_cell(cell, broken);
        cell->get_dof_indices(cont_dofs);
        broken_cell->get_dof_indices(broken_dofs);
        for (unsigned int j = 0; j < cont_dofs.size(); ++j)
          if (owned.is_element(cont_dofs[j]))
            {
              const auto position = owned.index_within_set(cont_dofs[j]);
              sum[position] += u(broken_dofs[match[j]]);
              ++count[position];
            }
      }
    for (std::size_t k = 0; k < sum.size(); ++k)
      s(owned.nth_index_in_set(k)) = sum[k] / std::max(count[k], 1u);

    if (g)
      {
        std::map<types::global_dof_index, double> boundary;
        for (const types::boundary_id id :
             continuous.get_triangulation().get_boundary_ids())
          if (domain == nullptr || domain->is_clamped(id))
            VectorTools::interpolate_boundary_values(
              mapping, continuous, id, *g, boundary);
        for (const auto &[i, value] : boundary)
          if (owned.is_element(i))
            s(i) = value;
      }
    s.compress(VectorOperation::insert);
    if (hanging_nodes)
      hanging_nodes->distribute(s);
  }


  template class JumpLifting<2>;
  template void
  oswald_interpolation(const Mapping<2> &,
                       const DoFHandler<2> &,
                       const TrilinosWrappers::MPI::Vector &,
                       const DoFHandler<2> &,
                       const Function<2> *,
                       TrilinosWrappers::MPI::Vector &,
                       const Domain *,
                       const AffineConstraints<double> *);
} // namespace VI
