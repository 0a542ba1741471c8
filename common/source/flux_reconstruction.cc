#include <deal.II/base/geometry_info.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/vector.h>

#include <vi/flux_reconstruction.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>

namespace VI
{
  using namespace dealii;

  // The inverse of a patch matrix: the patch problems of every field and
  // every iterate are then one matrix product (BLAS) each.
  template <int dim>
  struct FluxReconstruction<dim>::LocalSolver
  {
    LAPACKFullMatrix<double> inverse;
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
    const Triangulation<dim> &tria = potential.get_triangulation();
    AssertThrow(!tria.has_hanging_nodes(),
                ExcMessage("The flux reconstruction on vertex patches needs "
                           "a mesh without hanging nodes."));

    dof_handler.reinit(tria);
    dof_handler.distribute_dofs(fe_flux);
    owned_dofs = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_dofs);

    patches.clear();
    cell_patches.assign(tria.n_active_cells(), {});
    n_local_solvers = 0;

    const auto      vertex_cells    = GridTools::vertex_to_cell_map(tria);
    const IndexSet &owned_potential = potential.locally_owned_dofs();

    // Boundary vertices: those of boundary faces.
    std::vector<bool> at_boundary(tria.n_vertices(), false);
    for (const auto &cell : tria.active_cell_iterators())
      if (!cell->is_artificial())
        for (const unsigned int f : cell->face_indices())
          if (cell->face(f)->at_boundary())
            for (unsigned int v = 0; v < cell->face(f)->n_vertices(); ++v)
              at_boundary[cell->face(f)->vertex_index(v)] = true;

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

    std::vector<bool>                    visited(tria.n_vertices(), false);
    std::vector<types::global_dof_index> rt_dofs(fe_flux.n_dofs_per_cell());
    for (const auto &potential_cell : potential.active_cell_iterators())
      if (potential_cell->is_locally_owned())
        for (const unsigned int v : potential_cell->vertex_indices())
          {
            const unsigned int a = potential_cell->vertex_index(v);
            if (visited[a] || !owned_potential.is_element(
                                potential_cell->vertex_dof_index(v, 0)))
              continue;
            visited[a] = true;

            Patch patch;
            patch.vertex          = a;
            patch.interior        = !at_boundary[a];
            const Point<dim> &x_a = tria.get_vertices()[a];

            // Cells in a canonical order (by angle around a), so that
            // patches of the same shape get the same local numbering.
            std::vector<CellIterator> cells(vertex_cells[a].begin(),
                                            vertex_cells[a].end());
            std::sort(cells.begin(),
                      cells.end(),
                      [&](const CellIterator &c1, const CellIterator &c2) {
                        const auto d1 = c1->center() - x_a,
                                   d2 = c2->center() - x_a;
                        return std::atan2(d1[1], d1[0]) <
                               std::atan2(d2[1], d2[0]);
                      });

            std::map<types::global_dof_index, int> sigma_numbers;
            patch.n_q = 0;
            for (const auto &cell : cells)
              {
                PatchCell patch_cell;
                patch_cell.cell         = cell;
                patch_cell.local_vertex = numbers::invalid_unsigned_int;
                for (const unsigned int w : cell->vertex_indices())
                  if (cell->vertex_index(w) == a)
                    patch_cell.local_vertex = w;
                Assert(patch_cell.local_vertex != numbers::invalid_unsigned_int,
                       ExcInternalError());

                typename DoFHandler<dim>::active_cell_iterator dof_cell(
                  &tria, cell->level(), cell->index(), &dof_handler);
                dof_cell->get_dof_indices(rt_dofs);

                // Zero normal flux on the faces away from a (where psi_a
                // vanishes): the outer boundary of the patch.
                std::vector<bool> fixed(fe_flux.n_dofs_per_cell(), false);
                for (const unsigned int f : cell->face_indices())
                  {
                    bool contains_a = false;
                    for (unsigned int w = 0; w < cell->face(f)->n_vertices();
                         ++w)
                      contains_a |= (cell->face(f)->vertex_index(w) == a);
                    if (!contains_a)
                      for (unsigned int i = 0; i < fe_flux.n_dofs_per_face(f);
                           ++i)
                        fixed[fe_flux.face_to_cell_index(i, f)] = true;
                  }
                patch_cell.sigma_index.resize(fe_flux.n_dofs_per_cell());
                for (unsigned int j = 0; j < fe_flux.n_dofs_per_cell(); ++j)
                  if (fixed[j])
                    patch_cell.sigma_index[j] = -1;
                  else
                    {
                      const auto inserted =
                        sigma_numbers.emplace(rt_dofs[j],
                                              int(patch.sigma_dofs.size()));
                      if (inserted.second)
                        patch.sigma_dofs.push_back(rt_dofs[j]);
                      patch_cell.sigma_index[j] = inserted.first->second;
                    }
                patch_cell.q_offset = patch.n_q;
                patch.n_q += fe_divergence.n_dofs_per_cell();
                patch.cells.push_back(patch_cell);
              }

            // The shape of the patch, normalised by its size: quadrature
            // points relative to a, line orientations, fixed fluxes.
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
                for (const int i : patch_cell.sigma_index)
                  key.push_back(i);
              }
            auto &solver = solvers[key];
            if (!solver)
              {
                solver = make_local_solver(patch);
                ++n_local_solvers;
              }
            patch.solver = solver;

            const unsigned int patch_number = patches.size();
            for (unsigned int c = 0; c < patch.cells.size(); ++c)
              cell_patches[patch.cells[c].cell->active_cell_index()]
                .emplace_back(patch_number, c);
            patches.push_back(std::move(patch));
          }
  }


  // The matrix of the mixed patch problem, for the unknowns (sigma, gamma,
  // rho): [A B^T 0; B 0 m; 0 m^T 0], A the RT mass matrix, B_{q, tau} =
  // (div tau, q), and for interior patches the multiplier rho of the
  // mean-value condition (gamma, 1) = 0 with m_q = (1, q).
  template <int dim>
  std::shared_ptr<const typename FluxReconstruction<dim>::LocalSolver>
  FluxReconstruction<dim>::make_local_solver(const Patch &patch) const
  {
    const unsigned int n_sigma = patch.sigma_dofs.size();
    const unsigned int n       = n_sigma + patch.n_q + (patch.interior ? 1 : 0);
    auto               solver  = std::make_shared<LocalSolver>();
    LAPACKFullMatrix<double> &matrix = solver->inverse;
    matrix.reinit(n, n);

    FEValues<dim> flux_values(mapping,
                              fe_flux,
                              quadrature,
                              update_values | update_gradients |
                                update_JxW_values);
    FEValues<dim> q_values(mapping, fe_divergence, quadrature, update_values);
    const FEValuesExtractors::Vector flux(0);

    for (const auto &patch_cell : patch.cells)
      {
        flux_values.reinit(patch_cell.cell);
        q_values.reinit(patch_cell.cell);
        for (const unsigned int q : flux_values.quadrature_point_indices())
          {
            const double dx = flux_values.JxW(q);
            for (const unsigned int i : flux_values.dof_indices())
              {
                const int I = patch_cell.sigma_index[i];
                if (I < 0)
                  continue;
                const auto   tau_i = flux_values[flux].value(i, q);
                const double div_i = flux_values[flux].divergence(i, q);
                for (const unsigned int j : flux_values.dof_indices())
                  {
                    const int J = patch_cell.sigma_index[j];
                    if (J >= 0)
                      matrix(I, J) +=
                        tau_i * flux_values[flux].value(j, q) * dx;
                  }
                for (unsigned int k = 0; k < fe_divergence.n_dofs_per_cell();
                     ++k)
                  {
                    const double b = div_i * q_values.shape_value(k, q) * dx;
                    const unsigned int K = n_sigma + patch_cell.q_offset + k;
                    matrix(K, I) += b;
                    matrix(I, K) += b;
                  }
              }
            if (patch.interior)
              for (unsigned int k = 0; k < fe_divergence.n_dofs_per_cell(); ++k)
                {
                  const double       m = q_values.shape_value(k, q) * dx;
                  const unsigned int K = n_sigma + patch_cell.q_offset + k;
                  matrix(K, n - 1) += m;
                  matrix(n - 1, K) += m;
                }
          }
      }

    matrix.invert();
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
      rhs[p].reinit(patches[p].solver->inverse.m(), n_fields);

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
                const unsigned int v          = patch_cell.local_vertex;
                const double       psi        = hat_values.shape_value(v, q);
                const auto         grad_psi   = hat_values.shape_grad(v, q);
                for (unsigned int f = 0; f < n_fields; ++f)
                  {
                    const double c_a =
                      sources.vertex_source ?
                        sources.vertex_source(patch.vertex, f) :
                        0.;
                    const Tensor<1, dim> weighted_flux = psi * dx * flux[f][q];
                    for (const unsigned int j : flux_values.dof_indices())
                      {
                        const int J = patch_cell.sigma_index[j];
                        if (J >= 0)
                          rhs[p](J, f) -= weighted_flux * tau[j];
                      }
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
    LAPACKFullMatrix<double> solution;
    std::vector<double>      values;
    for (unsigned int p = 0; p < patches.size(); ++p)
      {
        const auto &inverse = patches[p].solver->inverse;
        solution.reinit(inverse.m(), n_fields);
        inverse.mmult(solution, rhs[p]);
        const unsigned int n_sigma = patches[p].sigma_dofs.size();
        values.resize(n_sigma);
        for (unsigned int f = 0; f < n_fields; ++f)
          {
            for (unsigned int j = 0; j < n_sigma; ++j)
              values[j] = solution(j, f);
            accumulated[f].add(patches[p].sigma_dofs, values);
          }
      }
    for (unsigned int f = 0; f < n_fields; ++f)
      {
        accumulated[f].compress(VectorOperation::add);
        sigma[f]->reinit(owned_dofs, relevant_dofs, comm);
        *sigma[f] = accumulated[f];
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
