#include <deal.II/base/geometry_info.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/la_parallel_vector.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/flux_reconstruction.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <set>
#include <sstream>

namespace VI
{
  using namespace dealii;

  // The LU factors of a patch matrix (LAPACK getrf, once per mesh: a third
  // of the work of an inverse); the patch problems of every field and every
  // iterate are then two triangular solves each (getrs), which cost what a
  // product with the inverse would.
  template <int dim>
  struct FluxReconstruction<dim>::LocalSolver
  {
    LAPACKFullMatrix<double> lu;
  };


  template <int dim>
  FluxReconstruction<dim>::FluxReconstruction(const Mapping<dim> &mapping,
                                              const unsigned int  degree)
      : mapping(mapping)
      , degree(degree)
      , fe_flux(degree)
      , fe_divergence(degree)
      , fe_hat(1)
      , quadrature(quadrature_points(degree))
  {
  }


  template <int dim>
  unsigned int
  FluxReconstruction<dim>::quadrature_points(const unsigned int degree)
  {
    return degree + 3 + (degree + 3) % 2;
  }


  template <int dim>
  FluxReconstruction<dim>::~FluxReconstruction()
  {
    dof_handler.clear();
  }


  template <int dim>
  void
  FluxReconstruction<dim>::reinit(const DoFHandler<dim> &potential)
  {
    const Triangulation<dim> &tria   = potential.get_triangulation();
    const MPI_Comm            comm   = potential.get_communicator();
    const unsigned int        rank   = Utilities::MPI::this_mpi_process(comm);
    const unsigned int        n_rank = Utilities::MPI::n_mpi_processes(comm);

    dof_handler.reinit(tria);
    dof_handler.distribute_dofs(fe_flux);
    owned_dofs = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);
    hanging_constraints.clear();
    hanging_constraints.reinit(relevant_dofs);
    DoFTools::make_hanging_node_constraints(dof_handler, hanging_constraints);
    hanging_constraints.close();

    patches.clear();
    cell_patches.assign(tria.n_active_cells(), {});
    n_local_solvers = 0;

    // The conforming hat functions: Q1 with its hanging node constraints,
    // one patch per unconstrained (regular) vertex, numbered by its degree
    // of freedom. hats_of[j] lists the cells where psi_j does not vanish,
    // with psi_j's values at their vertices.
    DoFHandler<dim> hats(tria);
    hats.distribute_dofs(fe_hat);
    IndexSet relevant_hats;
    DoFTools::extract_locally_relevant_dofs(hats, relevant_hats);
    AffineConstraints<double> hat_constraints(relevant_hats);
    DoFTools::make_hanging_node_constraints(hats, hat_constraints);
    hat_constraints.close();

    const unsigned int n_vertices = GeometryInfo<dim>::vertices_per_cell;
    std::map<types::global_dof_index,
             std::map<CellIterator, std::vector<double>>>
                                                    hats_of;
    std::map<types::global_dof_index, unsigned int> vertex_of;
    for (const auto &hat_cell : hats.active_cell_iterators())
      if (!hat_cell->is_artificial())
        {
          const CellIterator cell(hat_cell);
          for (const unsigned int v : hat_cell->vertex_indices())
            {
              const auto i   = hat_cell->vertex_dof_index(v, 0);
              const auto add = [&](const types::global_dof_index j,
                                   const double                  w) {
                auto &values = hats_of[j][cell];
                values.resize(n_vertices, 0.);
                values[v] = w;
              };
              if (hat_constraints.is_constrained(i))
                for (const auto &[j, w] :
                     *hat_constraints.get_constraint_entries(i))
                  add(j, w);
              else
                {
                  add(i, 1.);
                  vertex_of[i] = hat_cell->vertex_index(v);
                }
            }
        }

    // A patch is complete here if every cell around a, and the finer cells
    // beyond the hanging faces at a, are owned or ghost.
    std::vector<bool> at_boundary(tria.n_vertices(), false);
    for (const auto &cell : tria.active_cell_iterators())
      if (!cell->is_artificial())
        for (const unsigned int f : cell->face_indices())
          if (cell->face(f)->at_boundary())
            for (unsigned int v = 0; v < cell->face(f)->n_vertices(); ++v)
              at_boundary[cell->face(f)->vertex_index(v)] = true;
    const auto complete = [&](const types::global_dof_index j) {
      const auto vertex = vertex_of.find(j);
      if (vertex == vertex_of.end())
        return false;
      for (const auto &[cell, values] : hats_of[j])
        for (const unsigned int f : cell->face_indices())
          {
            bool contains_a = false;
            for (unsigned int w = 0; w < cell->face(f)->n_vertices(); ++w)
              contains_a |= (cell->face(f)->vertex_index(w) == vertex->second);
            if (!contains_a || cell->face(f)->at_boundary())
              continue;
            if (cell->face(f)->has_children())
              {
                for (unsigned int c = 0; c < cell->face(f)->n_children(); ++c)
                  if (cell->neighbor_child_on_subface(f, c)->is_artificial())
                    return false;
              }
            else if (cell->neighbor(f)->is_artificial())
              return false;
          }
      return true;
    };

    // The lowest rank that sees a patch whole solves it.
    LinearAlgebra::distributed::Vector<double> solver_rank(
      hats.locally_owned_dofs(), relevant_hats, comm);
    for (const auto j : relevant_hats)
      solver_rank(j) = n_rank;
    for (const auto &[j, cells] : hats_of)
      if (!hat_constraints.is_constrained(j) && complete(j))
        solver_rank(j) = rank;
    solver_rank.compress(VectorOperation::min);
    solver_rank.update_ghost_values();
    for (const auto j : hats.locally_owned_dofs())
      if (!hat_constraints.is_constrained(j) && solver_rank(j) == n_rank)
        {
          std::ostringstream where;
          if (vertex_of.count(j))
            where << " at " << tria.get_vertices()[vertex_of[j]];
          AssertThrow(false,
                      ExcMessage("Flux reconstruction: no process sees the "
                                 "whole vertex patch" +
                                 where.str() +
                                 " (its hanging nodes reach beyond the ghost "
                                 "cells); use fewer processes."));
        }

    // Each cell's share of the patch matrices, computed when a first patch
    // needs it and kept until all patches are built.
    CellMatrixCache cell_matrix_cache(*this, tria.n_active_cells());
    // Patch matrices shared between patches of the same normalised shape.
    std::map<std::vector<std::int64_t>, std::shared_ptr<const LocalSolver>>
      solvers;
    // (Mapped points from the Q1 element: in deal.II 9.4 an FEValues of a
    // Raviart-Thomas element that asks for mapping data only trips over the
    // face sign changes of unstructured meshes, deal.II PR 15963.)
    FEValues<dim> shape_values(mapping,
                               fe_hat,
                               QGauss<dim>(2),
                               update_quadrature_points);

    std::vector<types::global_dof_index> rt_dofs(fe_flux.n_dofs_per_cell());
    std::vector<bool>                    on_face(fe_flux.n_dofs_per_cell());
    for (const auto &[j, cell_hats] : hats_of)
      {
        if (hat_constraints.is_constrained(j) || solver_rank(j) != double(rank))
          continue;
        const unsigned int a = vertex_of[j];
        Patch              patch;
        patch.vertex          = a;
        patch.interior        = !at_boundary[a];
        const Point<dim> &x_a = tria.get_vertices()[a];

        // Cells in a canonical order (by angle around a, then distance),
        // so that patches of the same shape get the same local numbering.
        std::vector<CellIterator> cells;
        for (const auto &entry : cell_hats)
          cells.push_back(entry.first);
        const auto polar = [&](const CellIterator &c) {
          const auto d = c->center() - x_a;
          return std::make_pair(std::atan2(d[1], d[0]), d.norm());
        };
        std::sort(cells.begin(),
                  cells.end(),
                  [&](const CellIterator &c1, const CellIterator &c2) {
                    return polar(c1) < polar(c2);
                  });

        // The free fluxes: the dofs on faces where psi_a does not vanish
        // (the others carry sigma^a . n = 0), or their parents on the
        // coarse side of a hanging face; and the dofs inside the cells.
        std::set<types::global_dof_index> free;
        for (const auto &cell : cells)
          {
            const auto &psi = cell_hats.at(cell);
            typename DoFHandler<dim>::active_cell_iterator dof_cell(
              &tria, cell->level(), cell->index(), &dof_handler);
            dof_cell->get_dof_indices(rt_dofs);
            std::fill(on_face.begin(), on_face.end(), false);
            std::vector<bool> is_free(fe_flux.n_dofs_per_cell(), true);
            for (const unsigned int f : cell->face_indices())
              {
                bool nonzero = false;
                for (unsigned int w = 0; w < cell->face(f)->n_vertices(); ++w)
                  nonzero |=
                    psi[GeometryInfo<dim>::face_to_cell_vertices(f, w)] != 0.;
                for (unsigned int i = 0; i < fe_flux.n_dofs_per_face(f); ++i)
                  {
                    const unsigned int k = fe_flux.face_to_cell_index(i, f);
                    on_face[k]           = true;
                    is_free[k]           = nonzero;
                  }
              }
            for (unsigned int k = 0; k < fe_flux.n_dofs_per_cell(); ++k)
              if (is_free[k])
                {
                  if (hanging_constraints.is_constrained(rt_dofs[k]))
                    for (const auto &entry :
                         *hanging_constraints.get_constraint_entries(
                           rt_dofs[k]))
                      free.insert(entry.first);
                  else
                    free.insert(rt_dofs[k]);
                }
          }

        std::map<types::global_dof_index, unsigned int> sigma_numbers;
        const auto number = [&](const types::global_dof_index g) {
          const auto inserted =
            sigma_numbers.emplace(g, (unsigned int)patch.sigma_dofs.size());
          if (inserted.second)
            patch.sigma_dofs.push_back(g);
          return inserted.first->second;
        };
        patch.n_q = 0;
        for (const auto &cell : cells)
          {
            PatchCell patch_cell;
            patch_cell.cell = cell;
            patch_cell.hat  = cell_hats.at(cell);
            typename DoFHandler<dim>::active_cell_iterator dof_cell(
              &tria, cell->level(), cell->index(), &dof_handler);
            dof_cell->get_dof_indices(rt_dofs);
            patch_cell.sigma_index.resize(fe_flux.n_dofs_per_cell());
            for (unsigned int k = 0; k < fe_flux.n_dofs_per_cell(); ++k)
              if (hanging_constraints.is_constrained(rt_dofs[k]))
                {
                  for (const auto &[g, w] :
                       *hanging_constraints.get_constraint_entries(rt_dofs[k]))
                    if (free.count(g))
                      patch_cell.sigma_index[k].emplace_back(number(g), w);
                }
              else if (free.count(rt_dofs[k]))
                patch_cell.sigma_index[k].emplace_back(number(rt_dofs[k]), 1.);
            patch_cell.q_offset = patch.n_q;
            patch.n_q += fe_divergence.n_dofs_per_cell();
            patch.cells.push_back(patch_cell);
          }

        // The shape of the patch, normalised by its size: quadrature
        // points relative to a, line orientations, psi_a, free fluxes.
        double h = 0;
        for (const auto &cell : cells)
          h = std::max(h, cell->diameter());
        std::vector<std::int64_t> key = {patch.interior,
                                         std::int64_t(cells.size())};
        for (const auto &patch_cell : patch.cells)
          {
            shape_values.reinit(patch_cell.cell);
            for (const auto &x : shape_values.get_quadrature_points())
              for (unsigned int d = 0; d < dim; ++d)
                key.push_back(std::llround((x[d] - x_a[d]) / h * 1e9));
            for (const unsigned int l : patch_cell.cell->line_indices())
              key.push_back(patch_cell.cell->line_orientation(l));
            for (const double value : patch_cell.hat)
              key.push_back(std::llround(value * 1e9));
            for (const auto &expansion : patch_cell.sigma_index)
              {
                key.push_back(-1);
                for (const auto &[I, w] : expansion)
                  {
                    key.push_back(I);
                    key.push_back(std::llround(w * 1e9));
                  }
              }
          }
        auto &solver = solvers[key];
        if (!solver)
          {
            solver = make_local_solver(patch, cell_matrix_cache);
            ++n_local_solvers;
          }
        patch.solver = solver;

        const unsigned int patch_number = patches.size();
        for (unsigned int c = 0; c < patch.cells.size(); ++c)
          cell_patches[patch.cells[c].cell->active_cell_index()].emplace_back(
            patch_number, c);
        patches.push_back(std::move(patch));
      }
    hats.clear();
  }


  // What a cell contributes to the matrices of the patches it belongs to:
  // the RT mass matrix (tau_j, tau_i)_K, the divergence coupling (div
  // tau_i, q_k)_K and the means (1, q_k)_K, computed once per cell (a cell
  // is in up to 2^dim patches, and FEValues of the RT element on curved
  // cells is the expensive part of a patch matrix).
  template <int dim>
  struct FluxReconstruction<dim>::CellMatrices
  {
    FullMatrix<double> mass;
    FullMatrix<double> divergence; ///< [k][i]
    Vector<double>     mean;
  };


  // The cell matrices computed so far (by active cell index), and the
  // FEValues that compute them, set up once per mesh.
  template <int dim>
  struct FluxReconstruction<dim>::CellMatrixCache
  {
    CellMatrixCache(const FluxReconstruction<dim> &reconstruction,
                    const unsigned int             n_active_cells)
        : flux_values(reconstruction.mapping,
                      reconstruction.fe_flux,
                      reconstruction.quadrature,
                      update_values | update_gradients | update_JxW_values)
        , q_values(reconstruction.mapping,
                   reconstruction.fe_divergence,
                   reconstruction.quadrature,
                   update_values)
        , entries(n_active_cells)
    {
    }

    FEValues<dim>                              flux_values, q_values;
    std::vector<std::unique_ptr<CellMatrices>> entries;
  };


  template <int dim>
  const typename FluxReconstruction<dim>::CellMatrices &
  FluxReconstruction<dim>::cell_matrices(const CellIterator &cell,
                                         CellMatrixCache    &cache) const
  {
    auto &entry = cache.entries[cell->active_cell_index()];
    if (entry)
      return *entry;
    entry                    = std::make_unique<CellMatrices>();
    const unsigned int n_tau = fe_flux.n_dofs_per_cell(),
                       n_q   = fe_divergence.n_dofs_per_cell();
    entry->mass.reinit(n_tau, n_tau);
    entry->divergence.reinit(n_q, n_tau);
    entry->mean.reinit(n_q);

    FEValues<dim>                   &flux_values = cache.flux_values;
    FEValues<dim>                   &q_values    = cache.q_values;
    const FEValuesExtractors::Vector flux(0);
    flux_values.reinit(cell);
    q_values.reinit(cell);
    std::vector<Tensor<1, dim>> tau(n_tau);
    std::vector<double>         div_tau(n_tau);
    for (const unsigned int q : flux_values.quadrature_point_indices())
      {
        const double dx = flux_values.JxW(q);
        for (unsigned int i = 0; i < n_tau; ++i)
          {
            tau[i]     = flux_values[flux].value(i, q);
            div_tau[i] = flux_values[flux].divergence(i, q);
          }
        for (unsigned int i = 0; i < n_tau; ++i)
          for (unsigned int j = 0; j < n_tau; ++j)
            entry->mass(i, j) += tau[i] * tau[j] * dx;
        for (unsigned int k = 0; k < n_q; ++k)
          {
            const double q_k = q_values.shape_value(k, q) * dx;
            entry->mean(k) += q_k;
            for (unsigned int i = 0; i < n_tau; ++i)
              entry->divergence(k, i) += div_tau[i] * q_k;
          }
      }
    return *entry;
  }


  // The matrix of the mixed patch problem, for the unknowns (sigma, gamma,
  // rho): [A B^T 0; B 0 m; 0 m^T 0], A the RT mass matrix, B_{q, tau} =
  // (div tau, q), and for interior patches the multiplier rho of the
  // mean-value condition (gamma, 1) = 0 with m_q = (1, q).
  template <int dim>
  std::shared_ptr<const typename FluxReconstruction<dim>::LocalSolver>
  FluxReconstruction<dim>::make_local_solver(const Patch     &patch,
                                             CellMatrixCache &cache) const
  {
    const unsigned int n_sigma = patch.sigma_dofs.size();
    const unsigned int n       = n_sigma + patch.n_q + (patch.interior ? 1 : 0);
    auto               solver  = std::make_shared<LocalSolver>();
    LAPACKFullMatrix<double> &matrix = solver->lu;
    matrix.reinit(n, n);

    const unsigned int n_tau = fe_flux.n_dofs_per_cell(),
                       n_q   = fe_divergence.n_dofs_per_cell();
    for (const auto &patch_cell : patch.cells)
      {
        const CellMatrices &local = cell_matrices(patch_cell.cell, cache);
        for (unsigned int i = 0; i < n_tau; ++i)
          for (const auto &[I, w_i] : patch_cell.sigma_index[i])
            {
              for (unsigned int j = 0; j < n_tau; ++j)
                for (const auto &[J, w_j] : patch_cell.sigma_index[j])
                  matrix(I, J) += w_i * w_j * local.mass(i, j);
              for (unsigned int k = 0; k < n_q; ++k)
                {
                  const double       b = w_i * local.divergence(k, i);
                  const unsigned int K = n_sigma + patch_cell.q_offset + k;
                  matrix(K, I) += b;
                  matrix(I, K) += b;
                }
            }
        if (patch.interior)
          for (unsigned int k = 0; k < n_q; ++k)
            {
              const unsigned int K = n_sigma + patch_cell.q_offset + k;
              matrix(K, n - 1) += local.mean(k);
              matrix(n - 1, K) += local.mean(k);
            }
      }

    matrix.compute_lu_factorization();
    return solver;
  }


  template <int dim>
  void
  FluxReconstruction<dim>::reconstruct(
    const Sources                                      &sources,
    const std::vector<TrilinosWrappers::MPI::Vector *> &sigma) const
  {
    const MPI_Comm     comm     = dof_handler.get_communicator();
    const unsigned int n_fields = sources.n_fields;
    AssertDimension(sigma.size(), n_fields);

    // Right-hand sides of all patches, one column per field.
    std::vector<LAPACKFullMatrix<double>> rhs(patches.size());
    for (unsigned int p = 0; p < patches.size(); ++p)
      rhs[p].reinit(patches[p].solver->lu.m(), n_fields);

    FEValues<dim> flux_values(mapping,
                              fe_flux,
                              quadrature,
                              update_values | update_JxW_values);
    FEValues<dim> hat_values(mapping,
                             fe_hat,
                             quadrature,
                             update_values | update_gradients);
    FEValues<dim> q_values(mapping, fe_divergence, quadrature, update_values);
    const FEValuesExtractors::Vector         flux_extractor(0);
    std::vector<std::vector<Tensor<1, dim>>> flux(
      n_fields, std::vector<Tensor<1, dim>>(quadrature.size()));
    std::vector<std::vector<double>> source(
      n_fields, std::vector<double>(quadrature.size()));
    std::vector<Tensor<1, dim>> tau(fe_flux.n_dofs_per_cell());

    // One pass over the cells: each cell adds its part of the right-hand
    // sides of the patches it belongs to.
    for (const auto &cell :
         dof_handler.get_triangulation().active_cell_iterators())
      {
        if (cell->is_artificial())
          continue;
        const auto &memberships = cell_patches[cell->active_cell_index()];
        if (memberships.empty())
          continue;
        flux_values.reinit(cell);
        hat_values.reinit(cell);
        q_values.reinit(cell);
        sources.cell_values(cell, flux, source);

        for (const unsigned int q : flux_values.quadrature_point_indices())
          {
            const double dx = flux_values.JxW(q);
            for (const unsigned int j : flux_values.dof_indices())
              tau[j] = flux_values[flux_extractor].value(j, q);
            for (const auto &[p, c] : memberships)
              {
                const Patch       &patch      = patches[p];
                const PatchCell   &patch_cell = patch.cells[c];
                const unsigned int n_sigma    = patch.sigma_dofs.size();
                double             psi        = 0;
                Tensor<1, dim>     grad_psi;
                for (unsigned int v = 0; v < patch_cell.hat.size(); ++v)
                  if (patch_cell.hat[v] != 0.)
                    {
                      psi += patch_cell.hat[v] * hat_values.shape_value(v, q);
                      grad_psi +=
                        patch_cell.hat[v] * hat_values.shape_grad(v, q);
                    }
                for (unsigned int f = 0; f < n_fields; ++f)
                  {
                    const double c_a =
                      sources.vertex_source ?
                        sources.vertex_source(patch.vertex, f) :
                        0.;
                    const Tensor<1, dim> weighted_flux = psi * dx * flux[f][q];
                    for (const unsigned int j : flux_values.dof_indices())
                      for (const auto &[J, w] : patch_cell.sigma_index[j])
                        rhs[p](J, f) -= w * (weighted_flux * tau[j]);
                    const double g =
                      ((source[f][q] + c_a) * psi - flux[f][q] * grad_psi) * dx;
                    for (unsigned int k = 0;
                         k < fe_divergence.n_dofs_per_cell();
                         ++k)
                      rhs[p](n_sigma + patch_cell.q_offset + k, f) +=
                        g * q_values.shape_value(k, q);
                  }
              }
          }
      }

    std::vector<TrilinosWrappers::MPI::Vector> accumulated(n_fields);
    for (auto &v : accumulated)
      v.reinit(owned_dofs, relevant_dofs, comm, /*vector_writable=*/true);
    std::vector<double> values;
    for (unsigned int p = 0; p < patches.size(); ++p)
      {
        // The patch solution overwrites its right-hand sides.
        LAPACKFullMatrix<double> &solution = rhs[p];
        patches[p].solver->lu.solve(solution);
        const unsigned int n_sigma = patches[p].sigma_dofs.size();
        values.resize(n_sigma);
        for (unsigned int f = 0; f < n_fields; ++f)
          {
            for (unsigned int j = 0; j < n_sigma; ++j)
              values[j] = solution(j, f);
            accumulated[f].add(patches[p].sigma_dofs, values);
          }
      }
    // The fluxes on the fine side of hanging faces from the coarse side.
    TrilinosWrappers::MPI::Vector owned(owned_dofs, comm);
    for (unsigned int f = 0; f < n_fields; ++f)
      {
        accumulated[f].compress(VectorOperation::add);
        for (const auto i : owned_dofs)
          owned(i) = accumulated[f](i);
        owned.compress(VectorOperation::insert);
        hanging_constraints.distribute(owned);
        sigma[f]->reinit(owned_dofs, relevant_dofs, comm);
        *sigma[f] = owned;
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
  const IndexSet &
  FluxReconstruction<dim>::locally_relevant_dofs() const
  {
    return relevant_dofs;
  }


  template <int dim>
  std::pair<unsigned int, unsigned int>
  FluxReconstruction<dim>::statistics() const
  {
    return {patches.size(), n_local_solvers};
  }


  template class FluxReconstruction<2>;
} // namespace VI
