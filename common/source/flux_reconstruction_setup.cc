// The set-up of FluxReconstruction on a mesh, reinit(), phase by phase:
// the hat functions' shares of the owned cells, their exchange between the
// ranks, the patch layouts and the patch solvers (see Setup).

#include <deal.II/base/geometry_info.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/parallel.h>
#include <deal.II/base/partitioner.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/affine_constraints.h>

#include <vi/flux_reconstruction.h>
#include <vi/piola_divergence.h>
#include <vi/same_cell.h>

#include "flux_reconstruction_internal.h"
#include "flux_reconstruction_shares.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <mutex>
#include <numeric>

namespace VI
{
  using namespace dealii;

  // The phases of reinit(), in their order, and what each hands on to the
  // next: the Raviart-Thomas space and the hat functions, the data of the
  // owned cells and the shares of the hat functions psi_a on them, the
  // exchange of the shares with the ranks that solve their patches, the
  // shares solved here grouped by patch, the patch layouts (in chunks on
  // all threads), the patches and their solvers in the order of the
  // patches, the factorisations of the new solvers, and where the fluxes
  // are summed.
  template <int dim>
  struct FluxReconstruction<dim>::Setup
  {
    static constexpr unsigned int n_v = GeometryInfo<dim>::vertices_per_cell;

    /// A share solved here: the rank it came from and its index in that
    /// rank's Shares.
    struct ShareHere
    {
      unsigned int from, index;
    };

    /// What the patches of a chunk find, gathered after in the order of the
    /// patches.
    struct PatchChunk
    {
      std::vector<Patch> patches; ///< starts relative to the chunk
      std::vector<std::shared_ptr<const PatchLayout>> layouts;
      /// the global dofs of the patch unknowns as they are numbered, and
      /// those of them that are not relevant here
      std::vector<types::global_dof_index> dofs, beyond;
      /// per cell of each patch, in order: (psi_a, q_k)_K, the metric, and
      /// where its share came from
      std::vector<double>    hat_masses, metrics;
      std::vector<ShareHere> cells;
    };
    static constexpr unsigned int chunk_size = 1024;

    /// A cell of the current patch: its data (cell `cell` of `table`),
    /// psi_a on it, where its share came from, and its polar coordinates
    /// around the vertex.
    struct Member
    {
      std::pair<double, double> polar;
      const CellTable          *table;
      std::size_t               cell;
      const double             *hat;
      ShareHere                 share;

      bool
      operator<(const Member &other) const
      {
        return polar < other.polar;
      }
    };

    /// The free dofs of the current patch and their numbers (unnumbered
    /// until first met).
    static constexpr unsigned int not_free   = numbers::invalid_unsigned_int;
    static constexpr unsigned int unnumbered = not_free - 1;

    /// One thread's work space for the patches of its chunks.
    struct PatchScratch
    {
      explicit PatchScratch(const unsigned int n_tau)
          : is_free(n_tau)
      {
      }

      std::vector<Member> members;
      /// (a patch has a few dozen)
      std::vector<std::pair<types::global_dof_index, unsigned int>> free_dofs;
      std::vector<bool>                                             is_free;
      std::vector<std::int64_t>                                     layout_key;
      std::vector<const std::int8_t *> signs_of_cells;
      PatchLayout                      layout; // of the current patch
      Layouts                          cache;

      auto
      find_free(const types::global_dof_index g)
      {
        return std::find_if(free_dofs.begin(),
                            free_dofs.end(),
                            [g](const auto &entry) {
                              return entry.first == g;
                            });
      }
    };

    /// A new solver, made (when not shared) and factorised after the loop
    /// over the patches on all cores: the patch, its layout and its cells'
    /// metrics.
    struct NewSolver
    {
      std::size_t                               patch;
      LocalSolver                              *shared; ///< or to be made
      const std::shared_ptr<const PatchLayout> *layout;
      const double                             *metrics;
      std::size_t                               storage_start = 0;
    };

    Setup(FluxReconstruction<dim>            &reconstruction,
          const DoFHandler<dim>              &potential,
          const std::set<types::boundary_id> &free_boundary_ids)
        : reconstruction(reconstruction)
        , free_boundary_ids(free_boundary_ids)
        , tria(potential.get_triangulation())
        , comm(potential.get_communicator())
        , rank(Utilities::MPI::this_mpi_process(comm))
        , n_rank(Utilities::MPI::n_mpi_processes(comm))
        , n_tau(reconstruction.fe_flux.n_dofs_per_cell())
        , n_q(reconstruction.fe_divergence.n_dofs_per_cell())
    {
    }

    // The Raviart-Thomas space with its constraints (hanging nodes, and
    // sigma . n = 0 on the free boundary), the previous mesh's patches
    // cleared, and the hat functions.
    void
    distribute_dofs()
    {
      FluxReconstruction<dim> &r = reconstruction;
      r.dof_handler.reinit(tria);
      r.dof_handler.distribute_dofs(r.fe_flux);
      r.owned_dofs = r.dof_handler.locally_owned_dofs();
      DoFTools::extract_locally_relevant_dofs(r.dof_handler, r.relevant_dofs);
      r.ghosted_fluxes.reinit(r.owned_dofs, r.relevant_dofs, comm);
      flux_constraints.reinit(r.relevant_dofs);
      DoFTools::make_hanging_node_constraints(r.dof_handler, flux_constraints);
      // Where the membranes are free, the fluxes carry their zero normal
      // derivative: the face dofs (normal moments) there are zero. A patch
      // whose boundary faces are all free is then closed like an interior
      // one, and compatible, since its vertex is not a Dirichlet node.
      std::vector<types::global_dof_index> face_dofs(
        r.fe_flux.n_dofs_per_face());
      if (!free_boundary_ids.empty())
        for (const auto &cell : r.dof_handler.active_cell_iterators())
          if (!cell->is_artificial())
            for (const unsigned int f : cell->face_indices())
              if (cell->face(f)->at_boundary() &&
                  free_boundary_ids.count(cell->face(f)->boundary_id()))
                {
                  cell->face(f)->get_dof_indices(face_dofs);
                  for (const types::global_dof_index i : face_dofs)
                    if (!flux_constraints.is_constrained(i))
                      flux_constraints.add_line(i);
                }
      flux_constraints.close();

      r.patches.clear();
      r.hat_masses.clear();
      r.membership_start.clear();
      r.memberships.clear();
      r.hanging_hats.clear();
      r.n_sent.clear();
      r.received.clear();
      r.local_solvers.clear();
      r.product_storage.reset();
      r.n_reconstructions = 0;

      // The conforming hat functions: Q1 with its hanging node constraints,
      // one patch per unconstrained (regular) vertex, numbered by its degree
      // of freedom and solved by the owner of that degree of freedom (who
      // owns a cell at the vertex).
      hats.reinit(tria);
      hats.distribute_dofs(r.fe_hat);
      DoFTools::extract_locally_relevant_dofs(hats, relevant_hats);
      hat_constraints.reinit(relevant_hats);
      DoFTools::make_hanging_node_constraints(hats, hat_constraints);
      hat_constraints.close();

      // The Piola signs, for the patch layouts, the right-hand sides of
      // reconstruct() and the estimators, from the mesh (no Raviart-Thomas
      // FEValues, see PiolaDivergence::topological_signs).
      r.piola_signs.assign(std::size_t(tria.n_active_cells()) * n_tau, 0);
      r.cell_metric.assign(std::size_t(tria.n_active_cells()) * n_metric, 0.);
    }

    // The data and shares of the owned cells, psi_j on a cell being the Q1
    // function with value 1 at the vertex of j and the constraint weights
    // at the hanging vertices that depend on j. First the cells' data, on
    // all threads (each cell writes its own entries).
    void
    compute_cell_data()
    {
      FluxReconstruction<dim> &r = reconstruction;
      for (const auto &hat_cell : hats.active_cell_iterators())
        if (hat_cell->is_locally_owned())
          owned_cells.push_back(hat_cell);
      CellTable &table = mine.cells;
      table.reinit(n_tau, n_q, owned_cells.size());
      std::vector<types::global_dof_index> rt_dofs(owned_cells.size() * n_tau);

      parallel::apply_to_subranges(
        std::size_t(0),
        owned_cells.size(),
        [&](const std::size_t begin, const std::size_t end) {
          // (The Jacobians from the Q1 element: in deal.II 9.4 an FEValues of
          // a Raviart-Thomas element that asks for mapping data only trips
          // over the face sign changes of unstructured meshes, deal.II PR
          // 15963.)
          FEValues<dim>                        hat_values(r.mapping,
                                   r.fe_hat,
                                   r.quadrature,
                                   update_values | update_jacobians |
                                     update_JxW_values);
          std::vector<types::global_dof_index> cell_dofs(n_tau);
          for (std::size_t c = begin; c < end; ++c)
            {
              const CellIterator cell(owned_cells[c]);
              for (unsigned int d = 0; d < dim; ++d)
                table.centers[c * dim + d] = cell->center()[d];
              same_cell(cell, r.dof_handler)->get_dof_indices(cell_dofs);
              std::copy(cell_dofs.begin(),
                        cell_dofs.end(),
                        &rt_dofs[c * n_tau]);
              std::int8_t *const cell_signs =
                &r.piola_signs[cell->active_cell_index() * n_tau];
              PiolaDivergence<dim>::topological_signs(
                cell, r.fe_flux, ArrayView<std::int8_t>(cell_signs, n_tau));
              std::copy_n(cell_signs, n_tau, &table.signs[c * n_tau]);
              hat_values.reinit(cell);
              double *const  vertex_mass = &table.vertex_masses[c * n_v * n_q];
              Tensor<2, dim> mean_jacobian;
              for (const unsigned int q : hat_values.quadrature_point_indices())
                {
                  for (unsigned int v = 0; v < n_v; ++v)
                    for (unsigned int k = 0; k < n_q; ++k)
                      vertex_mass[v * n_q + k] += hat_values.shape_value(v, q) *
                                                  r.q_reference[q * n_q + k] *
                                                  hat_values.JxW(q);
                  mean_jacobian += r.quadrature.weight(q) *
                                   Tensor<2, dim>(hat_values.jacobian(q));
                }
              // G = J^T J / det J of the mean Jacobian (the jacobian of a
              // bilinear cell at its center)
              const Tensor<2, dim> G = transpose(mean_jacobian) *
                                       mean_jacobian /
                                       determinant(mean_jacobian);
              double *const metric =
                &r.cell_metric[cell->active_cell_index() * n_metric];
              for (unsigned int a = 0, m = 0; a < dim; ++a)
                for (unsigned int b = a; b < dim; ++b, ++m)
                  metric[m] = G[a][b];
              std::copy_n(metric, n_metric, &table.metrics[c * n_metric]);
            }
        },
        /*grainsize=*/1024);
      // the expansions, in the order of the cells (one entry per dof away
      // from hanging faces)
      table.expansion.reserve(rt_dofs.size());
      for (const types::global_dof_index dof : rt_dofs)
        table.add_expansion(dof, flux_constraints);
    }

    // The shares psi_j of the owned cells, in the order of the cells, and the
    // vertices of the unconstrained hats.
    void
    compute_hat_shares()
    {
      vertex_of.assign(relevant_hats.n_elements(),
                       numbers::invalid_unsigned_int);
      std::vector<std::pair<types::global_dof_index, std::array<double, n_v>>>
        psi;
      // (n_v shares per cell away from hanging vertices: reserved, the
      // arrays are not grown by doubling)
      mine.patch.reserve(owned_cells.size() * n_v);
      mine.cell.reserve(owned_cells.size() * n_v);
      mine.hat.reserve(owned_cells.size() * n_v * n_v);
      parts.reserve(owned_cells.size() * n_v);
      for (std::size_t c = 0; c < owned_cells.size(); ++c)
        {
          const auto &hat_cell = owned_cells[c];
          psi.clear();
          for (const unsigned int v : hat_cell->vertex_indices())
            {
              const auto i   = hat_cell->vertex_dof_index(v, 0);
              const auto add = [&](const types::global_dof_index j,
                                   const double                  w) {
                auto entry =
                  std::find_if(psi.begin(), psi.end(), [j](const auto &e) {
                    return e.first == j;
                  });
                if (entry == psi.end())
                  entry = psi.insert(psi.end(), {j, std::array<double, n_v>{}});
                entry->second[v] = w;
              };
              if (hat_constraints.is_constrained(i))
                for (const auto &[j, w] :
                     *hat_constraints.get_constraint_entries(i))
                  add(j, w);
              else
                {
                  add(i, 1.);
                  vertex_of[relevant_hats.index_within_set(i)] =
                    hat_cell->vertex_index(v);
                }
            }
          for (const auto &[j, values] : psi)
            mine.add(j, c, values.data());
        }
    }

    // The shares of patches solved elsewhere go to their ranks, with the
    // data of their cells; the others stay. The hats of the shares are all
    // in relevant_hats, whose order lists them sorted once marked (a sort
    // of one entry per share would cost more; IndexSet::add_index inserts
    // into a sorted list: sorted ranges go in at once).
    void
    exchange_shares()
    {
      IndexSet patch_hats(hats.n_dofs());
      {
        std::vector<bool> marked(relevant_hats.n_elements(), false);
        for (const types::global_dof_index j : mine.patch)
          {
            const auto position = relevant_hats.index_within_set(j);
            AssertIndexRange(position, marked.size());
            marked[position] = true;
          }
        std::vector<types::global_dof_index> in_order;
        auto                                 hat = relevant_hats.begin();
        for (std::size_t k = 0; k < marked.size(); ++k, ++hat)
          if (marked[k])
            in_order.push_back(*hat);
        patch_hats.add_indices(in_order.begin(), in_order.end());
      }
      const std::vector<unsigned int> owners =
        Utilities::MPI::compute_index_owner(hats.locally_owned_dofs(),
                                            patch_hats,
                                            comm);
      std::map<unsigned int, Shares>                                outgoing;
      std::map<std::pair<unsigned int, unsigned int>, unsigned int> sent_cell;
      for (unsigned int i = 0; i < mine.patch.size(); ++i)
        {
          const unsigned int owner =
            owners[patch_hats.index_within_set(mine.patch[i])];
          const double *hat = &mine.hat[i * n_v];
          if (owner == rank)
            {
              solved_here.push_back(i);
              continue;
            }
          Shares    &to = outgoing[owner];
          const auto sent =
            sent_cell.emplace(std::make_pair(owner, mine.cell[i]),
                              to.cells.size());
          if (sent.second)
            to.cells.append(mine.cells, mine.cell[i]);
          to.add(mine.patch[i], sent.first->second, hat);
          add_part(owned_cells[mine.cell[i]]->active_cell_index(),
                   {owner, reconstruction.n_sent[owner]++, 0, 0},
                   hat);
        }
      if (n_rank > 1)
        incoming = Utilities::MPI::some_to_some(comm, outgoing);
      outgoing.clear();
    }

    // visit(position of the patch dof in relevant_hats, rank, index) for the
    // shares solved here: by rank, mine among the others, and by index in
    // that rank's Shares.
    template <class Visit>
    void
    for_each_share_here(const Visit &visit) const
    {
      const auto visit_mine = [&]() {
        for (const unsigned int i : solved_here)
          visit(relevant_hats.index_within_set(mine.patch[i]), rank, i);
      };
      bool mine_visited = false;
      for (const auto &[from, shares] : incoming)
        {
          if (!mine_visited && from > rank)
            {
              visit_mine();
              mine_visited = true;
            }
          for (unsigned int i = 0; i < shares.patch.size(); ++i)
            visit(relevant_hats.index_within_set(shares.patch[i]), from, i);
        }
      if (!mine_visited)
        visit_mine();
    }

    // The shares solved here, grouped by patch in the order of the patch
    // dofs and, within a patch, by rank and index in that rank's Shares: a
    // counting sort on the positions of the patch dofs in relevant_hats
    // (where they all are: on cells here, or owned here).
    void
    group_shares_here()
    {
      group_start.assign(relevant_hats.n_elements() + 1, 0);
      for_each_share_here(
        [&](const std::size_t position,
            const unsigned int,
            const unsigned int) { ++group_start[position + 1]; });
      std::partial_sum(group_start.begin(),
                       group_start.end(),
                       group_start.begin());
      shares_here.resize(group_start.back());
      {
        std::vector<std::size_t> next(group_start.begin(),
                                      group_start.end() - 1);
        for_each_share_here([&](const std::size_t  position,
                                const unsigned int from,
                                const unsigned int index) {
          shares_here[next[position]++] = {from, index};
        });
      }
      // the patches solved here, by the positions of their dofs
      for (unsigned int i = 0; i < relevant_hats.n_elements(); ++i)
        if (group_start[i + 1] > group_start[i])
          patches_here.push_back(i);
      for (const auto &[from, shares] : incoming)
        reconstruction.received[from].resize(shares.patch.size());
    }

    // The patches, in chunks on all threads: per patch, its cells (data,
    // psi_a, where the share came from) in a canonical order, its unknowns,
    // their numbering and its layout. What a chunk finds is gathered after,
    // in the order of the patches, so that nothing depends on the threads.
    // The cells' data are not needed after.
    void
    lay_out_patches()
    {
      chunks.resize((patches_here.size() + chunk_size - 1) / chunk_size);
      parallel::apply_to_subranges(
        std::size_t(0),
        chunks.size(),
        [&](const std::size_t first_chunk, const std::size_t end_chunk) {
          PatchScratch scratch(n_tau);
          for (std::size_t ch = first_chunk; ch < end_chunk; ++ch)
            {
              PatchChunk       &chunk = chunks[ch];
              const std::size_t end_patch =
                std::min<std::size_t>((ch + 1) * chunk_size,
                                      patches_here.size());
              // (the positions without patches have no shares)
              const std::size_t n_patches = end_patch - ch * chunk_size,
                                n_cells =
                                  group_start[patches_here[end_patch - 1] + 1] -
                                  group_start[patches_here[ch * chunk_size]];
              chunk.patches.reserve(n_patches);
              chunk.layouts.reserve(n_patches);
              chunk.hat_masses.reserve(n_cells * n_q);
              chunk.metrics.reserve(n_cells * n_metric);
              chunk.cells.reserve(n_cells);
              for (std::size_t p = ch * chunk_size; p < end_patch; ++p)
                lay_out_patch(chunk, p, scratch);
            }
        },
        /*grainsize=*/1);
      mine.cells = CellTable();
      for (auto &[from, shares] : incoming)
        shares.cells = CellTable();
    }

    // Patch p of those solved here: its cells, unknowns and layout, added to
    // its chunk.
    void
    lay_out_patch(PatchChunk &chunk, const std::size_t p, PatchScratch &scratch)
    {
      const unsigned int position = patches_here[p];
      const unsigned int a        = vertex_of[position];
      Patch              patch;
      patch.vertex          = a;
      patch.dofs_start      = chunk.dofs.size();
      patch.hat_mass        = nullptr; // (set once the chunk is done)
      const Point<dim> &x_a = tria.get_vertices()[a];

      order_cells(position, x_a, scratch);
      mark_free_dofs(scratch);
      number_unknowns(chunk, patch, scratch);
      chunk.layouts.push_back(
        reconstruction.shared_layout(scratch.layout,
                                     scratch.signs_of_cells,
                                     scratch.cache,
                                     layouts,
                                     layouts_mutex,
                                     scratch.layout_key));
      chunk.patches.push_back(std::move(patch));
    }

    // Cells in a canonical order (by angle around a, then distance), so that
    // patches of the same shape get the same local numbering.
    void
    order_cells(const unsigned int position,
                const Point<dim>  &x_a,
                PatchScratch      &scratch) const
    {
      std::vector<Member> &members = scratch.members;
      members.clear();
      for (std::size_t s = group_start[position]; s < group_start[position + 1];
           ++s)
        {
          const ShareHere share = shares_here[s];
          const Shares   &shares =
            share.from == rank ? mine : incoming.at(share.from);
          Member member;
          member.table = &shares.cells;
          member.cell  = shares.cell[share.index];
          member.hat   = &shares.hat[share.index * n_v];
          member.share = share;
          Tensor<1, dim> d;
          for (unsigned int k = 0; k < dim; ++k)
            d[k] = member.table->centers[member.cell * dim + k] - x_a[k];
          member.polar = {std::atan2(d[1], d[0]), d.norm()};
          members.push_back(member);
        }
      std::sort(members.begin(), members.end());
    }

    // The free fluxes: the dofs on faces where psi_a does not vanish (the
    // others carry sigma^a . n = 0), or their parents on the coarse side of
    // a hanging face; and the dofs inside the cells. They are marked here
    // (unnumbered), then numbered as first met in the cells' order.
    void
    mark_free_dofs(PatchScratch &scratch) const
    {
      const FE_RaviartThomas<dim> &fe_flux = reconstruction.fe_flux;
      std::vector<bool>           &is_free = scratch.is_free;
      scratch.free_dofs.clear();
      for (const Member &member : scratch.members)
        {
          std::fill(is_free.begin(), is_free.end(), true);
          for (const unsigned int f : GeometryInfo<dim>::face_indices())
            {
              bool nonzero = false;
              for (unsigned int w = 0; w < GeometryInfo<dim>::vertices_per_face;
                   ++w)
                nonzero |=
                  member.hat[GeometryInfo<dim>::face_to_cell_vertices(f, w)] !=
                  0.;
              for (unsigned int i = 0; i < fe_flux.n_dofs_per_face(f); ++i)
                is_free[fe_flux.face_to_cell_index(i, f)] = nonzero;
            }
          for (unsigned int k = 0; k < n_tau; ++k)
            if (is_free[k])
              for (const auto &[g, w] :
                   member.table->expansion_of(member.cell, k))
                if (scratch.find_free(g) == scratch.free_dofs.end())
                  scratch.free_dofs.emplace_back(g, unnumbered);
        }
    }

    // sigma^a's unknowns are the free dofs, numbered as first met: the
    // patch's layout (without its basis) and its cells' parts of the chunk,
    // (psi_a, q_k)_K, the metrics and where the shares came from.
    void
    number_unknowns(PatchChunk   &chunk,
                    const Patch  &patch,
                    PatchScratch &scratch) const
    {
      const auto local_number = [&](const types::global_dof_index g) {
        const auto entry = scratch.find_free(g);
        if (entry == scratch.free_dofs.end())
          return not_free;
        if (entry->second == unnumbered)
          {
            entry->second = chunk.dofs.size() - patch.dofs_start;
            chunk.dofs.push_back(g);
            if (!reconstruction.relevant_dofs.is_element(g))
              chunk.beyond.push_back(g);
          }
        return entry->second;
      };
      PatchLayout &layout = scratch.layout;
      layout.n_cells      = scratch.members.size();
      layout.sigma_start.clear();
      layout.sigma_entries.clear();
      scratch.signs_of_cells.clear();
      for (const Member &member : scratch.members)
        {
          for (unsigned int k = 0; k < n_tau; ++k)
            {
              layout.sigma_start.push_back(layout.sigma_entries.size());
              for (const auto &[g, w] :
                   member.table->expansion_of(member.cell, k))
                if (const unsigned int I = local_number(g); I != not_free)
                  layout.sigma_entries.emplace_back(I, w);
            }
          layout.sigma_start.push_back(layout.sigma_entries.size());
          const CellTable  &table = *member.table;
          const std::size_t start = chunk.hat_masses.size();
          chunk.hat_masses.resize(start + n_q, 0.);
          for (unsigned int v = 0; v < n_v; ++v)
            for (unsigned int k = 0; k < n_q; ++k)
              chunk.hat_masses[start + k] +=
                member.hat[v] *
                table.vertex_masses[(member.cell * n_v + v) * n_q + k];
          chunk.metrics.insert(chunk.metrics.end(),
                               &table.metrics[member.cell * n_metric],
                               &table.metrics[(member.cell + 1) * n_metric]);
          chunk.cells.push_back(member.share);
          scratch.signs_of_cells.push_back(&table.signs[member.cell * n_tau]);
        }
      layout.n_sigma = chunk.dofs.size() - patch.dofs_start;
    }

    // An owned cell's part in a patch, psi_a on the cell given by its values
    // at the vertices: in `parts` until all are known (store_parts()).
    void
    add_part(const unsigned int cell, Membership part, const double *hat)
    {
      const unsigned int n_nonzero = n_v - std::count(hat, hat + n_v, 0.);
      const double      *one       = std::find(hat, hat + n_v, 1.);
      if (n_nonzero == 1 && one != hat + n_v)
        part.hat = one - hat;
      else
        {
          part.hat = n_v + reconstruction.hanging_hats.size();
          reconstruction.hanging_hats.emplace_back();
          std::copy_n(hat, n_v, reconstruction.hanging_hats.back().begin());
        }
      parts.emplace_back(cell, part);
    }

    // The parts by cell, each cell's in the order they were found: a
    // counting sort on the active cell indices.
    void
    store_parts()
    {
      FluxReconstruction<dim> &r = reconstruction;
      r.membership_start.assign(tria.n_active_cells() + 1, 0);
      for (const auto &[cell, part] : parts)
        ++r.membership_start[cell + 1];
      std::partial_sum(r.membership_start.begin(),
                       r.membership_start.end(),
                       r.membership_start.begin());
      r.memberships.resize(parts.size());
      std::vector<std::size_t> next(r.membership_start.begin(),
                                    r.membership_start.end() - 1);
      for (const auto &[cell, part] : parts)
        r.memberships[next[cell]++] = part;
      parts = decltype(parts)();
    }

    // In the order of the patches: their solvers, shared between patches
    // of the same layout and metrics, and their cells' parts. On curved or
    // perturbed meshes no two patches have the same metrics: once the
    // first patches show that, solvers are no longer looked up (the
    // metrics are invariant under scaling, so on uniformly refined meshes
    // a few solvers serve every level).
    void
    gather_patches()
    {
      std::vector<Patch> &patches = reconstruction.patches;
      std::unordered_map<std::vector<std::int64_t>,
                         std::shared_ptr<const LocalSolver>,
                         KeyHash>
                                solvers;
      bool                      share_solvers = true;
      constexpr unsigned int    sharing_trial = 1000;
      std::vector<std::int64_t> key;
      dofs_offset.assign(chunks.size() + 1, 0);
      patches.reserve(patches_here.size());
      for (std::size_t ch = 0; ch < chunks.size(); ++ch)
        {
          const PatchChunk &chunk = chunks[ch];
          dofs_offset[ch + 1]     = dofs_offset[ch] + chunk.dofs.size();
          std::size_t first_cell  = 0;
          for (std::size_t i = 0; i < chunk.patches.size(); ++i)
            {
              Patch patch = chunk.patches[i];
              patch.dofs_start += dofs_offset[ch];
              patch.hat_mass = &chunk.hat_masses[first_cell * n_q];
              const std::shared_ptr<const PatchLayout> &layout =
                chunk.layouts[i];
              const double *metrics = &chunk.metrics[first_cell * n_metric];

              if (share_solvers && patches.size() == sharing_trial &&
                  new_solvers.size() > patches.size() / 2)
                {
                  share_solvers = false;
                  solvers.clear();
                }
              if (share_solvers)
                {
                  key.assign({reinterpret_cast<std::intptr_t>(layout.get())});
                  for (unsigned int m = 0; m < layout->n_cells * n_metric; ++m)
                    key.push_back(std::llround(metrics[m] * 1e9));
                  std::shared_ptr<const LocalSolver> &solver = solvers[key];
                  if (!solver)
                    {
                      // made here, to be shared; factorised below
                      auto created    = std::make_shared<LocalSolver>();
                      created->layout = layout;
                      new_solvers.push_back(
                        {patches.size(), created.get(), &layout, metrics});
                      solver = std::move(created);
                    }
                  patch.solver = solver;
                }
              else
                {
                  new_solvers.push_back(
                    {patches.size(), nullptr, &layout, metrics});
                }

              record_cell_parts(chunk,
                                first_cell,
                                layout->n_cells,
                                patches.size());
              first_cell += layout->n_cells;
              patches.push_back(std::move(patch));
            }
        }
    }

    // Where the right-hand sides of the cells of patch number patch_number
    // (from cell first_cell of its chunk on) come from.
    void
    record_cell_parts(const PatchChunk  &chunk,
                      const std::size_t  first_cell,
                      const unsigned int n_cells,
                      const unsigned int patch_number)
    {
      for (unsigned int c = 0; c < n_cells; ++c)
        {
          const auto [from, index] = chunk.cells[first_cell + c];
          if (from == rank)
            {
              add_part(owned_cells[mine.cell[index]]->active_cell_index(),
                       {rank, patch_number, c, 0},
                       &mine.hat[index * n_v]);
            }
          else
            {
              // a rank computes the right-hand sides of the shares it
              // sent in the order it sent them
              reconstruction.received[from][index] = {patch_number, c};
              ++n_received[from];
            }
        }
    }

    // The metrics and factors of all new solvers in one array (0.35 GB on
    // 7.9e5 Q1 patches), first touched on the threads that factorise: one
    // large allocation, which glibc maps in huge pages when asked to
    // (README.md), instead of a vector per patch from the threads' heaps.
    void
    factorise_solvers()
    {
      FluxReconstruction<dim> &r            = reconstruction;
      std::size_t              storage_size = 0;
      for (NewSolver &job : new_solvers)
        {
          job.storage_start = storage_size;
          storage_size += LocalSolver::storage_size(**job.layout);
        }
      r.solver_storage.reset(new double[storage_size]);
      r.local_solvers.resize(new_solvers.size());
      parallel_for_each(
        new_solvers.size(),
        [&](const std::size_t i) {
          const NewSolver             &job    = new_solvers[i];
          LocalSolver                 *solver = job.shared;
          std::shared_ptr<LocalSolver> created;
          if (!solver)
            {
              created         = std::make_shared<LocalSolver>();
              created->layout = *job.layout;
              solver          = created.get();
            }
          solver->metrics = &r.solver_storage[job.storage_start];
          std::copy_n(job.metrics,
                      solver->layout->n_cells * n_metric,
                      solver->metrics);
          r.factorise(*solver);
          r.local_solvers[i] = solver;
          if (created)
            r.patches[job.patch].solver = std::move(created);
        },
        /*grainsize=*/256);
      for (PatchChunk &chunk : chunks)
        {
          chunk.metrics = std::vector<double>();
          chunk.cells   = std::vector<ShareHere>();
          chunk.layouts = std::vector<std::shared_ptr<const PatchLayout>>();
        }
      for (const auto &[from, shares] : incoming)
        AssertThrow(n_received[from] == shares.patch.size(),
                    ExcMessage("Flux reconstruction: a cell share sent to this "
                               "process belongs to no patch solved here."));
    }

    // Where the fluxes are summed: the owned dofs, and as ghosts the
    // relevant ones (the patches' and the constraints' dofs) and, with
    // hanging nodes in parallel, a few beyond that patches solved here
    // write; the patch unknowns as local indices there, and their cells'
    // (psi_a, q_k)_K, gathered from the chunks. Then the constraints of the
    // owned dofs and the owned cells with parts in patches.
    void
    set_up_sums()
    {
      FluxReconstruction<dim>             &r = reconstruction;
      std::vector<types::global_dof_index> beyond;
      for (const PatchChunk &chunk : chunks)
        beyond.insert(beyond.end(), chunk.beyond.begin(), chunk.beyond.end());
      std::sort(beyond.begin(), beyond.end());
      beyond.erase(std::unique(beyond.begin(), beyond.end()), beyond.end());
      IndexSet writable_dofs = r.relevant_dofs;
      writable_dofs.add_indices(beyond.begin(), beyond.end());
      writable_dofs.compress();
      const auto partitioner =
        std::make_shared<Utilities::MPI::Partitioner>(r.owned_dofs,
                                                      writable_dofs,
                                                      comm);
      r.flux_partitioner = partitioner;
      r.patch_positions.resize(dofs_offset.back());
      r.hat_masses.resize(chunks.size());
      parallel_for_each(
        chunks.size(),
        [&](const std::size_t ch) {
          PatchChunk &chunk = chunks[ch];
          for (std::size_t i = 0; i < chunk.dofs.size(); ++i)
            r.patch_positions[dofs_offset[ch] + i] =
              partitioner->global_to_local(chunk.dofs[i]);
          // (moved: the patches point into them)
          r.hat_masses[ch] = std::move(chunk.hat_masses);
          chunk            = PatchChunk();
        },
        /*grainsize=*/1);
      // The constraints of the owned dofs (the others are the owners'); their
      // entries, on the coarse side of the face, are relevant.
      r.constrained_dofs.clear();
      r.constraint_start.assign(1, 0);
      r.constraint_entries.clear();
      for (const auto &line : flux_constraints.get_lines())
        if (r.owned_dofs.is_element(line.index))
          {
            r.constrained_dofs.push_back(
              partitioner->global_to_local(line.index));
            for (const auto &[g, w] : line.entries)
              {
                Assert(writable_dofs.is_element(g), ExcInternalError());
                r.constraint_entries.emplace_back(
                  partitioner->global_to_local(g), w);
              }
            r.constraint_start.push_back(r.constraint_entries.size());
          }
      store_parts();
      r.cells_with_shares.clear();
      for (const auto &cell : tria.active_cell_iterators())
        if (cell->is_locally_owned() && r.parts_of(cell).size() > 0)
          r.cells_with_shares.push_back(cell);
      hats.clear();
    }

    FluxReconstruction<dim>            &reconstruction;
    const std::set<types::boundary_id> &free_boundary_ids;
    const Triangulation<dim>           &tria;
    const MPI_Comm                      comm;
    const unsigned int                  rank, n_rank;
    const unsigned int                  n_tau, n_q;

    AffineConstraints<double> flux_constraints;
    DoFHandler<dim>           hats;
    IndexSet                  relevant_hats;
    AffineConstraints<double> hat_constraints;

    /// The owned cells, their data and the shares of their hats.
    std::vector<typename DoFHandler<dim>::cell_iterator> owned_cells;
    Shares                                               mine;
    /// the vertex of each unconstrained hat, by its position in
    /// relevant_hats
    std::vector<unsigned int> vertex_of;
    /// The shares of mine solved here, and those received from other ranks.
    std::vector<unsigned int>      solved_here;
    std::map<unsigned int, Shares> incoming;
    /// The shares solved here grouped by patch (patch position i from
    /// group_start[i] on), and the positions of the patches solved here.
    std::vector<std::size_t>  group_start;
    std::vector<ShareHere>    shares_here;
    std::vector<unsigned int> patches_here;

    std::vector<PatchChunk> chunks;
    Layouts                 layouts; // shared by the patches of all chunks
    std::mutex              layouts_mutex;

    /// The owned cells' parts in patches: (active cell index, part).
    std::vector<std::pair<unsigned int, Membership>> parts;

    std::vector<NewSolver>               new_solvers;
    std::vector<std::size_t>             dofs_offset;
    std::map<unsigned int, unsigned int> n_received;
  };


  template <int dim>
  void
  FluxReconstruction<dim>::reinit(
    const DoFHandler<dim>              &potential,
    const std::set<types::boundary_id> &free_boundary_ids)
  {
    Setup setup(*this, potential, free_boundary_ids);
    setup.distribute_dofs();
    setup.compute_cell_data();
    setup.compute_hat_shares();
    setup.exchange_shares();
    setup.group_shares_here();
    setup.lay_out_patches();
    setup.gather_patches();
    setup.factorise_solvers();
    setup.set_up_sums();
  }


  // The class itself is instantiated in flux_reconstruction.cc (before this
  // file in a unity build): here only what this file defines.
  template void
  FluxReconstruction<2>::reinit(const DoFHandler<2> &,
                                const std::set<types::boundary_id> &);
} // namespace VI
