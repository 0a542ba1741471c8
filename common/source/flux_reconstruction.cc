// FluxReconstruction: the reference products, the patch layouts and
// factorisations, and the reconstruction of the fluxes (reconstruct()); the
// set-up of the patches of a mesh is in flux_reconstruction_setup.cc.

#include <deal.II/base/geometry_info.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/partitioner.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/la_parallel_vector.h>
#include <deal.II/lac/vector.h>

#include <vi/flux_reconstruction.h>
#include <vi/piola_divergence.h>

#include "flux_reconstruction_internal.h"

#include <algorithm>
#include <array>
#include <boost/serialization/utility.hpp>
#include <boost/serialization/vector.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>

namespace VI
{
  using namespace dealii;


  template <int dim>
  FluxReconstruction<dim>::FluxReconstruction(
    const Mapping<dim> &mapping,
    const unsigned int  degree,
    const unsigned int  potential_degree,
    const unsigned int  n_points)
      : mapping(mapping)
      , fe_flux(degree)
      , fe_divergence(degree)
      , fe_hat(1)
      , quadrature(n_points != numbers::invalid_unsigned_int ?
                     n_points :
                     quadrature_points(potential_degree ==
                                           numbers::invalid_unsigned_int ?
                                         degree :
                                         potential_degree,
                                       degree))
  {
    AssertThrow(potential_degree == numbers::invalid_unsigned_int ||
                  potential_degree >= degree,
                ExcMessage("the flux degree exceeds the potential's"));
    // Q_p and the divergence moments on the reference cell: the values of
    // FE_DGQ do not depend on the cell, and (div tau_i, q_k)_K = s_i
    // (div^ tau^_i, q^_k) (see PiolaDivergence).
    const unsigned int n_tau = fe_flux.n_dofs_per_cell(),
                       n_q   = fe_divergence.n_dofs_per_cell();
    const PiolaDivergence<dim> divergence(fe_flux, quadrature);
    q_reference.resize(quadrature.size() * n_q);
    divergence_reference.assign(n_q * n_tau, 0.);
    weighted_flux_reference.resize(quadrature.size() * n_tau * dim);
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      for (unsigned int i = 0; i < n_tau; ++i)
        for (unsigned int d = 0; d < dim; ++d)
          weighted_flux_reference[(q * n_tau + i) * dim + d] =
            fe_flux.shape_value_component(i, quadrature.point(q), d) *
            quadrature.weight(q);
    // int tau^_i^a tau^_j^b on the reference cell (exact: the rule has at
    // least p + 3 points per direction), symmetrised for a < b
    metric_reference.assign(n_metric * n_tau * n_tau, 0.);
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      {
        const double *tau   = &weighted_flux_reference[q * n_tau * dim];
        const double  scale = 1. / quadrature.weight(q);
        unsigned int  m     = 0;
        for (unsigned int a = 0; a < dim; ++a)
          for (unsigned int b = a; b < dim; ++b, ++m)
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int j = 0; j < n_tau; ++j)
                metric_reference[(m * n_tau + i) * n_tau + j] +=
                  (tau[i * dim + a] * tau[j * dim + b] +
                   (a < b ? tau[i * dim + b] * tau[j * dim + a] : 0.)) *
                  scale;
      }
    // Their nonzero entries, for the patch solves (a Raviart-Thomas function
    // of a quadrilateral has one nonzero component: a quarter of the
    // entries of M^_m are nonzero, some of the others round-off).
    for (unsigned int m = 0; m < n_metric; ++m)
      for (unsigned int i = 0; i < n_tau; ++i)
        for (unsigned int j = 0; j < n_tau; ++j)
          if (const double value =
                metric_reference[(m * n_tau + i) * n_tau + j];
              value != 0.)
            metric_entries.push_back({m, i, j, value});
    for (unsigned int q = 0; q < quadrature.size(); ++q)
      for (unsigned int k = 0; k < n_q; ++k)
        {
          const double q_k = fe_divergence.shape_value(k, quadrature.point(q));
          q_reference[q * n_q + k] = q_k;
          for (unsigned int i = 0; i < n_tau; ++i)
            divergence_reference[k * n_tau + i] +=
              divergence.reference_divergence(i, q) * q_k *
              quadrature.weight(q);
        }
  }


  template <int dim>
  unsigned int
  FluxReconstruction<dim>::quadrature_points(
    const unsigned int potential_degree,
    const unsigned int flux_degree)
  {
    // (flux_degree = invalid_unsigned_int, the default, is never < p)
    const unsigned int n =
      potential_degree + (flux_degree < potential_degree ? 1 : 3);
    return n + n % 2;
  }


  template <int dim>
  FluxReconstruction<dim>::~FluxReconstruction()
  {
    dof_handler.clear();
  }


  // The layout of the patch's connectivity and Piola signs, which
  // determine B: new ones get the divergence basis of B and the energy
  // products P_c,m and Q_c,m (see PatchLayout).
  template <int dim>
  std::shared_ptr<const typename FluxReconstruction<dim>::PatchLayout>
  FluxReconstruction<dim>::shared_layout(
    const PatchLayout                      &layout,
    const std::vector<const std::int8_t *> &signs,
    Layouts                                &cache,
    Layouts                                &layouts,
    std::mutex                             &mutex,
    std::vector<std::int64_t>              &key) const
  {
    const unsigned int n_tau   = fe_flux.n_dofs_per_cell(),
                       n_q_K   = fe_divergence.n_dofs_per_cell();
    const unsigned int n_sigma = layout.n_sigma;
    const unsigned int n_q     = layout.n_cells * n_q_K;
    const auto        &entries = layout.sigma_entries;
    key.assign({layout.n_cells, n_sigma});
    key.insert(key.end(), layout.sigma_start.begin(), layout.sigma_start.end());
    for (const auto &[I, w] : entries)
      {
        key.push_back(I);
        // (the constraint weights are the element's: equal weights have
        // equal bits)
        std::int64_t bits;
        std::memcpy(&bits, &w, sizeof bits);
        key.push_back(bits);
      }
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      key.insert(key.end(), signs[c], signs[c] + n_tau);
    auto &cached = cache[key];
    if (cached)
      return cached;
    const std::lock_guard<std::mutex> lock(mutex);
    auto                             &shared = layouts[key];
    if (shared)
      {
        cached = shared;
        return cached;
      }

    std::vector<double> B(n_q * n_sigma, 0.);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      {
        const auto *start = &layout.sigma_start[c * (n_tau + 1)];
        for (unsigned int i = 0; i < n_tau; ++i)
          for (unsigned int e = start[i]; e < start[i + 1]; ++e)
            for (unsigned int k = 0; k < n_q_K; ++k)
              B[(c * n_q_K + k) * n_sigma + entries[e].first] +=
                entries[e].second *
                (signs[c][i] * divergence_reference[k * n_tau + i]);
      }
    auto new_layout = std::make_shared<PatchLayout>(layout);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      new_layout->signs.insert(new_layout->signs.end(),
                               signs[c],
                               signs[c] + n_tau);
    new_layout->basis =
      std::make_shared<const DivergenceBasis>(n_sigma, n_q, B);
    const DivergenceBasis &basis    = *new_layout->basis;
    const unsigned int     d        = basis.n_free;
    const unsigned int     n_packed = new_layout->n_packed();
    const unsigned int     n_block  = new_layout->energy_block();
    new_layout->energy.assign(std::size_t(layout.n_cells) * n_metric * n_block,
                              0.);

    // Per cell: SZ = S_c E_c Z (n_tau x d) and SB = S_c E_c B^+ (n_tau x
    // n_q), by rows; then per metric entry T = M^_m SZ and the products.
    std::vector<double> SZ(n_tau * d), SB(n_tau * n_q), T(n_tau * d);
    for (unsigned int c = 0; c < layout.n_cells; ++c)
      {
        std::fill(SZ.begin(), SZ.end(), 0.);
        std::fill(SB.begin(), SB.end(), 0.);
        const auto *start = &layout.sigma_start[c * (n_tau + 1)];
        for (unsigned int i = 0; i < n_tau; ++i)
          for (unsigned int e = start[i]; e < start[i + 1]; ++e)
            {
              const auto   I = entries[e].first;
              const double w = entries[e].second * signs[c][i];
              for (unsigned int j = 0; j < d; ++j)
                SZ[i * d + j] += w * basis.kernel[j * n_sigma + I];
              for (unsigned int k = 0; k < n_q; ++k)
                SB[i * n_q + k] += w * basis.pseudo_inverse[k * n_sigma + I];
            }
        for (unsigned int m = 0; m < n_metric; ++m)
          {
            const double *M = &metric_reference[m * n_tau * n_tau];
            std::fill(T.begin(), T.end(), 0.);
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int l = 0; l < n_tau; ++l)
                if (const double M_il = M[i * n_tau + l]; M_il != 0.)
                  for (unsigned int j = 0; j < d; ++j)
                    T[i * d + j] += M_il * SZ[l * d + j];
            double *const P =
              &new_layout->energy[(std::size_t(c) * n_metric + m) * n_block];
            double *const Q = P + n_packed;
            for (unsigned int i = 0; i < n_tau; ++i)
              for (unsigned int j = 0; j < d; ++j)
                {
                  const double t = T[i * d + j];
                  for (unsigned int l = 0; l <= j; ++l)
                    P[j * (j + 1) / 2 + l] += t * SZ[i * d + l];
                  for (unsigned int k = 0; k < n_q; ++k)
                    Q[j * n_q + k] += t * SB[i * n_q + k];
                }
          }
      }
    shared = new_layout;
    cached = shared;
    return cached;
  }


  // The patch energy on the divergence-free fluxes from the cells'
  // metrics: Z^T A Z = sum G_c,m P_c,m = L L^T.
  template <int dim>
  void
  FluxReconstruction<dim>::factorise(LocalSolver &solver) const
  {
    const PatchLayout &layout = *solver.layout;
    const unsigned int d      = layout.basis->n_free;
    double *const      L      = solver.cholesky();
    layout.combine(solver.metrics, 0, layout.n_packed(), L);
    // Cholesky in place, row by row of the packed lower triangle.
    for (unsigned int j = 0; j < d; ++j)
      {
        double *const row_j = L + j * (j + 1) / 2;
        for (unsigned int m = 0; m <= j; ++m)
          {
            const double *const row_m = L + m * (m + 1) / 2;
            double              value = row_j[m];
            for (unsigned int r = 0; r < m; ++r)
              value -= row_j[r] * row_m[r];
            if (m < j)
              row_j[m] = value / row_m[m];
            else
              {
                AssertThrow(value > 0.,
                            ExcMessage("Flux reconstruction: the energy of a "
                                       "patch is not positive definite on "
                                       "its divergence-free fluxes (a "
                                       "degenerate cell?)."));
                row_j[j] = std::sqrt(value);
              }
          }
      }
  }


  // C = Z^T A B^+ = sum G_c,m Q_c,m of every solver, in one array.
  template <int dim>
  void
  FluxReconstruction<dim>::keep_products() const
  {
    std::vector<std::size_t> start(local_solvers.size() + 1, 0);
    for (std::size_t s = 0; s < local_solvers.size(); ++s)
      start[s + 1] = start[s] + local_solvers[s]->layout->n_products();
    product_storage.reset(new double[start.back()]);
    parallel_for_each(
      local_solvers.size(),
      [&](const std::size_t s) {
        LocalSolver       &solver = *local_solvers[s];
        const PatchLayout &layout = *solver.layout;
        double *const      C      = &product_storage[start[s]];
        layout.combine(solver.metrics,
                       layout.n_packed(),
                       layout.n_products(),
                       C);
        solver.products = C;
      },
      /*grainsize=*/256);
  }


  // What one thread needs for the right-hand sides of a cell: the hat
  // functions' values, its own evaluator of the data, and arrays.
  template <int dim>
  struct FluxReconstruction<dim>::CellScratch
  {
    CellScratch(const FluxReconstruction<dim> &reconstruction,
                const Sources                 &sources)
        : sources(sources)
        , hat_values(reconstruction.mapping,
                     reconstruction.fe_hat,
                     reconstruction.quadrature,
                     update_values | update_gradients | update_jacobians |
                       update_JxW_values)
        , cell_values(sources.make_cell_values())
        , flux(sources.n_fields,
               std::vector<Tensor<1, dim>>(reconstruction.quadrature.size()))
        , source(sources.n_fields,
                 std::vector<double>(reconstruction.quadrature.size()))
    {
    }

    // WorkStream copies the scratch once per thread: a new FEValues and a
    // new evaluator of the data.
    CellScratch(const CellScratch &other)
        : sources(other.sources)
        , hat_values(other.hat_values.get_mapping(),
                     other.hat_values.get_fe(),
                     other.hat_values.get_quadrature(),
                     other.hat_values.get_update_flags())
        , cell_values(sources.make_cell_values())
        , flux(other.flux)
        , source(other.source)
    {
    }

    const Sources                           &sources;
    FEValues<dim>                            hat_values;
    typename Sources::CellValues             cell_values;
    std::vector<std::vector<Tensor<1, dim>>> flux;
    std::vector<std::vector<double>>         source;
    std::vector<double>                      flux_moments, vertex_rhs;
  };


  template <int dim>
  ArrayView<const typename FluxReconstruction<dim>::Membership>
  FluxReconstruction<dim>::parts_of(const CellIterator &cell) const
  {
    const std::size_t begin = membership_start[cell->active_cell_index()],
                      end   = membership_start[cell->active_cell_index() + 1];
    return {memberships.data() + begin, end - begin};
  }


  // The right-hand sides of one cell's parts in its patches, in the order
  // of parts_of(cell), record = (n_tau + n_q) n_fields numbers each.
  template <int dim>
  struct FluxReconstruction<dim>::CellShare
  {
    CellIterator        cell;
    std::vector<double> rhs;
  };


  // In the metric G of the cell, (psi F, tau_j) is int psi (G F^) . (s_j
  // tau^_j) over the reference cell, with the Piola pull-back F^ = adj(J) F
  // = det J J^-1 F (so that F in RT_p gives the product of the patch
  // energy): the sum over the quadrature points of psi s_j (G adj(J) F) .
  // tau^_j w_q, which on parallelograms is the L2 product psi s_j (J^T F) .
  // tau^_j w_q. No Raviart-Thomas values on the cell are needed, only J, G
  // and the signs.
  template <int dim>
  void
  FluxReconstruction<dim>::cell_share(const CellIterator &cell,
                                      CellScratch        &scratch,
                                      CellShare          &share) const
  {
    const unsigned int n_fields   = scratch.sources.n_fields;
    const unsigned int n_tau      = fe_flux.n_dofs_per_cell(),
                       n_q        = fe_divergence.n_dofs_per_cell();
    const unsigned int     record = (n_tau + n_q) * n_fields;
    constexpr unsigned int n_v    = GeometryInfo<dim>::vertices_per_cell;
    const ArrayView<const Membership> parts        = parts_of(cell);
    FEValues<dim>                    &hat_values   = scratch.hat_values;
    auto                             &flux         = scratch.flux;
    auto                             &source       = scratch.source;
    auto                             &flux_moments = scratch.flux_moments;
    auto                             &vertex_rhs   = scratch.vertex_rhs;
    flux_moments.resize(n_fields * n_tau);
    vertex_rhs.assign(n_v * record, 0.);

    hat_values.reinit(cell);
    scratch.cell_values(cell, flux, source);
    Tensor<2, dim> G;
    {
      const double *metric = &cell_metric[cell->active_cell_index() * n_metric];
      for (unsigned int a = 0, m = 0; a < dim; ++a)
        for (unsigned int b = a; b < dim; ++b, ++m)
          G[a][b] = G[b][a] = metric[m];
    }

    // The right-hand sides of the cell's Q1 shape functions phi_v,
    // vertex_rhs[v record ...]; psi_a on the cell is the combination with
    // the weights of its membership (one phi_v, or constraint weights at
    // hanging vertices).
    for (const unsigned int q : hat_values.quadrature_point_indices())
      {
        const double         dx = hat_values.JxW(q);
        const Tensor<2, dim> J(hat_values.jacobian(q));
        // the metric's product with the Piola pull-back adj(J) F of F:
        // G adj(J) = J^T on parallelograms
        const Tensor<2, dim> pull = G * (determinant(J) * invert(J));
        const double *reference   = &weighted_flux_reference[q * n_tau * dim];
        // (G adj(J) F_f) . tau^_j w_q, without the signs
        for (unsigned int f = 0; f < n_fields; ++f)
          {
            double mapped[dim];
            for (unsigned int e = 0; e < dim; ++e)
              {
                mapped[e] = 0;
                for (unsigned int d = 0; d < dim; ++d)
                  mapped[e] += pull[e][d] * flux[f][q][d];
              }
            for (unsigned int j = 0; j < n_tau; ++j)
              {
                double value = 0;
                for (unsigned int e = 0; e < dim; ++e)
                  value += mapped[e] * reference[j * dim + e];
                flux_moments[f * n_tau + j] = value;
              }
          }
        const double *q_k = &q_reference[q * n_q];
        for (unsigned int v = 0; v < n_v; ++v)
          {
            const double          phi      = hat_values.shape_value(v, q);
            const Tensor<1, dim> &grad_phi = hat_values.shape_grad(v, q);
            double               *values   = &vertex_rhs[v * record];
            for (unsigned int f = 0; f < n_fields; ++f, values += n_tau + n_q)
              {
                const double *moments = &flux_moments[f * n_tau];
                for (unsigned int j = 0; j < n_tau; ++j)
                  values[j] -= phi * moments[j];
                const double g =
                  (source[f][q] * phi - flux[f][q] * grad_phi) * dx;
                for (unsigned int k = 0; k < n_q; ++k)
                  values[n_tau + k] += g * q_k[k];
              }
          }
      }
    share.cell = cell;
    share.rhs.assign(parts.size() * record, 0.);
    for (unsigned int m = 0; m < parts.size(); ++m)
      if (parts[m].hat < n_v)
        std::copy_n(&vertex_rhs[parts[m].hat * record],
                    record,
                    &share.rhs[m * record]);
      else
        for (unsigned int v = 0; v < n_v; ++v)
          if (const double w = hanging_hats[parts[m].hat - n_v][v]; w != 0.)
            {
              const double *from = &vertex_rhs[v * record];
              double       *to   = &share.rhs[m * record];
              for (unsigned int i = 0; i < record; ++i)
                to[i] += w * from[i];
            }
    const std::int8_t *signs = &piola_signs[cell->active_cell_index() * n_tau];
    for (unsigned int m = 0; m < parts.size(); ++m)
      for (unsigned int f = 0; f < n_fields; ++f)
        {
          double *values = share.rhs.data() + m * record + f * (n_tau + n_q);
          for (unsigned int j = 0; j < n_tau; ++j)
            if (signs[j] < 0)
              values[j] = -values[j];
        }
  }


  // values[f (n_tau + n_q) + j] = -(psi_a F_f, tau_j)_K and
  // values[f (n_tau + n_q) + n_tau + k] = (s_f psi_a - F_f . grad psi_a,
  // q_k)_K.
  template <int dim>
  void
  FluxReconstruction<dim>::add_cell_share(const unsigned int p,
                                          const unsigned int position,
                                          const double      *values,
                                          const unsigned int n_fields,
                                          double *const      rhs) const
  {
    const PatchLayout &layout   = *patches[p].solver->layout;
    const unsigned int n_tau    = fe_flux.n_dofs_per_cell(),
                       n_q      = fe_divergence.n_dofs_per_cell();
    const unsigned int  n_sigma = layout.n_sigma;
    const unsigned int  n       = patches[p].solver->n();
    const unsigned int *start   = &layout.sigma_start[position * (n_tau + 1)];
    const auto         *entries = layout.sigma_entries.data();
    for (unsigned int f = 0; f < n_fields; ++f, values += n_tau + n_q)
      {
        double *const column = rhs + std::size_t(f) * n;
        for (unsigned int j = 0; j < n_tau; ++j)
          for (unsigned int e = start[j]; e < start[j + 1]; ++e)
            column[entries[e].first] += entries[e].second * values[j];
        for (unsigned int k = 0; k < n_q; ++k)
          column[n_sigma + position * n_q + k] += values[n_tau + k];
      }
  }


  template <int dim>
  void
  FluxReconstruction<dim>::reconstruct(
    const Sources                                      &sources,
    const std::vector<TrilinosWrappers::MPI::Vector *> &sigma) const
  {
    const unsigned int n_fields = sources.n_fields;
    const unsigned int n_tau    = fe_flux.n_dofs_per_cell();
    AssertDimension(sigma.size(), n_fields);

    // Right-hand sides of all patches solved here, one column per field
    // (patch p from rhs_start[p] on), and those of owned cells in patches
    // solved elsewhere (see assemble_right_hand_sides()).
    std::vector<std::size_t> rhs_start(patches.size() + 1, 0);
    for (unsigned int p = 0; p < patches.size(); ++p)
      rhs_start[p + 1] =
        rhs_start[p] + std::size_t(patches[p].solver->n()) * n_fields;
    // (zeroed on all threads: on a large mesh this is the first touch of
    // much memory, whose page faults then run in parallel)
    const std::unique_ptr<double[]> rhs_storage(new double[rhs_start.back()]);
    double *const                   rhs = rhs_storage.get();
    parallel::apply_to_subranges(
      std::size_t(0),
      rhs_start.back(),
      [&](const std::size_t begin, const std::size_t end) {
        std::fill(rhs + begin, rhs + end, 0.);
      },
      /*grainsize=*/std::size_t(1) << 16);
    assemble_right_hand_sides(sources, rhs_start, rhs);

    // The patch problems, independent of each other (concurrently): the
    // patch solution overwrites its right-hand sides, sigma^a is the head
    // of each column. A mesh reconstructed more than once keeps the
    // products C of its solvers (see LocalSolver).
    if (++n_reconstructions == 2)
      keep_products();
    parallel::apply_to_subranges(
      0u,
      static_cast<unsigned int>(patches.size()),
      [&](const unsigned int begin, const unsigned int end) {
        std::vector<double> work;
        for (unsigned int p = begin; p < end; ++p)
          patches[p].solver->solve(
            rhs + rhs_start[p], n_fields, metric_entries, n_tau, work);
      },
      /*grainsize=*/256);
    sum_patch_fluxes(rhs_start, rhs, sigma);
  }


  // The right-hand sides of the patch problems: the cells' parts, computed
  // by their owners, and the vertices' constants.
  template <int dim>
  void
  FluxReconstruction<dim>::assemble_right_hand_sides(
    const Sources                  &sources,
    const std::vector<std::size_t> &rhs_start,
    double *const                   rhs) const
  {
    const MPI_Comm     comm     = dof_handler.get_communicator();
    const unsigned int rank     = Utilities::MPI::this_mpi_process(comm);
    const unsigned int n_fields = sources.n_fields;
    const unsigned int n_tau    = fe_flux.n_dofs_per_cell(),
                       n_q      = fe_divergence.n_dofs_per_cell();
    const unsigned int record   = (n_tau + n_q) * n_fields;
    std::map<unsigned int, std::vector<double>> outgoing;
    for (const auto &[to, n] : n_sent)
      outgoing[to].assign(n * record, 0.);

    // One pass over the owned cells: each cell computes its part of the
    // right-hand sides of the patches it belongs to (concurrently, see
    // cell_share()), and the parts are added to the patches' right-hand
    // sides, or to what is sent to other processes, in the order of the
    // cells.
    const auto worker =
      [&](const typename std::vector<CellIterator>::const_iterator &cell,
          CellScratch                                              &scratch,
          CellShare &share) { cell_share(*cell, scratch, share); };
    const auto copier = [&](const CellShare &share) {
      const ArrayView<const Membership> parts = parts_of(share.cell);
      for (unsigned int m = 0; m < parts.size(); ++m)
        if (parts[m].rank == rank)
          add_cell_share(parts[m].index,
                         parts[m].position,
                         share.rhs.data() + m * record,
                         n_fields,
                         rhs + rhs_start[parts[m].index]);
        else
          std::copy_n(share.rhs.data() + m * record,
                      record,
                      outgoing[parts[m].rank].data() + parts[m].index * record);
    };
    WorkStream::run(cells_with_shares.cbegin(),
                    cells_with_shares.cend(),
                    worker,
                    copier,
                    CellScratch(*this, sources),
                    CellShare(),
                    /*queue_length=*/2 * MultithreadInfo::n_threads(),
                    /*chunk_size=*/64);

    // The parts computed by the owners of cells in patches solved here.
    if (Utilities::MPI::n_mpi_processes(comm) > 1)
      {
        const auto incoming = Utilities::MPI::some_to_some(comm, outgoing);
        for (const auto &[from, values] : incoming)
          {
            const auto &targets = received.at(from);
            AssertDimension(values.size(), targets.size() * record);
            for (unsigned int i = 0; i < targets.size(); ++i)
              add_cell_share(targets[i].first,
                             targets[i].second,
                             values.data() + i * record,
                             n_fields,
                             rhs + rhs_start[targets[i].first]);
          }
      }

    // The constants c_a of the vertices: c_a (psi_a, q_k) on every cell.
    if (sources.vertex_source)
      for (unsigned int p = 0; p < patches.size(); ++p)
        {
          const Patch       &patch    = patches[p];
          const PatchLayout &layout   = *patch.solver->layout;
          const double      *hat_mass = patch.hat_mass;
          for (unsigned int f = 0; f < n_fields; ++f)
            {
              const double c_a    = sources.vertex_source(patch.vertex, f);
              double      *column = rhs + rhs_start[p] +
                               std::size_t(f) * patch.solver->n() +
                               layout.n_sigma;
              for (unsigned int k = 0; k < layout.n_cells * n_q; ++k)
                column[k] += c_a * hat_mass[k];
            }
        }
  }


  template <int dim>
  void
  FluxReconstruction<dim>::sum_patch_fluxes(
    const std::vector<std::size_t>                     &rhs_start,
    const double                                       *rhs,
    const std::vector<TrilinosWrappers::MPI::Vector *> &sigma) const
  {
    const MPI_Comm     comm     = dof_handler.get_communicator();
    const unsigned int n_fields = sigma.size();
    // The fluxes of the patches summed in patch order, the fields
    // concurrently; then the sums of dofs other processes own added
    // there (in serial, nothing to send).
    std::vector<LinearAlgebra::distributed::Vector<double>> sums(n_fields);
    for (auto &sum : sums)
      sum.reinit(flux_partitioner);
    parallel_for_each(
      n_fields,
      [&](const unsigned int f) {
        double *const values = sums[f].get_values();
        for (unsigned int p = 0; p < patches.size(); ++p)
          {
            const LocalSolver &solver = *patches[p].solver;
            const double      *column =
              rhs + rhs_start[p] + std::size_t(f) * solver.n();
            const unsigned int *positions =
              &patch_positions[patches[p].dofs_start];
            for (unsigned int i = 0; i < solver.layout->n_sigma; ++i)
              values[positions[i]] += column[i];
          }
      },
      /*grainsize=*/1);
    TrilinosWrappers::MPI::Vector owned(owned_dofs, comm);
    for (unsigned int f = 0; f < n_fields; ++f)
      {
        LinearAlgebra::distributed::Vector<double> &sum = sums[f];
        sum.compress(VectorOperation::add);
        // The fluxes on the fine side of hanging faces from the coarse side
        // (the patches wrote none there), which may be owned elsewhere.
        sum.update_ghost_values();
        double *const values = sum.get_values();
        for (std::size_t c = 0; c < constrained_dofs.size(); ++c)
          {
            double value = 0;
            for (unsigned int e = constraint_start[c];
                 e < constraint_start[c + 1];
                 ++e)
              value += constraint_entries[e].second *
                       values[constraint_entries[e].first];
            values[constrained_dofs[c]] = value;
          }
        // The owned entries come first, in the order of owned_dofs, as in
        // the Trilinos vector; the ghosts of sigma from their owners.
        std::copy_n(values, sum.locally_owned_size(), owned.begin());
        ghosted_fluxes.copy(owned, *sigma[f]);
      }
  }


  template <int dim>
  const DoFHandler<dim> &
  FluxReconstruction<dim>::get_dof_handler() const
  {
    return dof_handler;
  }


  template <int dim>
  const Quadrature<dim> &
  FluxReconstruction<dim>::get_quadrature() const
  {
    return quadrature;
  }


  template <int dim>
  const IndexSet &
  FluxReconstruction<dim>::locally_owned_dofs() const
  {
    return owned_dofs;
  }


  template <int dim>
  const std::vector<std::int8_t> &
  FluxReconstruction<dim>::get_piola_signs() const
  {
    return piola_signs;
  }


  template <int dim>
  const IndexSet &
  FluxReconstruction<dim>::locally_relevant_dofs() const
  {
    return relevant_dofs;
  }


  template <int dim>
  std::pair<unsigned int, unsigned int>
  FluxReconstruction<dim>::statistics() const
  {
    return {patches.size(), local_solvers.size()};
  }


  template class FluxReconstruction<2>;
} // namespace VI
