#include "hho_problem.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>

#include <vi/errors.h>
#include <vi/mesh_sequence.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include "jacobian_solver.h"
#include "local_operators.h"

#include <sstream>

namespace StepHHO
{
  namespace
  {
    /// values(i) = X(indices[i]) (owned or ghost entries of X).
    template <typename Indices>
    void
    get_values(const TrilinosWrappers::MPI::Vector &X,
               const Indices                       &indices,
               Vector<double>                      &values,
               const unsigned int                   offset = 0)
    {
      for (unsigned int i = 0; i < indices.size(); ++i)
        values(offset + i) = X(indices[i]);
    }


    /**
     * The L2 projection onto the face space P_{p-1}(F) of face f: the
     * coefficients of Pi_F v in the basis of `face_fe` on that face, from
     * the values v(x_q) at the quadrature points of `face_values` (which
     * holds the face element's values and JxW there).
     */
    template <int dim>
    void
    project_onto_face(const FEFaceValues<dim>   &face_values,
                      const FiniteElement<dim>  &face_fe,
                      const unsigned int         f,
                      const std::vector<double> &v,
                      dealii::Vector<double>    &coefficients)
    {
      const unsigned int n_F = face_fe.n_dofs_per_face(f);
      FullMatrix<double> M_F(n_F, n_F);
      Vector<double>     moments(n_F);
      for (const unsigned int q : face_values.quadrature_point_indices())
        for (unsigned int k = 0; k < n_F; ++k)
          {
            const double psi_k =
              face_values.shape_value(face_fe.face_to_cell_index(k, f), q);
            moments(k) += v[q] * psi_k * face_values.JxW(q);
            for (unsigned int l = 0; l < n_F; ++l)
              M_F(k, l) +=
                psi_k *
                face_values.shape_value(face_fe.face_to_cell_index(l, f), q) *
                face_values.JxW(q);
          }
      M_F.gauss_jordan();
      coefficients.reinit(n_F);
      M_F.vmult(coefficients, moments);
    }
  } // namespace


  template <int dim>
  HHOProblem<dim>::HHOProblem(const Parameters &parameters,
                              ParameterHandler &prm,
                              const MPI_Comm    comm)
      : StationaryProblem("step-hho", parameters, prm, comm)
      , parameters(parameters)
      , comm(comm)
      , domain(parameters.mesh, parameters.problem.boundary)
      , data(
          VI::make_membrane_data<dim>(parameters.problem, domain.center<dim>()))
      , C(parameters.nonlinear_solver.c_function)
      , triangulation(comm)
      , mapping(domain.make_mapping<dim>(parameters.discretization.degree))
      , degree(parameters.discretization.degree)
      , cell_fe(degree)
      , face_fe(degree - 1)
      , cell_dof_handler(triangulation)
      , face_dof_handler(triangulation)
      , stopping(parameters.nonlinear_solver,
                 stopping_hooks(),
                 parameters.output.verbose ? &pcout : nullptr)
  {
    static_assert(dim == 2,
                  "The contact nodes are those of the square "
                  "(local_operators.h).");
    if (parameters.problem.model == VI::Model::obstacle)
      throw VI::InputError("Problem/Model = obstacle is implemented for "
                           "step-membranes' Method = fem only; use "
                           "two-membranes with step-hho");
    // The nodal basis phi_I = sum_j T_jI P_j of P_p at the contact nodes of
    // the reference cell, in terms of FE_DGP's Legendre basis P_j.
    V = LocalOperators::vandermonde_matrix(
      cell_fe,
      LocalOperators::contact_nodes(
        degree,
        parameters.contact_nodes == "padua" ?
          LocalOperators::ContactNodes::padua :
          LocalOperators::ContactNodes::gauss_padua));
    T.reinit(V.m(), V.n());
    T.invert(V);
    gradient_basis = LocalOperators::subspace_basis(
      cell_fe, parameters.gradient_degree == "p" ? degree : degree - 1);
  }


  template <int dim>
  HHOProblem<dim>::~HHOProblem() = default;


  // ------------------------------------------------------------------------
  // Index bookkeeping.

  template <int dim>
  typename HHOProblem<dim>::CellIterator
  HHOProblem<dim>::face_cell(const CellIterator &cell) const
  {
    return CellIterator(&triangulation,
                        cell->level(),
                        cell->index(),
                        &face_dof_handler);
  }


  template <int dim>
  types::global_dof_index
  HHOProblem<dim>::face_unknown(const types::global_dof_index face_dof,
                                const unsigned int            alpha) const
  {
    return n_fields * cell_dof_handler.n_dofs() + 2 * face_dof + alpha;
  }


  template <int dim>
  types::global_dof_index
  HHOProblem<dim>::face_dof(const types::global_dof_index face_unknown) const
  {
    return (face_unknown - n_fields * cell_dof_handler.n_dofs()) / 2;
  }


  template <int dim>
  unsigned int
  HHOProblem<dim>::n_local_unknowns() const
  {
    return n_fields * cell_fe.n_dofs_per_cell() + 2 * face_fe.n_dofs_per_cell();
  }


  // Positions in X of the cell unknowns (x1, x2, x3; n_c each) and of the
  // face unknowns (y1, y2; n_f each, in FE_FaceQ's cell-local order) of a
  // locally owned cell: the local order of static_condensation.h.
  template <int dim>
  ArrayView<const types::global_dof_index>
  HHOProblem<dim>::local_unknowns(const CellIterator &cell) const
  {
    const unsigned int n = n_local_unknowns();
    return ArrayView<const types::global_dof_index>(
      unknown_indices.data() + cell->active_cell_index() * n, n);
  }


  template <int dim>
  const typename HHOProblem<dim>::LocalMatrices &
  HHOProblem<dim>::local_matrices_of(const CellIterator &cell) const
  {
    return local_matrices[cell_shape[cell->active_cell_index()]];
  }


  // ------------------------------------------------------------------------
  // The program's steps.

  // The data must be finite and admit a solution: g1 >= g2 on the boundary
  // (otherwise the constraint u1 >= u2 contradicts the boundary condition).
  // Checked on the first mesh (forces at the cell quadrature points,
  // boundary data at the face quadrature points of the boundary) before
  // anything is written.
  template <int dim>
  void
  HHOProblem<dim>::check_data() const
  {
    // The Gauss points of every face of the unit cell.
    const QGauss<dim - 1>   face_quadrature(degree + 2);
    std::vector<Point<dim>> boundary_points;
    for (const unsigned int f : GeometryInfo<dim>::face_indices())
      for (const auto &x : face_quadrature.get_points())
        {
          Point<dim> p;
          p[f / 2] = double(f % 2);
          for (unsigned int d = 0, k = 0; d < dim; ++d)
            if (d != f / 2)
              p[d] = x[k++];
          boundary_points.push_back(p);
        }
    VI::check_membrane_data(data,
                            triangulation,
                            domain,
                            *mapping,
                            QGauss<dim>(degree + 2).get_points(),
                            boundary_points,
                            comm);
  }


  template <int dim>
  void
  HHOProblem<dim>::make_grid()
  {
    domain.make_coarse_mesh(triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
  }


  // Number the unknowns, project the Dirichlet data onto the clamped faces,
  // and make the sparsity of the matrices that are solved: the face systems
  // with static condensation, the whole Jacobian without.
  template <int dim>
  void
  HHOProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");
    distribute_unknowns();
    index_local_unknowns();
    make_face_constraints();
    // Every cell node carries a complementarity pair.
    contact_rows.reinit(owned_nodes, AffineConstraints<double>());

    if (parameters.static_condensation)
      make_face_sparsity();
    else
      make_jacobian_sparsity();
    reinit_vectors();
  }


  // The cell DoFs (the nodes) and the face DoFs, and the unknowns X they
  // carry: those of the nodes and faces a process owns, and those it sees.
  template <int dim>
  void
  HHOProblem<dim>::distribute_unknowns()
  {
    cell_dof_handler.distribute_dofs(cell_fe);
    face_dof_handler.distribute_dofs(face_fe);
    owned_nodes = cell_dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(cell_dof_handler, relevant_nodes);
    owned_faces = face_dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(face_dof_handler, relevant_faces);

    const types::global_dof_index n_unknowns =
      n_fields * cell_dof_handler.n_dofs() + 2 * face_dof_handler.n_dofs();
    const auto unknowns_of = [&](const IndexSet &nodes, const IndexSet &faces) {
      IndexSet unknowns(n_unknowns);
      unknowns.add_indices(VI::NodalFields::system_index_set(nodes));
      std::vector<types::global_dof_index> face_unknowns;
      face_unknowns.reserve(2 * faces.n_elements());
      for (const types::global_dof_index j : faces)
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          face_unknowns.push_back(face_unknown(j, alpha));
      unknowns.add_indices(face_unknowns.begin(), face_unknowns.end());
      unknowns.compress();
      return unknowns;
    };
    owned_system    = unknowns_of(owned_nodes, owned_faces);
    relevant_system = unknowns_of(relevant_nodes, relevant_faces);
  }


  // The positions in X of the unknowns of every locally owned and ghost
  // cell, in the local order of static_condensation.h (local_unknowns()).
  template <int dim>
  void
  HHOProblem<dim>::index_local_unknowns()
  {
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();
    const unsigned int n   = n_local_unknowns();
    unknown_indices.assign(triangulation.n_active_cells() * n,
                           numbers::invalid_dof_index);
    std::vector<types::global_dof_index> nodes(n_c), face_dofs(n_f);
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (!cell->is_artificial())
        {
          cell->get_dof_indices(nodes);
          face_cell(cell)->get_dof_indices(face_dofs);
          types::global_dof_index *unknowns =
            unknown_indices.data() + cell->active_cell_index() * n;
          for (unsigned int alpha = 0; alpha < n_fields; ++alpha)
            for (unsigned int I = 0; I < n_c; ++I)
              unknowns[alpha * n_c + I] = index(nodes[I], alpha);
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            for (unsigned int k = 0; k < n_f; ++k)
              unknowns[n_fields * n_c + alpha * n_f + k] =
                face_unknown(face_dofs[k], alpha);
        }
  }


  // The constraints of the face DoFs (clamped boundary faces, and the halves
  // of faces between refinement levels) and of the face unknowns in X.
  template <int dim>
  void
  HHOProblem<dim>::make_face_constraints()
  {
    face_constraints.clear();
    face_constraints.reinit(relevant_faces);
    project_boundary_data();
    n_boundary_face_dofs =
      Utilities::MPI::sum(face_constraints.n_constraints(), comm);
    constrain_hanging_faces();
    face_constraints.close();

    // The same for both membranes' unknowns; the hanging ones also on
    // their own, for the iterate X (whose boundary values are not 0).
    system_constraints.clear();
    system_constraints.reinit(relevant_system);
    hanging_unknowns.clear();
    hanging_unknowns.reinit(relevant_system);
    for (const auto &line : face_constraints.get_lines())
      for (unsigned int alpha = 0; alpha < 2; ++alpha)
        {
          const types::global_dof_index i = face_unknown(line.index, alpha);
          system_constraints.add_line(i);
          if (line.entries.empty())
            continue;
          hanging_unknowns.add_line(i);
          for (const auto &[j, weight] : line.entries)
            {
              system_constraints.add_entry(i, face_unknown(j, alpha), weight);
              hanging_unknowns.add_entry(i, face_unknown(j, alpha), weight);
            }
        }
    system_constraints.close();
    hanging_unknowns.close();
  }


  // Faces between refinement levels (adaptive meshes). The coarse cell K
  // sees one face F, the two fine cells its halves F_c. The unknowns are
  // the polynomials of P_{p-1}(F_c) on the halves, as if K were a pentagon;
  // the coarse face's DoFs hold their L2 projection onto P_{p-1}(F), which
  // is all that K's local operators (four faces) see of them. The
  // interpolant of a smooth u then has Pi_F u on F (the projection onto the
  // halves, then onto F) and Pi_F_c u on F_c, so each cell keeps the
  // consistency of HHO, and testing the halves' rows shows that the fine
  // cells' numerical fluxes are minus the restrictions of the coarse one
  // (doc/reference.md, 2.3, "Faces between refinement levels"). Constraints:
  // coarse DoF k (nodal, basis phi_k of P_{p-1}(F)) = sum_{c,j} W_k,cj y_cj, W
  // = M^(-1) B with M_lk = (phi_k, phi_l)_F and B_l,cj = (psi_cj, phi_l)_F_c,
  // psi_cj the nodal basis of F_c.
  template <int dim>
  void
  HHOProblem<dim>::constrain_hanging_faces()
  {
    const unsigned int                   n_F = face_fe.n_dofs_per_face();
    const QGauss<dim - 1>                quadrature(degree + 1);
    FEFaceValues<dim>                    on_face(*mapping,
                              face_fe,
                              quadrature,
                              update_values | update_JxW_values);
    FESubfaceValues<dim>                 on_half(*mapping,
                                 face_fe,
                                 quadrature,
                                 update_values | update_JxW_values);
    std::vector<types::global_dof_index> coarse_dofs(n_F), half_dofs(n_F),
      both_halves(2 * n_F);
    FullMatrix<double>      M(n_F, n_F), B(n_F, 2 * n_F), W(n_F, 2 * n_F);
    types::global_dof_index n_owned = 0;
    for (const auto &cell : face_dof_handler.active_cell_iterators())
      if (!cell->is_artificial())
        for (const unsigned int f : cell->face_indices())
          {
            if (cell->at_boundary(f) || !cell->face(f)->has_children())
              continue;
            const auto basis = [&](const unsigned int k) {
              return face_fe.face_to_cell_index(k, f);
            };
            const typename Triangulation<dim>::cell_iterator geometry(cell);
            on_face.reinit(geometry, f);
            M = 0;
            for (const unsigned int q : on_face.quadrature_point_indices())
              for (unsigned int l = 0; l < n_F; ++l)
                for (unsigned int k = 0; k < n_F; ++k)
                  M(l, k) += on_face.shape_value(basis(l), q) *
                             on_face.shape_value(basis(k), q) * on_face.JxW(q);
            // psi_cj at the points of the half, which are those of the full
            // face's quadrature mapped onto it: L_j(x_q) = phi_j on F.
            B = 0;
            for (unsigned int c = 0; c < 2; ++c)
              {
                on_half.reinit(geometry, f, c);
                for (const unsigned int q : on_half.quadrature_point_indices())
                  for (unsigned int l = 0; l < n_F; ++l)
                    for (unsigned int j = 0; j < n_F; ++j)
                      B(l, c * n_F + j) += on_face.shape_value(basis(j), q) *
                                           on_half.shape_value(basis(l), q) *
                                           on_half.JxW(q);
              }
            M.gauss_jordan();
            M.mmult(W, B);

            cell->face(f)->get_dof_indices(coarse_dofs);
            for (unsigned int c = 0; c < 2; ++c)
              {
                cell->face(f)->child(c)->get_dof_indices(half_dofs);
                std::copy(half_dofs.begin(),
                          half_dofs.end(),
                          both_halves.begin() + c * n_F);
              }
            for (unsigned int k = 0; k < n_F; ++k)
              {
                if (face_constraints.is_constrained(coarse_dofs[k]))
                  continue;
                face_constraints.add_line(coarse_dofs[k]);
                n_owned += owned_faces.is_element(coarse_dofs[k]);
                for (unsigned int j = 0; j < 2 * n_F; ++j)
                  face_constraints.add_entry(coarse_dofs[k],
                                             both_halves[j],
                                             W(k, j));
              }
          }
    n_hanging_face_dofs = Utilities::MPI::sum(n_owned, comm);
  }


  // Dirichlet data: on each boundary face F, u_alpha,F = Pi_F g_alpha, the
  // L2 projection onto P_{p-1}(F). These face unknowns are fixed: Newton
  // updates vanish there (homogeneous constraints), and X carries the
  // projected values from the start.
  template <int dim>
  void
  HHOProblem<dim>::project_boundary_data()
  {
    boundary_values.reinit(owned_system, comm);
    {
      FEFaceValues<dim>    face_values(*mapping,
                                    face_fe,
                                    QGauss<dim - 1>(degree + 2),
                                    update_values | update_quadrature_points |
                                      update_JxW_values);
      const Function<dim> *g[2] = {data.g1.get(), data.g2.get()};
      std::vector<types::global_dof_index> face_dofs(face_fe.n_dofs_per_cell());
      std::vector<double> g_values(face_values.n_quadrature_points);
      Vector<double>      coefficients;
      for (const auto &cell : face_dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
          for (const unsigned int f : cell->face_indices())
            if (cell->face(f)->at_boundary() &&
                domain.is_clamped(cell->face(f)->boundary_id()))
              {
                cell->get_dof_indices(face_dofs);
                face_values.reinit(cell, f);
                for (unsigned int alpha = 0; alpha < 2; ++alpha)
                  {
                    g[alpha]->value_list(face_values.get_quadrature_points(),
                                         g_values);
                    project_onto_face(
                      face_values, face_fe, f, g_values, coefficients);
                    for (unsigned int k = 0; k < coefficients.size(); ++k)
                      {
                        const types::global_dof_index j =
                          face_dofs[face_fe.face_to_cell_index(k, f)];
                        face_constraints.add_line(j);
                        boundary_values(face_unknown(j, alpha)) =
                          coefficients(k);
                      }
                  }
              }
    }
    boundary_values.compress(VectorOperation::insert);
  }


  // With static condensation: the sparsity of the two face systems (the
  // mean and the difference of the membranes), which share the pattern of
  // the face DoFs.
  template <int dim>
  void
  HHOProblem<dim>::make_face_sparsity()
  {
    DynamicSparsityPattern pattern(relevant_faces);
    DoFTools::make_sparsity_pattern(face_dof_handler,
                                    pattern,
                                    face_constraints,
                                    /*keep_constrained_dofs=*/false);
    SparsityTools::distribute_sparsity_pattern(pattern,
                                               owned_faces,
                                               comm,
                                               relevant_faces);
    mean_matrix.reinit(owned_faces, owned_faces, pattern, comm);
    difference_matrix.reinit(owned_faces, owned_faces, pattern, comm);
    system_matrix.clear();
  }


  // Without static condensation: the sparsity of the whole Jacobian
  // A = [E ; J_C], from the couplings within each cell.
  template <int dim>
  void
  HHOProblem<dim>::make_jacobian_sparsity()
  {
    // The couplings of a cell: (x1; x1, x3, y1), (x2; x2, x3, y2),
    // (x3; x1, x2, x3) at each node, (y1; x1, y1), (y2; x2, y2).
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();
    const unsigned int n   = n_local_unknowns();
    // 0, 1: x1, x2; 2: x3; 3, 4: y1, y2
    const auto block = [&](const unsigned int i) {
      return i < n_fields * n_c ? i / n_c : 3 + (i - n_fields * n_c) / n_f;
    };
    const auto membrane = [&](const unsigned int b) {
      return b >= 3 ? b - 3 : b;
    };
    Table<2, bool> couples(n, n);
    for (unsigned int i = 0; i < n; ++i)
      for (unsigned int j = 0; j < n; ++j)
        {
          const unsigned int bi = block(i), bj = block(j);
          const bool         same_node = bi < 3 && bj < 3 && i % n_c == j % n_c;
          if (bi != 2 && bj != 2)
            couples(i, j) = membrane(bi) == membrane(bj);
          else if (bi == 2) // complementarity row
            couples(i, j) = bj < 3 && same_node;
          else // coupling -I, +I to the multiplier
            couples(i, j) = bi < 2 && same_node;
        }

    DynamicSparsityPattern pattern(relevant_system);
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          const auto unknowns = local_unknowns(cell);
          system_constraints.add_entries_local_to_global(
            std::vector<types::global_dof_index>(unknowns.begin(),
                                                 unknowns.end()),
            pattern,
            false,
            couples);
        }
    SparsityTools::distribute_sparsity_pattern(pattern,
                                               owned_system,
                                               comm,
                                               relevant_system);
    system_matrix.reinit(owned_system, owned_system, pattern, comm);
    mean_matrix.clear();
    difference_matrix.clear();
  }


  // The vectors of the three layouts, the copies into ghosted ones, the
  // constant modes of the face space (for AMG), and the cells'
  // eliminations.
  template <int dim>
  void
  HHOProblem<dim>::reinit_vectors()
  {
    load.reinit(owned_system, comm);
    solution.reinit(owned_system, comm);
    ghosted_iterate.reinit(owned_system, relevant_system, comm);
    for (auto *v :
         {&mean_rhs, &difference_rhs, &mean_update, &difference_update})
      v->reinit(owned_faces, comm);
    for (auto *v : {&ghosted_mean_update, &ghosted_difference_update})
      v->reinit(owned_faces, relevant_faces, comm);
    for (auto *field : {&u1_h, &u2_h, &gap_h, &lambda_h})
      field->reinit(owned_nodes, relevant_nodes, comm);
    ghosted_nodes.reinit(owned_nodes, relevant_nodes, comm);
    ghosted_faces.reinit(owned_faces, relevant_faces, comm);
    ghosted_system.reinit(owned_system, relevant_system, comm);
    DoFTools::extract_constant_modes(face_dof_handler,
                                     ComponentMask(),
                                     constant_modes);

    eliminations.clear();
    eliminations.resize(triangulation.n_active_cells());
  }


  // The face unknowns of X from its cell polynomials: on every interior
  // face the average of the projections of the two traces onto P_{p-1}(F),
  // on a free boundary face and a half of a face between refinement levels
  // the projection of its (fine) trace (used to start Newton on a refined
  // mesh).
  template <int dim>
  void
  HHOProblem<dim>::set_face_unknowns_from_traces(
    TrilinosWrappers::MPI::Vector &X) const
  {
    TrilinosWrappers::MPI::Vector        faces(owned_system, comm);
    FEFaceValues<dim>                    trace_values(*mapping,
                                   cell_fe,
                                   QGauss<dim - 1>(degree + 2),
                                   update_values);
    FEFaceValues<dim>                    face_values(*mapping,
                                  face_fe,
                                  QGauss<dim - 1>(degree + 2),
                                  update_values | update_JxW_values);
    const unsigned int                   n_c = cell_fe.n_dofs_per_cell();
    const unsigned int                   n_f = face_fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> nodes(n_c), face_dofs(n_f);
    Vector<double> coefficients[2] = {Vector<double>(n_c), Vector<double>(n_c)};
    const TrilinosWrappers::MPI::Vector *u[2] = {&u1_h, &u2_h};
    std::vector<double> trace(trace_values.n_quadrature_points);
    Vector<double>      projection;

    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            get_values(*u[alpha], nodes, coefficients[alpha]);
          face_cell(cell)->get_dof_indices(face_dofs);
          for (const unsigned int f : cell->face_indices())
            if (!cell->face(f)->at_boundary() ||
                !domain.is_clamped(cell->face(f)->boundary_id()))
              {
                // A free boundary face has one trace, with weight 1, and so
                // has a half of a face between refinement levels: that of
                // the fine cell (the coarse face's DoFs are the projection
                // of the halves, set below).
                if (cell->face(f)->has_children())
                  continue;
                const double weight =
                  cell->face(f)->at_boundary() || cell->neighbor_is_coarser(f) ?
                    1. :
                    0.5;
                trace_values.reinit(cell, f);
                // (the face element's values need only the geometry)
                face_values.reinit(
                  typename Triangulation<dim>::cell_iterator(cell), f);
                for (unsigned int alpha = 0; alpha < 2; ++alpha)
                  {
                    for (const unsigned int q :
                         trace_values.quadrature_point_indices())
                      {
                        trace[q] = 0;
                        for (unsigned int j = 0; j < n_c; ++j)
                          trace[q] += coefficients[alpha](j) *
                                      trace_values.shape_value(j, q);
                      }
                    project_onto_face(
                      face_values, face_fe, f, trace, projection);
                    for (unsigned int k = 0; k < projection.size(); ++k)
                      {
                        const types::global_dof_index i = face_unknown(
                          face_dofs[face_fe.face_to_cell_index(k, f)], alpha);
                        const double share = weight * projection(k);
                        faces.add(1, &i, &share);
                      }
                  }
              }
        }
    faces.compress(VectorOperation::add);
    X.add(1., faces);
    hanging_unknowns.distribute(X);
  }


  // The Newton iterate on a new mesh: the previous mesh's solution
  // transferred (nested iteration) as cell polynomials, with the face
  // unknowns from their traces; or zero cell, interior face and multiplier
  // unknowns. Either way the clamped boundary faces carry Pi_F g.
  template <int dim>
  void
  HHOProblem<dim>::initialize_iterate()
  {
    solution = boundary_values;
    if (!solution_transfer)
      return;

    TrilinosWrappers::MPI::Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      lambda(owned_nodes, comm);
    VI::interpolate_carried(solution_transfer, {&u1, &u2, &lambda});
    ghosted_nodes.copy(u1, u1_h);
    ghosted_nodes.copy(u2, u2_h);
    ghosted_nodes.copy(lambda, lambda_h);

    // Nodal values X_alpha = V c_alpha, dual coefficients
    // X3_I = (lambda_h, phi_I)_K = (T^T M c_lambda)_I.
    const unsigned int                   n_c = cell_fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> nodes(n_c);
    Vector<double>                       c(n_c), x(n_c), Mc(n_c);
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            {
              get_values(alpha == 0 ? u1 : u2, nodes, c);
              V.vmult(x, c);
              for (unsigned int I = 0; I < n_c; ++I)
                solution(index(nodes[I], alpha)) = x(I);
            }
          get_values(lambda, nodes, c);
          local_matrices_of(cell).mass.vmult(Mc, c);
          T.Tvmult(x, Mc);
          for (unsigned int I = 0; I < n_c; ++I)
            solution(index(nodes[I], multiplier)) = x(I);
        }
    solution.compress(VectorOperation::insert);
    set_face_unknowns_from_traces(solution);
  }


  template <int dim>
  std::string
  HHOProblem<dim>::description() const
  {
    const auto        &linear = parameters.linear_solver;
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << domain.name()
         << ", HHO cells P" << degree << " / faces P" << degree - 1
         << ", Newton-" << C.name()
         << (parameters.nonlinear_solver.nested_iteration ? " with" :
                                                            " without")
         << " nested iteration, "
         << (parameters.static_condensation ?
               "static condensation, " + VI::to_string(linear.solver) +
                 (linear.solver == VI::LinearSolverType::cg ?
                    " + " + VI::to_string(linear.preconditioner) :
                    std::string()) +
                 " on the faces" :
               "no static condensation, direct solver");
    return line.str();
  }


  template class HHOProblem<2>;
} // namespace StepHHO
