#include <deal.II/base/mpi.h>

#include <vi/contact_rows.h>
#include <vi/nodal_fields.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace VI
{
  using namespace dealii;
  using NodalFields::n_fields;

  namespace
  {
    /// The pair (a, b) = (X1 - X2, X3) of the node at local position k.
    std::array<double, 2>
    pair_at(const double *x, const std::size_t k)
    {
      return {{x[n_fields * k] - x[n_fields * k + 1], x[n_fields * k + 2]}};
    }
  } // namespace

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


  std::array<double, 2>
  ContactRows::scales(const TrilinosWrappers::MPI::Vector &X,
                      const double multiplier_scale) const
  {
    const double *x               = X.begin();
    double        local_scales[2] = {0., 0.};
    for (const std::size_t k : positions)
      {
        local_scales[0] = std::max({local_scales[0],
                                    std::abs(x[n_fields * k]),
                                    std::abs(x[n_fields * k + 1])});
        local_scales[1] =
          std::max(local_scales[1], std::abs(x[n_fields * k + 2]));
      }
    double global[2];
    Utilities::MPI::max(ArrayView<const double>(local_scales, 2),
                        X.get_mpi_communicator(),
                        ArrayView<double>(global, 2));
    const double tiny = std::numeric_limits<double>::min();
    return {{std::max(global[0], tiny),
             std::max({global[1], multiplier_scale, tiny})}};
  }


  void
  ContactRows::evaluate(const ComplementarityFunction       &C,
                        const TrilinosWrappers::MPI::Vector &X,
                        const double                         multiplier_scale,
                        TrilinosWrappers::MPI::Vector       &R,
                        ResidualNorms                       &norms) const
  {
    const double *x           = X.begin();
    double       *r           = R.begin();
    const auto [U_now, B_now] = scales(X, multiplier_scale);
    double local[3]           = {0., 0., 0.}; // C, C_mu, NaN
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        const std::size_t k = positions[n];
        const auto [a, b]   = pair_at(x, k);
        if (interior_point)
          {
            const double xs = a / U, ys = b / B;
            r[n_fields * k + 2] = U * (xs * ys - targets[n]) / (xs + ys);
          }
        else
          r[n_fields * k + 2] = row_value(C, a, b);
        const double scaled = std::abs(C.value(a / U_now, b / B_now));
        if (std::isnan(scaled) || std::isnan(r[n_fields * k + 2]))
          local[2] = 1;
        else
          {
            local[0] = std::max(local[0], scaled);
            if (on_path())
              local[1] = std::max(local[1], std::abs(r[n_fields * k + 2]) / U);
          }
      }
    double global[3];
    Utilities::MPI::max(ArrayView<const double>(local, 3),
                        X.get_mpi_communicator(),
                        ArrayView<double>(global, 3));
    const double nan      = std::numeric_limits<double>::quiet_NaN();
    norms.complementarity = global[2] > 0 ? nan : global[0];
    norms.smoothed_complementarity =
      global[2] > 0 ? nan : (on_path() ? global[1] : global[0]);
  }


  void
  ContactRows::set_smoothing(const double                         mu,
                             const TrilinosWrappers::MPI::Vector &X,
                             const double                         gap_stiffness)
  {
    if (mu > 0 && this->mu == 0)
      freeze_scales(X, gap_stiffness);
    else if (mu == 0)
      U = B = 1.;
    this->mu = mu;
  }


  void
  ContactRows::freeze_scales(const TrilinosWrappers::MPI::Vector &X,
                             const double                         gap_stiffness)
  {
    U = scales(X, 0.)[0];
    B = scales(X, path_stiffness_factor * gap_stiffness * U)[1];
  }


  void
  ContactRows::enter_interior_point(TrilinosWrappers::MPI::Vector &X,
                                    const double                   mu2,
                                    const double gap_stiffness)
  {
    freeze_scales(X, gap_stiffness);
    mu             = 0;
    interior_point = true;
    targets.assign(positions.size(), 0.);
    double      *x    = X.begin();
    const double root = std::sqrt(mu2);
    for (const std::size_t k : positions)
      {
        const auto [a, b] = pair_at(x, k);
        // The larger member stays (at least sqrt(mu2)): the crawl's
        // iterate keeps its gaps and its multipliers.
        double x_new = a / U, y_new = b / B;
        if (x_new >= y_new)
          {
            x_new = std::max(x_new, root);
            y_new = mu2 / x_new;
          }
        else
          {
            y_new = std::max(y_new, root);
            x_new = mu2 / y_new;
          }
        const double shift = 0.5 * (x_new * U - a);
        x[n_fields * k] += shift;
        x[n_fields * k + 1] -= shift;
        x[n_fields * k + 2] = y_new * B;
      }
  }


  void
  ContactRows::set_interior_point_targets(
    const TrilinosWrappers::MPI::Vector *dX,
    const double                         target)
  {
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        targets[n] = target;
        if (dX)
          {
            const auto [da, db] = pair_at(dX->begin(), positions[n]);
            targets[n] -= (da / U) * (db / B);
          }
      }
  }


  void
  ContactRows::centre_interior_point_targets(
    const TrilinosWrappers::MPI::Vector &X,
    const TrilinosWrappers::MPI::Vector &dX,
    const double                         s,
    const double                         target)
  {
    const double low = 0.1 * target, high = 10. * target;
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        const auto [a, b]   = pair_at(X.begin(), positions[n]);
        const auto [da, db] = pair_at(dX.begin(), positions[n]);
        const double v      = (a / U + s * da / U) * (b / B + s * db / B);
        if (v < low)
          targets[n] += low - v;
        else if (v > high)
          targets[n] += std::max(high - v, -high);
      }
  }


  void
  ContactRows::solve_interior_point_rows(
    const TrilinosWrappers::MPI::Vector &X,
    TrilinosWrappers::MPI::Vector       &dX) const
  {
    double *dx_all = dX.begin();
    for (std::size_t n = 0; n < positions.size(); ++n)
      {
        const std::size_t k = positions[n];
        const auto [a, b]   = pair_at(X.begin(), k);
        const auto [da, db] = pair_at(dx_all, k);
        const double x = a / U, y = b / B, dx = da / U, dy = db / B;
        const double rhs = targets[n] - x * y;
        if (x >= y)
          dx_all[n_fields * k + 2] = B * (rhs - y * dx) / x;
        else
          {
            const double shift = 0.5 * (U * (rhs - x * dy) / y - da);
            dx_all[n_fields * k] += shift;
            dx_all[n_fields * k + 1] -= shift;
          }
      }
  }


  std::array<double, 2>
  ContactRows::step_to_boundary(const TrilinosWrappers::MPI::Vector &X,
                                const TrilinosWrappers::MPI::Vector &dX,
                                const double                         s) const
  {
    double t = std::numeric_limits<double>::infinity(), sum = 0;
    for (const std::size_t k : positions)
      {
        const auto [a, b]   = pair_at(X.begin(), k);
        const auto [da, db] = pair_at(dX.begin(), k);
        const double x = a / U, y = b / B, dx = da / U, dy = db / B;
        if (dx < 0)
          t = std::min(t, -x / dx);
        if (dy < 0)
          t = std::min(t, -y / dy);
        sum += (x + s * dx) * (y + s * dy);
      }
    const MPI_Comm comm = X.get_mpi_communicator();
    const double   rows = Utilities::MPI::sum(double(positions.size()), comm);
    return {{Utilities::MPI::min(t, comm),
             Utilities::MPI::sum(sum, comm) / std::max(rows, 1.)}};
  }


  void
  ContactRows::attach_continuation(
    SemismoothNewton<TrilinosWrappers::MPI::Vector> &newton,
    const double                                     gap_stiffness)
  {
    using Vector         = TrilinosWrappers::MPI::Vector;
    newton.set_smoothing = [this, gap_stiffness](const Vector &X,
                                                 const double  mu) {
      set_smoothing(mu, X, gap_stiffness);
    };
    auto &rows = newton.interior_point;
    rows.enter = [this, gap_stiffness](Vector &X, const double mu2) {
      enter_interior_point(X, mu2, gap_stiffness);
    };
    rows.set_targets = [this](const Vector *dX, const double target) {
      set_interior_point_targets(dX, target);
    };
    rows.centre = [this](const Vector &X,
                         const Vector &dX,
                         const double  s,
                         const double  target) {
      centre_interior_point_targets(X, dX, s, target);
    };
    rows.solve_rows = [this](const Vector &X, Vector &dX) {
      solve_interior_point_rows(X, dX);
    };
    rows.step_to_boundary =
      [this](const Vector &X, const Vector &dX, const double s) {
        return step_to_boundary(X, dX, s);
      };
    rows.leave = [this]() { leave_interior_point(); };
  }


  void
  ContactRows::leave_interior_point()
  {
    interior_point = false;
    U = B = 1.;
  }


  void
  ContactRows::set_linearisation_point(const TrilinosWrappers::MPI::Vector &X)
  {
    const double *x = X.begin();
    const bool    at_zero =
      std::all_of(positions.begin(), positions.end(), [x](const std::size_t k) {
        return pair_at(x, k) == std::array<double, 2>{{0., 0.}};
      });
    // (without rows anywhere no gradient is asked for)
    cold_start =
      Utilities::MPI::min(int(at_zero), X.get_mpi_communicator()) == 1;
  }


  double
  ContactRows::row_value(const ComplementarityFunction &C,
                         const double                   a,
                         const double                   b) const
  {
    if (mu == 0)
      return C.value(a, b);
    return U * C.smoothed_value(a / U, b / B, mu);
  }


  std::array<double, 2>
  ContactRows::row_gradient(const ComplementarityFunction &C,
                            const double                   a,
                            const double                   b) const
  {
    if (interior_point)
      {
        const double x = a / U, y = b / B;
        return {{y / (x + y), x / (x + y) * U / B}};
      }
    if (mu == 0)
      return (cold_start && a == 0. && b == 0.) ?
               C.free_side_gradient_at_origin() :
               C.generalized_gradient(a, b);
    const auto g = C.smoothed_gradient(a / U, b / B, mu);
    return {{g[0], g[1] * U / B}};
  }


  bool
  ContactRows::enforces_gap(const std::array<double, 2> &g) const
  {
    return std::abs(g[0]) >= std::abs(g[1]) * B / U;
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
        const auto [a, b]   = pair_at(x, k);
        const auto g        = row_gradient(C, a, b);

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
        const auto [a, b]   = pair_at(x, k);
        const auto g        = row_gradient(C, a, b);
        // A row that mainly enforces X3 = 0 has the units of X3 times U / B.
        weights[n] =
          enforces_gap(g) ? stiffness_weight[k] : multiplier_weight[k] * B / U;
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
        const std::size_t k  = positions[n];
        const auto [a, b]    = pair_at(x, k);
        const bool is_active = enforces_gap(row_gradient(C, a, b));
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
      if (const auto [a, b] = pair_at(x, k); a <= b)
        {
          ind[k] = 1.;
          ++n_contact;
        }
    return Utilities::MPI::sum(n_contact, X.get_mpi_communicator());
  }
} // namespace VI
