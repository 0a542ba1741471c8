#include <vi/contact_preconditioner.h>
#include <vi/linear_solvers.h>
#include <vi/nodal_fields.h>
#include <vi/reduced_tension.h>

#include <algorithm>
#include <cmath>

namespace VI
{
  using namespace dealii;
  using NodalFields::n_fields;

  ContactPreconditioner::ContactPreconditioner(const AdditionalData &data)
      : data(data)
  {
  }


  void
  ContactPreconditioner::initialize_mesh(
    const TrilinosWrappers::SparseMatrix &S,
    const double                          mu1,
    const double                          mu2,
    const TrilinosWrappers::MPI::Vector  &coupling_vector,
    const ContactRows                    &contact_rows)
  {
    stiffness = &S;
    this->mu1 = mu1;
    this->mu2 = mu2;
    rows      = &contact_rows;

    const IndexSet &owned = S.locally_owned_range_indices();
    const MPI_Comm  comm  = S.get_mpi_communicator();
    const auto      n     = owned.n_elements();

    diagonal.resize(n);
    coupling.assign(coupling_vector.begin(), coupling_vector.begin() + n);
    for (std::size_t k = 0; k < n; ++k)
      diagonal[k] = S.diag_element(owned.nth_index_in_set(k));
    is_contact.assign(n, false);
    for (const std::size_t k : contact_rows.local_positions())
      is_contact[k] = true;

    for (auto *v : {&mean, &gap, &rhs_mean, &rhs_gap, &first, &stiffness_first})
      v->reinit(owned, comm);

    // The mean is contact-free: one AMG hierarchy for all Newton steps.
    amg_mean.initialize(S, elliptic_amg_settings(data.higher_order_elements));
  }


  void
  ContactPreconditioner::initialize_jacobian(
    const ComplementarityFunction       &C,
    const TrilinosWrappers::MPI::Vector &X)
  {
    const double mu_r = reduced_tension(mu1, mu2);
    const auto   n    = diagonal.size();
    alpha.assign(n, 0.);
    beta.assign(n, 1.);
    tied.assign(n, false);
    penalty.assign(n, 0.);

    const double *x = X.begin();
    gap_matrix.copy_from(*stiffness);
    gap_matrix *= mu_r;
    const IndexSet &owned = stiffness->locally_owned_range_indices();
    for (const std::size_t k : rows->local_positions())
      {
        // The gradient of the rows as the Jacobian has them: of C_mu on
        // the continuation's path, of C otherwise.
        const auto g = rows->row_gradient(C,
                                          x[n_fields * k] - x[n_fields * k + 1],
                                          x[n_fields * k + 2]);
        alpha[k]     = g[0];
        beta[k]      = g[1];
        // A node is tied where beta vanishes (Newton-min's nodes in contact)
        // and also where D alpha / beta exceeds the penalty (Fischer-
        // Burmeister near contact): there d3 = (r3 - alpha w) / beta would
        // divide the error of w by a small beta, while the first row gives
        // d3 from d1 alone.
        const double cap = data.tie_penalty * mu_r * diagonal[k];
        if (std::abs(beta[k]) <= 1e-12 * std::abs(alpha[k]))
          tied[k] = true;
        else
          {
            penalty[k] = coupling[k] * alpha[k] / beta[k];
            tied[k]    = penalty[k] >= cap;
          }
        if (tied[k])
          penalty[k] = cap;
        gap_matrix.add(owned.nth_index_in_set(k),
                       owned.nth_index_in_set(k),
                       penalty[k]);
      }
    gap_matrix.compress(VectorOperation::add);
    amg_gap.initialize(gap_matrix,
                       elliptic_amg_settings(data.higher_order_elements));
  }


  void
  ContactPreconditioner::vmult(TrilinosWrappers::MPI::Vector       &dst,
                               const TrilinosWrappers::MPI::Vector &src) const
  {
    const double  sum = mu1 + mu2;
    const double *r   = src.begin();
    double       *d   = dst.begin();
    const auto    n   = diagonal.size();

    // Eliminate d3 node by node and transform to mean and gap.
    double *b_mean = rhs_mean.begin(), *b_gap = rhs_gap.begin();
    for (std::size_t k = 0; k < n; ++k)
      {
        double       r1 = r[n_fields * k], r2 = r[n_fields * k + 1];
        const double r3 = r[n_fields * k + 2];
        b_mean[k] = b_gap[k] = 0;
        if (!is_contact[k])
          continue; // constrained nodes: solved exactly below
        double tie = 0;
        if (tied[k])
          tie = penalty[k] * r3 / alpha[k];
        else
          {
            r1 += coupling[k] * r3 / beta[k];
            r2 -= coupling[k] * r3 / beta[k];
          }
        b_mean[k] = r1 + r2;
        b_gap[k]  = (mu2 * r1 - mu1 * r2) / sum + tie;
      }

    amg_mean.vmult(mean, rhs_mean);
    mean /= sum;
    amg_gap.vmult(gap, rhs_gap);

    const double *m = mean.begin(), *w = gap.begin();
    double       *d1 = first.begin();
    for (std::size_t k = 0; k < n; ++k)
      d1[k] = is_contact[k] ? m[k] + mu2 / sum * w[k] :
                              r[n_fields * k] / (mu1 * diagonal[k]);

    // d3 on the tied nodes from the first row: mu1 (S d1)_i - D_i d3_i = r1_i.
    stiffness->vmult(stiffness_first, first);
    const double *Sd1 = stiffness_first.begin();

    for (std::size_t k = 0; k < n; ++k)
      {
        const double r1 = r[n_fields * k], r2 = r[n_fields * k + 1],
                     r3 = r[n_fields * k + 2];
        if (!is_contact[k])
          {
            // Constrained node: the rows are diagonal.
            d[n_fields * k]     = r1 / (mu1 * diagonal[k]);
            d[n_fields * k + 1] = r2 / (mu2 * diagonal[k]);
            d[n_fields * k + 2] = r3;
            continue;
          }
        d[n_fields * k]     = m[k] + mu2 / sum * w[k];
        d[n_fields * k + 1] = m[k] - mu1 / sum * w[k];
        d[n_fields * k + 2] = tied[k] ? (mu1 * Sd1[k] - r1) / coupling[k] :
                                        (r3 - alpha[k] * w[k]) / beta[k];
      }
  }
} // namespace VI
