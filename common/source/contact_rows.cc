#include <deal.II/base/mpi.h>

#include <vi/contact_rows.h>
#include <vi/nodal_fields.h>

#include <cmath>
#include <limits>

namespace VI
{
  using namespace dealii;
  using NodalFields::n_fields;

  void
  ContactRows::reinit(const IndexSet                  &owned_nodes,
                      const AffineConstraints<double> &u1_constraints)
  {
    node_indices.clear();
    positions.clear();
    std::size_t k = 0;
    for (const types::global_dof_index i : owned_nodes)
      {
        if (!u1_constraints.is_constrained(i))
          {
            node_indices.push_back(i);
            positions.push_back(k);
          }
        ++k;
      }
  }


  const std::vector<types::global_dof_index> &
  ContactRows::nodes() const
  {
    return node_indices;
  }


  const std::vector<std::size_t> &
  ContactRows::local_positions() const
  {
    return positions;
  }


  double
  ContactRows::evaluate(const ComplementarityFunction       &C,
                        const TrilinosWrappers::MPI::Vector &X,
                        const double                         multiplier_scale,
                        TrilinosWrappers::MPI::Vector       &R) const
  {
    const double *x = X.begin();
    double       *r = R.begin();

    double local_scales[2] = {0., 0.};
    for (const std::size_t k : positions)
      {
        local_scales[0] = std::max({local_scales[0],
                                    std::abs(x[n_fields * k]),
                                    std::abs(x[n_fields * k + 1])});
        local_scales[1] =
          std::max(local_scales[1], std::abs(x[n_fields * k + 2]));
      }
    double scales[2];
    Utilities::MPI::max(ArrayView<const double>(local_scales, 2),
                        X.get_mpi_communicator(),
                        ArrayView<double>(scales, 2));
    const double tiny = std::numeric_limits<double>::min();
    const double U    = std::max(scales[0], tiny);
    const double B    = std::max({scales[1], multiplier_scale, tiny});

    double residual = 0, not_a_number = 0;
    for (const std::size_t k : positions)
      {
        const double a      = x[n_fields * k] - x[n_fields * k + 1];
        const double b      = x[n_fields * k + 2];
        r[n_fields * k + 2] = C.value(a, b);
        const double scaled = std::abs(C.value(a / U, b / B));
        if (std::isnan(scaled))
          not_a_number = 1;
        else
          residual = std::max(residual, scaled);
      }
    double local[2] = {residual, not_a_number}, global[2];
    Utilities::MPI::max(ArrayView<const double>(local, 2),
                        X.get_mpi_communicator(),
                        ArrayView<double>(global, 2));
    return global[1] > 0 ? std::numeric_limits<double>::quiet_NaN() : global[0];
  }


  void
  ContactRows::set_jacobian_rows(const ComplementarityFunction       &C,
                                 const TrilinosWrappers::MPI::Vector &X,
                                 TrilinosWrappers::SparseMatrix      &A,
                                 const std::vector<double> &weights) const
  {
    const double *x = X.begin();
    for (std::size_t n = 0; n < node_indices.size(); ++n)
      {
        const std::size_t k = positions[n];
        const double      a = x[n_fields * k] - x[n_fields * k + 1];
        const double      b = x[n_fields * k + 2];
        const auto        g = C.generalized_gradient(a, b);

        const types::global_dof_index i          = node_indices[n];
        const types::global_dof_index columns[3] = {
          NodalFields::index(i, NodalFields::u1),
          NodalFields::index(i, NodalFields::u2),
          NodalFields::index(i, NodalFields::multiplier)};
        const double w         = weights.empty() ? 1. : weights[n];
        const double values[3] = {w * g[0], -w * g[0], w * g[1]};
        A.set(columns[2], 3, columns, values, /*elide_zero_values=*/false);
      }
  }


  std::vector<double>
  ContactRows::row_weights(const ComplementarityFunction       &C,
                           const TrilinosWrappers::MPI::Vector &X,
                           const std::vector<double> &stiffness_weight,
                           const std::vector<double> &multiplier_weight) const
  {
    const double       *x = X.begin();
    std::vector<double> weights(positions.size());
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        const std::size_t k = positions[n];
        const auto        g =
          C.generalized_gradient(x[n_fields * k] - x[n_fields * k + 1],
                                 x[n_fields * k + 2]);
        weights[n] = std::abs(g[0]) >= std::abs(g[1]) ? stiffness_weight[k] :
                                                        multiplier_weight[k];
      }
    return weights;
  }


  ActiveSetChange
  ContactRows::linearised_active_set(const ComplementarityFunction       &C,
                                     const TrilinosWrappers::MPI::Vector &X,
                                     std::vector<bool> &active,
                                     const bool         compare) const
  {
    AssertThrow(!compare || active.size() == positions.size(),
                ExcMessage("ContactRows: the previous active set belongs to "
                           "another mesh."));
    active.resize(positions.size());
    const double      *x        = X.begin();
    unsigned long long local[2] = {0, 0};
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        const std::size_t k = positions[n];
        const auto        g =
          C.generalized_gradient(x[n_fields * k] - x[n_fields * k + 1],
                                 x[n_fields * k + 2]);
        const bool is_active = std::abs(g[0]) >= std::abs(g[1]);
        local[0] += is_active;
        local[1] += compare && is_active != active[n];
        active[n] = is_active;
      }
    unsigned long long global[2];
    Utilities::MPI::sum(ArrayView<const unsigned long long>(local, 2),
                        X.get_mpi_communicator(),
                        ArrayView<unsigned long long>(global, 2));
    return {global[0], global[1]};
  }


  types::global_dof_index
  ContactRows::contact_set(const TrilinosWrappers::MPI::Vector &X,
                           TrilinosWrappers::MPI::Vector       &indicator) const
  {
    const double *x   = X.begin();
    double       *ind = indicator.begin();
    std::fill(ind, ind + indicator.locally_owned_size(), 0.);
    types::global_dof_index n_contact = 0;
    for (const std::size_t k : positions)
      if (x[n_fields * k] - x[n_fields * k + 1] <= x[n_fields * k + 2])
        {
          ind[k] = 1.;
          ++n_contact;
        }
    return Utilities::MPI::sum(n_contact, X.get_mpi_communicator());
  }
} // namespace VI
