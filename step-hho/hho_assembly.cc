#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>

#include <vi/errors.h>
#include <vi/nodal_fields.h>

#include "hho_problem.h"
#include "local_operators.h"

#include <cmath>
#include <cstdint>
#include <map>
#include <tuple>

namespace StepHHO
{
  namespace
  {
    /**
     * FEValues for the local HHO operators on one cell: the cell element on
     * the cell and on its faces, the face element on the faces. Quadrature
     * of degree 2p + 3: exact for the products of the local operators on
     * parallelograms, and one order more for the loads.
     */
    template <int dim>
    struct LocalValues
    {
      LocalValues(const Mapping<dim>       &mapping,
                  const FiniteElement<dim> &cell_fe,
                  const FiniteElement<dim> &face_fe)
          : cell_values(mapping,
                        cell_fe,
                        QGauss<dim>(cell_fe.degree + 2),
                        update_values | update_gradients |
                          update_quadrature_points | update_JxW_values)
          , trace_values(mapping,
                         cell_fe,
                         QGauss<dim - 1>(cell_fe.degree + 2),
                         update_values | update_quadrature_points |
                           update_normal_vectors | update_JxW_values)
          , face_values(mapping,
                        face_fe,
                        QGauss<dim - 1>(cell_fe.degree + 2),
                        update_values)
      {
      }

      LocalValues(const LocalValues &other)
          : LocalValues(other.cell_values.get_mapping(),
                        other.cell_values.get_fe(),
                        other.face_values.get_fe())
      {
      }

      FEValues<dim>     cell_values;
      FEFaceValues<dim> trace_values;
      FEFaceValues<dim> face_values;
    };
  } // namespace


  // The local matrices of every cell shape. With a mapping of degree 1 a
  // cell is determined by its vertices, and cells that are translates of
  // each other have the same local matrices (G_K, s_K, h_K and the Gram
  // matrix do not change under translation): they share one set, computed
  // on the first of them. On the uniform meshes of the square and the
  // L-shape that is one set for all cells; on the disk (curved cells, a
  // mapping of higher degree) every cell has its own.
  template <int dim>
  void
  HHOProblem<dim>::compute_local_matrices()
  {
    const auto *mapping_q = dynamic_cast<const MappingQ<dim> *>(mapping.get());
    const bool  by_vertices =
      mapping_q != nullptr && mapping_q->get_degree() == 1;
    // Vertex offsets rounded to 1e-12 of the domain's diameter.
    const double quantum = 1e-12 * domain.diameter();
    using Key            = std::vector<std::int64_t>;
    std::map<Key, unsigned int> shapes;
    std::vector<CellIterator>   first_cells;
    cell_shape.assign(triangulation.n_active_cells(),
                      numbers::invalid_unsigned_int);
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          unsigned int shape = first_cells.size();
          if (by_vertices)
            {
              Key key;
              for (const unsigned int v : cell->vertex_indices())
                for (unsigned int d = 0; d < dim; ++d)
                  key.push_back(std::llround(
                    (cell->vertex(v)[d] - cell->vertex(0)[d]) / quantum));
              shape = shapes.emplace(key, shape).first->second;
            }
          if (shape == first_cells.size())
            first_cells.push_back(cell);
          cell_shape[cell->active_cell_index()] = shape;
        }

    // a_K = (G_K, G_K)_K + s_K of one membrane (local_operators.h) in the
    // nodal basis, what the static condensation needs from it, and the
    // Gram matrix of FE_DGP's basis (diagonal on parallelograms).
    local_matrices.clear();
    local_matrices.resize(first_cells.size());
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const auto         worker =
      [&](const auto &first, LocalValues<dim> &scratch, std::tuple<> &) {
        const CellIterator &cell = *first;
        LocalMatrices      &matrices =
          local_matrices[cell_shape[cell->active_cell_index()]];
        FullMatrix<double> A;
        LocalOperators::local_hho_matrix<dim>(cell,
                                              scratch.cell_values,
                                              scratch.trace_values,
                                              scratch.face_values,
                                              gradient_basis,
                                              A);
        LocalOperators::change_cell_basis(T, A);
        matrices.operators.reinit(A, n_c);

        scratch.cell_values.reinit(cell);
        matrices.mass.reinit(n_c, n_c);
        for (const unsigned int q :
             scratch.cell_values.quadrature_point_indices())
          for (unsigned int i = 0; i < n_c; ++i)
            for (unsigned int j = 0; j < n_c; ++j)
              matrices.mass(i, j) += scratch.cell_values.shape_value(i, q) *
                                     scratch.cell_values.shape_value(j, q) *
                                     scratch.cell_values.JxW(q);
      };
    WorkStream::run(
      first_cells.cbegin(),
      first_cells.cend(),
      worker,
      [](const std::tuple<> &) {},
      LocalValues<dim>(*mapping, cell_fe, face_fe),
      std::tuple<>());
  }


  // Once per mesh: the local matrices of every cell shape, the loads
  // (f_alpha, phi_I)_K, and with static condensation the face matrix of the
  // mean of the membranes, which no Newton step changes; without, the whole
  // matrix E of the slides.
  template <int dim>
  void
  HHOProblem<dim>::assemble_system()
  {
    TimerOutput::Scope t(timer, "assembly");
    compute_local_matrices();

    load = 0;
    if (parameters.static_condensation)
      mean_matrix = 0;
    else
      system_matrix = 0;

    const unsigned int n_c   = cell_fe.n_dofs_per_cell();
    const unsigned int n_f   = face_fe.n_dofs_per_cell();
    const double       mu[2] = {data.mu1, data.mu2};

    // Vector: the loads of u1 and u2 (cell rows). Matrix: the mean's face
    // matrix, or E, on the cell.
    using CopyData = MeshWorker::CopyData<1, 1, 2>;
    const auto cell_worker =
      [&](const CellIterator &cell, LocalValues<dim> &scratch, CopyData &copy) {
        const auto unknowns = local_unknowns(cell);
        const StaticCondensation::CellOperators &operators =
          local_matrices_of(cell).operators;

        // (f_alpha, phi_I)_K = sum_j T_jI (f_alpha, P_j)_K.
        scratch.cell_values.reinit(cell);
        const auto    &points = scratch.cell_values.get_quadrature_points();
        Vector<double> modal(2 * n_c), nodal(n_c), part(n_c);
        for (const unsigned int q :
             scratch.cell_values.quadrature_point_indices())
          {
            const double f1 = data.f1->value(points[q]);
            const double f2 = data.f2->value(points[q]);
            for (unsigned int j = 0; j < n_c; ++j)
              {
                const double phi = scratch.cell_values.shape_value(j, q) *
                                   scratch.cell_values.JxW(q);
                modal(j) += f1 * phi;
                modal(n_c + j) += f2 * phi;
              }
          }
        copy.vectors[0].reinit(2 * n_c);
        copy.local_dof_indices[0].assign(unknowns.begin(),
                                         unknowns.begin() + 2 * n_c);
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          {
            for (unsigned int j = 0; j < n_c; ++j)
              part(j) = modal(alpha * n_c + j);
            T.Tvmult(nodal, part);
            for (unsigned int I = 0; I < n_c; ++I)
              copy.vectors[0](alpha * n_c + I) = nodal(I);
          }

        if (parameters.static_condensation)
          {
            StaticCondensation::CellElimination::mean_matrix(operators,
                                                             data.mu1,
                                                             data.mu2,
                                                             copy.matrices[0]);
            copy.local_dof_indices[1].resize(n_f);
            for (unsigned int k = 0; k < n_f; ++k)
              copy.local_dof_indices[1][k] =
                face_dof(unknowns[n_fields * n_c + k]);
            return;
          }
        // E on the cell, unknowns (x1, x2, x3, y1, y2): mu_alpha a_K on
        // (x_alpha, y_alpha), the coupling -I / +I of the dual basis; the
        // complementarity rows are set in each Newton step.
        const unsigned int n = n_local_unknowns();
        copy.matrices[0].reinit(n, n);
        const auto position = [&](const unsigned int alpha,
                                  const unsigned int i) {
          return i < n_c ? alpha * n_c + i :
                           n_fields * n_c + alpha * n_f + i - n_c;
        };
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          for (unsigned int i = 0; i < n_c + n_f; ++i)
            for (unsigned int j = 0; j < n_c + n_f; ++j)
              copy.matrices[0](position(alpha, i), position(alpha, j)) =
                mu[alpha] * operators.A(i, j);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            copy.matrices[0](I, 2 * n_c + I)       = -1.;
            copy.matrices[0](n_c + I, 2 * n_c + I) = +1.;
          }
        copy.local_dof_indices[1].assign(unknowns.begin(), unknowns.end());
      };

    const auto copier = [&](const CopyData &copy) {
      load.add(copy.local_dof_indices[0], copy.vectors[0]);
      if (parameters.static_condensation)
        face_constraints.distribute_local_to_global(copy.matrices[0],
                                                    copy.local_dof_indices[1],
                                                    mean_matrix);
      else
        system_constraints.distribute_local_to_global(copy.matrices[0],
                                                      copy.local_dof_indices[1],
                                                      system_matrix);
    };

    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          LocalValues<dim>(*mapping, cell_fe, face_fe),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    load.compress(VectorOperation::add);
    if (parameters.static_condensation)
      mean_matrix.compress(VectorOperation::add);
    else
      system_matrix.compress(VectorOperation::add);

    if (!std::isfinite(load.l2_norm()))
      throw VI::InputError(
        "Problem: the load vector is not finite: f1 or f2 evaluate to NaN or "
        "Inf somewhere in the domain");

    // Scales of the dimensionless residuals: the residual of the balance
    // equations at zero interior unknowns (the load with the Dirichlet
    // lifting), and the largest multiplier coefficient that load needs.
    TrilinosWrappers::MPI::Vector R0(owned_system, comm);
    equation_residual(boundary_values, R0);
    load_norm        = R0.l2_norm();
    double local_max = 0;
    for (std::size_t k = 0; k < n_fields * owned_nodes.n_elements(); ++k)
      local_max = std::max(local_max, std::abs(R0.begin()[k]));
    multiplier_scale = Utilities::MPI::max(local_max, comm);
  }


  template void
  HHOProblem<2>::compute_local_matrices();
  template void
  HHOProblem<2>::assemble_system();
} // namespace StepHHO
