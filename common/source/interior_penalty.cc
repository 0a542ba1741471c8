#include <vi/errors.h>
#include <vi/interior_penalty.h>
#include <vi/spellings.h>

#include <algorithm>
#include <sstream>

namespace VI
{
  InteriorPenalty::InteriorPenalty(const Type         type,
                                   const double       penalty_constant,
                                   const unsigned int degree)
      : SpeltChoice(type)
      , penalty_constant_(penalty_constant)
      , degree_(degree)
  {
    if (!(penalty_constant > 0.))
      {
        std::ostringstream message;
        message << "Discretization/Penalty = " << penalty_constant
                << " must be positive";
        throw InputError(message.str());
      }
    if (degree < 1)
      throw InputError("Discretization/Polynomial degree must be at least 1 "
                       "for the interior penalty methods");
  }


  const Spellings<InteriorPenaltyMethod> &
  InteriorPenalty::spellings()
  {
    static const Spellings<Type> methods = {{Type::sipg, "sipg"},
                                            {Type::nipg, "nipg"},
                                            {Type::iipg, "iipg"}};
    return methods;
  }


  InteriorPenalty
  InteriorPenalty::from_name(const std::string &name,
                             const double       penalty_constant,
                             const unsigned int degree)
  {
    if (const auto type = value_spelt(spellings(), name))
      return InteriorPenalty(*type, penalty_constant, degree);
    throw InputError("Discretization/Method = " + name +
                     " is not an interior penalty method (" + names() + ")");
  }


  std::string
  InteriorPenalty::label() const
  {
    std::string upper = name();
    std::transform(upper.begin(), upper.end(), upper.begin(), ::toupper);
    return upper;
  }


  double
  InteriorPenalty::symmetry() const
  {
    switch (type_)
      {
        case Type::sipg:
          return -1.;
        case Type::nipg:
          return 1.;
        default:
          return 0.;
      }
  }


  double
  InteriorPenalty::penalty_constant() const
  {
    return penalty_constant_;
  }


  unsigned int
  InteriorPenalty::degree() const
  {
    return degree_;
  }


  double
  InteriorPenalty::penalty(const double h_F) const
  {
    return penalty_constant_ * degree_ * (degree_ + 1.) / h_F;
  }


  template <int dim>
  double
  InteriorPenalty::normal_extent(
    const typename dealii::Triangulation<dim>::cell_iterator &cell,
    const unsigned int                                        face,
    const unsigned int                                        subface)
  {
    if (subface != dealii::numbers::invalid_unsigned_int)
      {
        const auto child = cell->neighbor_child_on_subface(face, subface);
        return std::min(cell->measure(), child->measure()) /
               cell->face(face)->child(subface)->measure();
      }
    const double face_measure = cell->face(face)->measure();
    double       volume       = cell->measure();
    if (!cell->at_boundary(face))
      volume = std::min(volume, cell->neighbor(face)->measure());
    return volume / face_measure;
  }


  template <int dim>
  void
  InteriorPenalty::for_each_face_part(
    dealii::FEInterfaceValues<dim>                               &interface,
    const typename dealii::DoFHandler<dim>::active_cell_iterator &cell,
    const unsigned int                                            face,
    const std::function<void(const unsigned int subface)>        &action)
  {
    const unsigned int none     = dealii::numbers::invalid_unsigned_int;
    const auto         neighbor = cell->neighbor(face);
    if (neighbor->has_children())
      for (unsigned int sf = 0; sf < cell->face(face)->n_children(); ++sf)
        {
          interface.reinit(cell,
                           face,
                           sf,
                           cell->neighbor_child_on_subface(face, sf),
                           cell->neighbor_of_neighbor(face),
                           none);
          action(sf);
        }
    else if (cell->neighbor_is_coarser(face))
      {
        const auto [neighbor_face, neighbor_subface] =
          cell->neighbor_of_coarser_neighbor(face);
        interface.reinit(
          cell, face, none, neighbor, neighbor_face, neighbor_subface);
        action(none);
      }
    else
      {
        interface.reinit(
          cell, face, none, neighbor, cell->neighbor_of_neighbor(face), none);
        action(none);
      }
  }


  template <int dim>
  void
  InteriorPenalty::add_cell_matrix(const dealii::FEValuesBase<dim> &values,
                                   dealii::FullMatrix<double>      &matrix)
  {
    const unsigned int n = values.dofs_per_cell;
    for (const unsigned int q : values.quadrature_point_indices())
      for (unsigned int i = 0; i < n; ++i)
        {
          const auto grad_i = values.shape_grad(i, q) * values.JxW(q);
          for (unsigned int j = 0; j < n; ++j)
            matrix(i, j) += grad_i * values.shape_grad(j, q);
        }
  }


  template <int dim>
  void
  InteriorPenalty::add_boundary_matrix(
    const dealii::FEFaceValuesBase<dim> &values,
    const double                         h_F,
    dealii::FullMatrix<double>          &matrix) const
  {
    const double       epsilon = symmetry(), gamma = penalty(h_F);
    const unsigned int n       = values.dofs_per_cell;
    const auto        &normals = values.get_normal_vectors();
    for (const unsigned int q : values.quadrature_point_indices())
      {
        const double dx = values.JxW(q);
        for (unsigned int i = 0; i < n; ++i)
          {
            const double v     = values.shape_value(i, q);
            const double dv_dn = values.shape_grad(i, q) * normals[q];
            for (unsigned int j = 0; j < n; ++j)
              {
                const double u     = values.shape_value(j, q);
                const double du_dn = values.shape_grad(j, q) * normals[q];
                matrix(i, j) +=
                  (-du_dn * v + epsilon * dv_dn * u + gamma * u * v) * dx;
              }
          }
      }
  }


  template <int dim>
  void
  InteriorPenalty::add_boundary_rhs(const dealii::FEFaceValuesBase<dim> &values,
                                    const double                         h_F,
                                    const std::vector<double>           &g,
                                    dealii::Vector<double> &rhs) const
  {
    const double       epsilon = symmetry(), gamma = penalty(h_F);
    const unsigned int n       = values.dofs_per_cell;
    const auto        &normals = values.get_normal_vectors();
    for (const unsigned int q : values.quadrature_point_indices())
      for (unsigned int i = 0; i < n; ++i)
        rhs(i) += (epsilon * values.shape_grad(i, q) * normals[q] +
                   gamma * values.shape_value(i, q)) *
                  g[q] * values.JxW(q);
  }


  template <int dim>
  void
  InteriorPenalty::add_face_matrix(const dealii::FEInterfaceValues<dim> &values,
                                   const double                          h_F,
                                   dealii::FullMatrix<double> &matrix) const
  {
    const double       epsilon = symmetry(), gamma = penalty(h_F);
    const unsigned int n       = values.n_current_interface_dofs();
    const auto        &normals = values.get_normal_vectors();
    for (const unsigned int q : values.quadrature_point_indices())
      {
        const double dx = values.JxW(q);
        for (unsigned int i = 0; i < n; ++i)
          {
            const double jump_v = values.jump_in_shape_values(i, q);
            const double average_dv =
              values.average_of_shape_gradients(i, q) * normals[q];
            for (unsigned int j = 0; j < n; ++j)
              {
                const double jump_u = values.jump_in_shape_values(j, q);
                const double average_du =
                  values.average_of_shape_gradients(j, q) * normals[q];
                matrix(i, j) +=
                  (-average_du * jump_v + epsilon * average_dv * jump_u +
                   gamma * jump_u * jump_v) *
                  dx;
              }
          }
      }
  }


  template void
  InteriorPenalty::for_each_face_part<2>(
    dealii::FEInterfaceValues<2> &,
    const typename dealii::DoFHandler<2>::active_cell_iterator &,
    const unsigned int,
    const std::function<void(const unsigned int)> &);
  template void
  InteriorPenalty::add_cell_matrix(const dealii::FEValuesBase<2> &,
                                   dealii::FullMatrix<double> &);
  template void
  InteriorPenalty::add_boundary_matrix(const dealii::FEFaceValuesBase<2> &,
                                       const double,
                                       dealii::FullMatrix<double> &) const;
  template void
  InteriorPenalty::add_boundary_rhs(const dealii::FEFaceValuesBase<2> &,
                                    const double,
                                    const std::vector<double> &,
                                    dealii::Vector<double> &) const;
  template void
  InteriorPenalty::add_face_matrix(const dealii::FEInterfaceValues<2> &,
                                   const double,
                                   dealii::FullMatrix<double> &) const;
  template double
  InteriorPenalty::normal_extent<2>(
    const typename dealii::Triangulation<2>::cell_iterator &,
    const unsigned int,
    const unsigned int);
} // namespace VI
