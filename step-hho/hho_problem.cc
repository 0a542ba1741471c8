#include "hho_problem.h"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/utilities.h>
#include <deal.II/base/work_stream.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/meshworker/copy_data.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/errors.h>
#include <vi/linear_solvers.h>
#include <vi/nodal_fields.h>
#include <vi/program.h>

#include "local_operators.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <tuple>

namespace StepHHO
{
  using VI::NodalFields::index;
  using VI::NodalFields::multiplier;
  using VI::NodalFields::n_fields;

  void
  Parameters::declare(ParameterHandler &prm)
  {
    VI::ProblemParameters::declare(prm,
                                   VI::membrane_test_case_names(),
                                   "seed-smooth");
    VI::MeshParameters::declare(prm, "global");
    // The shared declaration's default method is "fem", which must be among
    // the accepted values; step-hho then narrows "Method" to "hho" (a later
    // declaration of an entry replaces the earlier one).
    VI::DiscretizationParameters::declare(prm, "fem|hho");
    prm.enter_subsection("Discretization");
    {
      prm.declare_entry("Method",
                        "hho",
                        Patterns::Selection("hho"),
                        "Discretisation of the membranes: hho (cell "
                        "polynomials of degree p, face polynomials of degree "
                        "p - 1).");
      prm.declare_entry("Static condensation",
                        "true",
                        Patterns::Bool(),
                        "true: in every Newton step, eliminate the cell "
                        "unknowns (both membranes and the multiplier) cell by "
                        "cell and solve the system on the faces only; false: "
                        "solve the whole linearised system (for comparison; "
                        "needs Linear solver/Solver = direct).");
      prm.declare_entry("Gradient degree",
                        "p",
                        Patterns::Selection("p|p-1"),
                        "Degree k of the gradient reconstruction G_K in "
                        "P_k(K)^2: p as in the seed (exact on P_p on "
                        "parallelograms), or p-1 (exact on P_p on "
                        "parallelograms, and a projection of the gradient on "
                        "any straight-sided cell).");
      prm.declare_entry("Contact nodes",
                        "gauss-padua",
                        Patterns::Selection("gauss-padua|padua"),
                        "The nodes x_I of each cell at which u1 - u2 >= 0 is "
                        "imposed: the checkerboard half of a (p+1) x (p+2) "
                        "grid of Gauss-Legendre points (gauss-padua: all "
                        "interpolatory weights positive), or of "
                        "Chebyshev-Lobatto points (padua: some weights <= 0 "
                        "for p >= 2, which spoils the multiplier).");
    }
    prm.leave_subsection();
    VI::NonlinearSolverParameters::declare(prm, "exact");
    VI::LinearSolverParameters::declare(prm, "direct|cg", "cg");
    prm.enter_subsection("Linear solver");
    {
      prm.declare_entry("Solver",
                        "cg",
                        Patterns::Selection("direct|cg"),
                        "cg: conjugate gradients with the preconditioner "
                        "below on the condensed face system (symmetric "
                        "positive definite); direct: sparse LU through "
                        "Trilinos Amesos, on the face system with static "
                        "condensation and on the whole system without.");
      prm.declare_entry("Preconditioner",
                        "amg",
                        Patterns::Selection("ilu|amg"),
                        "Preconditioner of CG on each of the two face "
                        "systems (the mean and the difference of the "
                        "membranes): amg (Trilinos ML) or ilu (Trilinos "
                        "Ifpack).");
    }
    prm.leave_subsection();
    VI::OutputParameters::declare(prm);
  }


  void
  Parameters::parse(ParameterHandler &prm)
  {
    problem.parse(prm);
    mesh.parse(prm);
    discretization.parse(prm);
    prm.enter_subsection("Discretization");
    static_condensation = prm.get_bool("Static condensation");
    contact_nodes       = prm.get("Contact nodes");
    gradient_degree     = prm.get("Gradient degree");
    prm.leave_subsection();
    nonlinear_solver.parse(prm);
    linear_solver.parse(prm);
    output.parse(prm);

    if (linear_solver.solver == "cg" && !static_condensation)
      throw VI::InputError(
        "Linear solver/Solver = cg needs Discretization/Static condensation "
        "= true: without condensation the Newton system is a nonsymmetric "
        "saddle-point system (use Solver = direct)");
  }


  /**
   * The solver of one linear system of a Newton step (the whole Jacobian, or
   * one of the two face systems of the static condensation): sparse LU (VI::
   * LinearSolver: symbolic factorisation once per matrix, numeric one per
   * initialize()), or CG preconditioned with AMG or ILU for the face systems
   * of the static condensation, which are symmetric positive definite (the
   * energy of the cell problems with their constraints eliminated).
   */
  class JacobianSolver
  {
  public:
    JacobianSolver(const VI::LinearSolverParameters     &parameters,
                   const std::vector<std::vector<bool>> &constant_modes,
                   const bool                            higher_order)
        : parameters(parameters)
        , direct(parameters)
        , constant_modes(constant_modes)
        , higher_order(higher_order)
    {
    }

    void
    initialize(const TrilinosWrappers::SparseMatrix &A)
    {
      if (parameters.solver == "direct")
        direct.initialize(A);
      else if (parameters.preconditioner == "amg")
        {
          TrilinosWrappers::PreconditionAMG::AdditionalData settings;
          settings.elliptic              = true;
          settings.higher_order_elements = higher_order;
          settings.constant_modes        = constant_modes;
          auto amg = std::make_unique<TrilinosWrappers::PreconditionAMG>();
          amg->initialize(A, settings);
          preconditioner = std::move(amg);
        }
      else
        {
          TrilinosWrappers::PreconditionILU::AdditionalData settings(
            parameters.ilu_fill);
          auto ilu = std::make_unique<TrilinosWrappers::PreconditionILU>();
          ilu->initialize(A, settings);
          preconditioner = std::move(ilu);
        }
    }

    /**
     * Solve A x = b, by CG to |b - A x| <= tolerance; return the number of
     * CG iterations (0 for LU).
     */
    unsigned int
    solve(const TrilinosWrappers::SparseMatrix &A,
          TrilinosWrappers::MPI::Vector        &x,
          const TrilinosWrappers::MPI::Vector  &b,
          const double                          tolerance)
    {
      if (parameters.solver == "direct")
        return direct.solve(b, x);

      SolverControl                           control(parameters.max_iterations,
                            tolerance,
                            /*log_history=*/false,
                            /*log_result=*/false);
      SolverCG<TrilinosWrappers::MPI::Vector> cg(control);
      x = 0;
      try
        {
          cg.solve(A, x, b, *preconditioner);
        }
      catch (const SolverControl::NoConvergence &failure)
        {
          std::ostringstream message;
          message << "CG on the condensed system: no convergence in "
                  << failure.last_step << " iterations (residual "
                  << failure.last_residual << ", tolerance " << tolerance
                  << ")";
          throw VI::SolverFailure(message.str());
        }
      return control.last_step();
    }

  private:
    const VI::LinearSolverParameters                    parameters;
    VI::LinearSolver                                    direct;
    std::unique_ptr<TrilinosWrappers::PreconditionBase> preconditioner;
    const std::vector<std::vector<bool>>                constant_modes;
    const bool                                          higher_order;
  };


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

    /// The local vectors of the cell loops that only do dense linear
    /// algebra: one set per thread, reused from cell to cell.
    struct CellVectors
    {
      Vector<double> x, y, b, v, Av, Ga, Gb, r_L, dy;
    };

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
  } // namespace


  template <int dim>
  HHOProblem<dim>::HHOProblem(const Parameters &parameters,
                              ParameterHandler &prm,
                              const MPI_Comm    comm)
      : parameters(parameters)
      , prm(prm)
      , comm(comm)
      , pcout(std::cout, Utilities::MPI::this_mpi_process(comm) == 0)
      // Wall times of rank 0: a TimerOutput without communicator needs no MPI
      // in its destructor, which also runs when a failure unwinds the stack.
      , timer(pcout, TimerOutput::never, TimerOutput::wall_times)
      , geometry(VI::geometry_from_name(parameters.mesh.geometry))
      , data(VI::make_membrane_data<dim>(parameters.problem,
                                         VI::geometry_center<dim>(geometry)))
      , C(VI::ComplementarityFunction::from_name(
          parameters.nonlinear_solver.c_function))
      , triangulation(comm)
      , mapping(
          VI::make_mapping<dim>(geometry, parameters.discretization.degree))
      , degree(parameters.discretization.degree)
      , cell_fe(degree)
      , face_fe(degree - 1)
      , cell_dof_handler(triangulation)
      , face_dof_handler(triangulation)
      , run_record("step-hho", parameters.output.directory, timer, comm)
  {
    static_assert(dim == 2,
                  "The contact nodes are those of the square "
                  "(local_operators.h).");
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


  // Positions in X of the cell unknowns (x1, x2, x3; n_c each) and of the
  // face unknowns (y1, y2; n_f each, in FE_FaceQ's cell-local order) of a
  // locally owned cell: the local order of static_condensation.h.
  template <int dim>
  ArrayView<const types::global_dof_index>
  HHOProblem<dim>::local_unknowns(const CellIterator &cell) const
  {
    const unsigned int n =
      n_fields * cell_fe.n_dofs_per_cell() + 2 * face_fe.n_dofs_per_cell();
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
                            *mapping,
                            QGauss<dim>(degree + 2).get_points(),
                            boundary_points,
                            comm);
  }


  template <int dim>
  void
  HHOProblem<dim>::make_grid()
  {
    VI::make_coarse_mesh(geometry, triangulation);
    triangulation.refine_global(parameters.mesh.initial_refinements);
  }


  // Number the unknowns, project the Dirichlet data onto the boundary faces,
  // and make the sparsity of the matrices that are solved: the face systems
  // with static condensation, the whole Jacobian without.
  template <int dim>
  void
  HHOProblem<dim>::setup_system()
  {
    TimerOutput::Scope t(timer, "setup");

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

    {
      const unsigned int n_c = cell_fe.n_dofs_per_cell();
      const unsigned int n_f = face_fe.n_dofs_per_cell();
      const unsigned int n   = n_fields * n_c + 2 * n_f;
      unknown_indices.assign(triangulation.n_active_cells() * n,
                             numbers::invalid_dof_index);
      std::vector<types::global_dof_index> nodes(n_c), face_dofs(n_f);
      for (const auto &cell : cell_dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
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

    // Dirichlet data: on each boundary face F, u_alpha,F = Pi_F g_alpha, the
    // L2 projection onto P_{p-1}(F). These face unknowns are fixed: Newton
    // updates vanish there (homogeneous constraints), and X carries the
    // projected values from the start.
    face_constraints.clear();
    face_constraints.reinit(relevant_faces);
    boundary_values.reinit(owned_system, comm);
    {
      FEFaceValues<dim>    face_values(*mapping,
                                    face_fe,
                                    QGauss<dim - 1>(degree + 2),
                                    update_values | update_quadrature_points |
                                      update_JxW_values);
      const Function<dim> *g[2] = {data.g1.get(), data.g2.get()};
      std::vector<types::global_dof_index> face_dofs(face_fe.n_dofs_per_cell());
      for (const auto &cell : face_dof_handler.active_cell_iterators())
        if (cell->is_locally_owned())
          for (const unsigned int f : cell->face_indices())
            if (cell->face(f)->at_boundary())
              {
                cell->get_dof_indices(face_dofs);
                face_values.reinit(cell, f);
                const unsigned int n_F = face_fe.n_dofs_per_face(f);
                FullMatrix<double> M_F(n_F, n_F);
                Vector<double>     moments(n_F), coefficients(n_F);
                for (unsigned int alpha = 0; alpha < 2; ++alpha)
                  {
                    M_F     = 0;
                    moments = 0;
                    for (const unsigned int q :
                         face_values.quadrature_point_indices())
                      {
                        const double g_q =
                          g[alpha]->value(face_values.quadrature_point(q));
                        for (unsigned int k = 0; k < n_F; ++k)
                          {
                            const double psi_k = face_values.shape_value(
                              face_fe.face_to_cell_index(k, f), q);
                            moments(k) += g_q * psi_k * face_values.JxW(q);
                            for (unsigned int l = 0; l < n_F; ++l)
                              M_F(k, l) +=
                                psi_k *
                                face_values.shape_value(
                                  face_fe.face_to_cell_index(l, f), q) *
                                face_values.JxW(q);
                          }
                      }
                    M_F.gauss_jordan();
                    M_F.vmult(coefficients, moments);
                    for (unsigned int k = 0; k < n_F; ++k)
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
    face_constraints.close();
    boundary_values.compress(VectorOperation::insert);
    n_boundary_face_dofs =
      Utilities::MPI::sum(face_constraints.n_constraints(), comm);

    system_constraints.clear();
    system_constraints.reinit(relevant_system);
    for (const auto &line : face_constraints.get_lines())
      for (unsigned int alpha = 0; alpha < 2; ++alpha)
        system_constraints.add_line(face_unknown(line.index, alpha));
    system_constraints.close();

    // Every cell node carries a complementarity pair.
    contact_rows.reinit(owned_nodes, AffineConstraints<double>());

    if (parameters.static_condensation)
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
    else
      {
        // The couplings of a cell: (x1; x1, x3, y1), (x2; x2, x3, y2),
        // (x3; x1, x2, x3) at each node, (y1; x1, y1), (y2; x2, y2).
        const unsigned int n_c = cell_fe.n_dofs_per_cell();
        const unsigned int n_f = face_fe.n_dofs_per_cell();
        const unsigned int n   = n_fields * n_c + 2 * n_f;
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
              const bool same_node = bi < 3 && bj < 3 && i % n_c == j % n_c;
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
    const double quantum = 1e-12 * VI::geometry_diameter(geometry);
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
        const unsigned int n = n_fields * n_c + 2 * n_f;
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


  // The face unknowns of X from its cell polynomials: on every interior
  // face the average of the projections of the two traces onto P_{p-1}(F)
  // (used to start Newton on a refined mesh).
  template <int dim>
  void
  HHOProblem<dim>::set_face_unknowns_from_traces(
    TrilinosWrappers::MPI::Vector &X) const
  {
    TrilinosWrappers::MPI::Vector        faces(owned_system, comm);
    FEFaceValues<dim>                    trace_values(*mapping,
                                   cell_fe,
                                   QGauss<dim - 1>(degree + 2),
                                   update_values | update_JxW_values);
    FEFaceValues<dim>                    face_values(*mapping,
                                  face_fe,
                                  QGauss<dim - 1>(degree + 2),
                                  update_values);
    const unsigned int                   n_c = cell_fe.n_dofs_per_cell();
    const unsigned int                   n_f = face_fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> nodes(n_c), face_dofs(n_f);
    Vector<double> coefficients[2] = {Vector<double>(n_c), Vector<double>(n_c)};
    const TrilinosWrappers::MPI::Vector *u[2] = {&u1_h, &u2_h};

    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            get_values(*u[alpha], nodes, coefficients[alpha]);
          face_cell(cell)->get_dof_indices(face_dofs);
          for (const unsigned int f : cell->face_indices())
            if (!cell->face(f)->at_boundary())
              {
                trace_values.reinit(cell, f);
                // (the face element's values need only the geometry)
                face_values.reinit(
                  typename Triangulation<dim>::cell_iterator(cell), f);
                const unsigned int n_F = face_fe.n_dofs_per_face(f);
                FullMatrix<double> M_F(n_F, n_F);
                Vector<double>     moments(n_F), projection(n_F);
                for (unsigned int alpha = 0; alpha < 2; ++alpha)
                  {
                    M_F     = 0;
                    moments = 0;
                    for (const unsigned int q :
                         trace_values.quadrature_point_indices())
                      {
                        double trace = 0;
                        for (unsigned int j = 0; j < n_c; ++j)
                          trace += coefficients[alpha](j) *
                                   trace_values.shape_value(j, q);
                        for (unsigned int k = 0; k < n_F; ++k)
                          {
                            const double psi_k = face_values.shape_value(
                              face_fe.face_to_cell_index(k, f), q);
                            moments(k) += trace * psi_k * trace_values.JxW(q);
                            for (unsigned int l = 0; l < n_F; ++l)
                              M_F(k, l) +=
                                psi_k *
                                face_values.shape_value(
                                  face_fe.face_to_cell_index(l, f), q) *
                                trace_values.JxW(q);
                          }
                      }
                    M_F.gauss_jordan();
                    M_F.vmult(projection, moments);
                    for (unsigned int k = 0; k < n_F; ++k)
                      {
                        const types::global_dof_index i = face_unknown(
                          face_dofs[face_fe.face_to_cell_index(k, f)], alpha);
                        const double half = 0.5 * projection(k);
                        faces.add(1, &i, &half);
                      }
                  }
              }
        }
    faces.compress(VectorOperation::add);
    X.add(1., faces);
  }


  // The Newton iterate on a new mesh: the previous mesh's solution
  // transferred (nested iteration) as cell polynomials, with the face
  // unknowns from their traces; or zero cell, interior face and multiplier
  // unknowns. Either way the boundary faces carry Pi_F g.
  template <int dim>
  void
  HHOProblem<dim>::initialize_iterate()
  {
    solution = boundary_values;
    if (!solution_transfer)
      return;

    TrilinosWrappers::MPI::Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      lambda(owned_nodes, comm);
    std::vector<TrilinosWrappers::MPI::Vector *> fields = {&u1, &u2, &lambda};
    solution_transfer->interpolate(fields);
    solution_transfer.reset();
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


  // ------------------------------------------------------------------------
  // Semismooth Newton.

  // The rows of the balance equations, E X - F: cell rows of u1 and u2,
  // and the face rows of the interior faces (the rows of the boundary faces
  // and of the complementarity are left 0). Cell by cell with the local HHO
  // matrices; the face rows collect the contributions of both neighbours.
  template <int dim>
  void
  HHOProblem<dim>::equation_residual(const TrilinosWrappers::MPI::Vector &X,
                                     TrilinosWrappers::MPI::Vector &R) const
  {
    ghosted_system.copy(X, ghosted_iterate);
    R                        = 0;
    const unsigned int n_c   = cell_fe.n_dofs_per_cell();
    const unsigned int n_f   = face_fe.n_dofs_per_cell();
    const double       mu[2] = {data.mu1, data.mu2};

    using CopyData = MeshWorker::CopyData<0, 1, 1>;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const StaticCondensation::CellOperators &operators =
          local_matrices_of(cell).operators;
        const auto      unknowns      = local_unknowns(cell);
        const auto      face_unknowns = unknowns.begin() + n_fields * n_c;
        Vector<double> &x = scratch.x, &y = scratch.y, &b = scratch.b;
        x.reinit(n_fields * n_c, true);
        y.reinit(2 * n_f, true);
        b.reinit(2 * n_c, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          x(i) = ghosted_iterate(unknowns[i]);
        for (unsigned int k = 0; k < 2 * n_f; ++k)
          y(k) = ghosted_iterate(face_unknowns[k]);
        for (unsigned int i = 0; i < 2 * n_c; ++i)
          b(i) = load(unknowns[i]);

        // Rows: cells of u1, u2 (2 n_c), faces of y1, y2 (2 n_f).
        copy.vectors[0].reinit(2 * n_c + 2 * n_f);
        copy.local_dof_indices[0].assign(unknowns.begin(),
                                         unknowns.begin() + 2 * n_c);
        copy.local_dof_indices[0].insert(copy.local_dof_indices[0].end(),
                                         face_unknowns,
                                         unknowns.end());
        Vector<double> &v = scratch.v, &Av = scratch.Av;
        v.reinit(n_c + n_f, true);
        Av.reinit(n_c + n_f, true);
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          {
            for (unsigned int I = 0; I < n_c; ++I)
              v(I) = x(alpha * n_c + I);
            for (unsigned int k = 0; k < n_f; ++k)
              v(n_c + k) = y(alpha * n_f + k);
            operators.A.vmult(Av, v);
            const double sign = alpha == 0 ? -1. : 1.;
            for (unsigned int I = 0; I < n_c; ++I)
              copy.vectors[0](alpha * n_c + I) =
                mu[alpha] * Av(I) + sign * x(2 * n_c + I) - b(alpha * n_c + I);
            // (no equation in the rows of the fixed boundary face values)
            for (unsigned int k = 0; k < n_f; ++k)
              if (!system_constraints.is_constrained(
                    face_unknowns[alpha * n_f + k]))
                copy.vectors[0](2 * n_c + alpha * n_f + k) =
                  mu[alpha] * Av(n_c + k);
          }
      };
    const auto copier = [&](const CopyData &copy) {
      R.add(copy.local_dof_indices[0], copy.vectors[0]);
    };
    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          CellVectors(),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    R.compress(VectorOperation::add);
  }


  // R(X) = [E X - F ; C(X)] and its two dimensionless norms.
  template <int dim>
  VI::ResidualNorms
  HHOProblem<dim>::residual(const TrilinosWrappers::MPI::Vector &X,
                            TrilinosWrappers::MPI::Vector       &R) const
  {
    TimerOutput::Scope t(timer, "residual");
    equation_residual(X, R);
    VI::ResidualNorms norms;
    norms.equations =
      R.l2_norm() / std::max(load_norm, std::numeric_limits<double>::min());
    norms.complementarity = contact_rows.evaluate(C, X, multiplier_scale, R);
    return norms;
  }


  template <int dim>
  void
  HHOProblem<dim>::setup_jacobian(const TrilinosWrappers::MPI::Vector &X)
  {
    if (parameters.static_condensation)
      assemble_difference_matrix(X);
    else
      {
        TimerOutput::Scope t(timer, "assembly: jacobian rows");
        contact_rows.set_jacobian_rows(C, X, system_matrix);
        system_matrix.compress(VectorOperation::insert);
      }
    // The factorisation (LU) or the preconditioner (CG) of this Jacobian.
    TimerOutput::Scope t(timer, "solve: setup");
    jacobian_solver->initialize(
      parameters.static_condensation ? difference_matrix : system_matrix);
  }


  // Static condensation of the generalised Jacobian at X: on every cell,
  // eliminate (x1, x2, x3) (static_condensation.h) and add the cell's
  // contribution to the face matrix of the difference of the membranes
  // (that of the mean does not depend on X).
  template <int dim>
  void
  HHOProblem<dim>::assemble_difference_matrix(
    const TrilinosWrappers::MPI::Vector &X)
  {
    TimerOutput::Scope t(timer, "static condensation");
    difference_matrix      = 0;
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();

    using CopyData = MeshWorker::CopyData<1, 0, 1>;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        // The generalised Jacobian (dC/da, dC/db) at the cell's nodes,
        // a = X1_I - X2_I, b = X3_I (all owned by this process).
        const auto      unknowns = local_unknowns(cell);
        Vector<double> &Ga = scratch.Ga, &Gb = scratch.Gb;
        Ga.reinit(n_c, true);
        Gb.reinit(n_c, true);
        for (unsigned int I = 0; I < n_c; ++I)
          {
            const auto g =
              C.generalized_gradient(X(unknowns[I]) - X(unknowns[n_c + I]),
                                     X(unknowns[2 * n_c + I]));
            Ga(I) = g[0];
            Gb(I) = g[1];
          }
        const StaticCondensation::CellOperators &operators =
          local_matrices_of(cell).operators;
        StaticCondensation::CellElimination &elimination =
          eliminations[cell->active_cell_index()];
        elimination.reinit(operators, data.mu1, data.mu2, Ga, Gb);
        elimination.difference_matrix(operators, copy.matrices[0]);
        copy.local_dof_indices[0].resize(n_f);
        for (unsigned int k = 0; k < n_f; ++k)
          copy.local_dof_indices[0][k] = face_dof(unknowns[n_fields * n_c + k]);
      };
    const auto copier = [&](const CopyData &copy) {
      face_constraints.distribute_local_to_global(copy.matrices[0],
                                                  copy.local_dof_indices[0],
                                                  difference_matrix);
    };
    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          CellVectors(),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    difference_matrix.compress(VectorOperation::add);
  }


  template <int dim>
  unsigned int
  HHOProblem<dim>::solve_with_jacobian(const TrilinosWrappers::MPI::Vector &rhs,
                                       TrilinosWrappers::MPI::Vector       &dX)
  {
    if (!parameters.static_condensation)
      {
        TimerOutput::Scope t(timer, "solve");
        return jacobian_solver->solve(system_matrix, dX, rhs, 0.);
      }
    condense_rhs(rhs);
    const unsigned int iterations = solve_condensed_system();
    recover_cell_unknowns(rhs, dX);
    return iterations;
  }


  // The right-hand sides of the face systems: the face rows of rhs, minus
  // what the cell rows contribute through the eliminated cell unknowns,
  // (b1, b2); then those of the mean, b1 + b2, and of the difference,
  // (mu2 b1 - mu1 b2) / (mu1 + mu2).
  template <int dim>
  void
  HHOProblem<dim>::condense_rhs(const TrilinosWrappers::MPI::Vector &rhs)
  {
    TimerOutput::Scope            t(timer, "static condensation");
    const unsigned int            n_c = cell_fe.n_dofs_per_cell();
    const unsigned int            n_f = face_fe.n_dofs_per_cell();
    TrilinosWrappers::MPI::Vector condensed(owned_system, comm);
    std::copy(rhs.begin() + n_fields * owned_nodes.n_elements(),
              rhs.end(),
              condensed.begin() + n_fields * owned_nodes.n_elements());

    using CopyData = MeshWorker::CopyData<0, 1, 1>;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const auto      unknowns = local_unknowns(cell);
        Vector<double> &r_L      = scratch.r_L;
        r_L.reinit(n_fields * n_c, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          r_L(i) = rhs(unknowns[i]);
        eliminations[cell->active_cell_index()].condensed_rhs(
          local_matrices_of(cell).operators, r_L, copy.vectors[0]);
        copy.local_dof_indices[0].assign(unknowns.begin() + n_fields * n_c,
                                         unknowns.end());
        for (unsigned int k = 0; k < 2 * n_f; ++k)
          if (system_constraints.is_constrained(copy.local_dof_indices[0][k]))
            copy.vectors[0](k) = 0;
      };
    const auto copier = [&](const CopyData &copy) {
      condensed.add(copy.local_dof_indices[0], copy.vectors[0]);
    };
    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          CellVectors(),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    condensed.compress(VectorOperation::add);

    const double  m = data.mu1 + data.mu2;
    const double *faces =
      condensed.begin() + n_fields * owned_nodes.n_elements();
    for (std::size_t k = 0; k < owned_faces.n_elements(); ++k)
      {
        const double b1           = faces[2 * k];
        const double b2           = faces[2 * k + 1];
        mean_rhs.begin()[k]       = b1 + b2;
        difference_rhs.begin()[k] = (data.mu2 * b1 - data.mu1 * b2) / m;
      }
  }


  // The two face systems, each by CG to a residual below Linear
  // solver/Tolerance times the norm of the whole right-hand side (so that
  // the mean's system, whose right-hand side vanishes once its equations
  // are solved, costs no iterations in later Newton steps); then the face
  // updates of both membranes, dy1 = ds + mu2 / m dd, dy2 = ds - mu1 / m dd.
  template <int dim>
  unsigned int
  HHOProblem<dim>::solve_condensed_system()
  {
    TimerOutput::Scope t(timer, "solve");
    const double       tolerance =
      parameters.linear_solver.tolerance *
      std::sqrt(mean_rhs.norm_sqr() + difference_rhs.norm_sqr());
    const unsigned int iterations =
      mean_solver->solve(mean_matrix, mean_update, mean_rhs, tolerance) +
      jacobian_solver->solve(difference_matrix,
                             difference_update,
                             difference_rhs,
                             tolerance);
    face_constraints.distribute(mean_update);
    face_constraints.distribute(difference_update);
    ghosted_faces.copy(mean_update, ghosted_mean_update);
    ghosted_faces.copy(difference_update, ghosted_difference_update);
    return iterations;
  }


  // The Newton update: its face part from the mean and the difference, its
  // cell part recovered cell by cell.
  template <int dim>
  void
  HHOProblem<dim>::recover_cell_unknowns(
    const TrilinosWrappers::MPI::Vector &rhs,
    TrilinosWrappers::MPI::Vector       &dX)
  {
    TimerOutput::Scope t(timer, "recovery");
    const unsigned int n_c = cell_fe.n_dofs_per_cell();
    const unsigned int n_f = face_fe.n_dofs_per_cell();
    const double       m   = data.mu1 + data.mu2;
    const double       w1 = data.mu2 / m, w2 = -data.mu1 / m;

    using CopyData = MeshWorker::CopyData<0, 1, 1>;
    const auto cell_worker =
      [&](const CellIterator &cell, CellVectors &scratch, CopyData &copy) {
        const auto unknowns = local_unknowns(cell);
        copy.local_dof_indices[0].assign(unknowns.begin(),
                                         unknowns.begin() + n_fields * n_c);
        Vector<double> &r_L = scratch.r_L, &dy = scratch.dy;
        r_L.reinit(n_fields * n_c, true);
        dy.reinit(2 * n_f, true);
        for (unsigned int i = 0; i < n_fields * n_c; ++i)
          r_L(i) = rhs(unknowns[i]);
        for (unsigned int k = 0; k < n_f; ++k)
          {
            const types::global_dof_index j =
              face_dof(unknowns[n_fields * n_c + k]);
            const double ds = ghosted_mean_update(j);
            const double dd = ghosted_difference_update(j);
            dy(k)           = ds + w1 * dd;
            dy(n_f + k)     = ds + w2 * dd;
          }
        eliminations[cell->active_cell_index()].recover(
          local_matrices_of(cell).operators, r_L, dy, copy.vectors[0]);
      };
    const auto copier = [&](const CopyData &copy) {
      dX.set(copy.local_dof_indices[0], copy.vectors[0]);
    };
    MeshWorker::mesh_loop(cell_dof_handler.active_cell_iterators() |
                            IteratorFilters::LocallyOwnedCell(),
                          cell_worker,
                          copier,
                          CellVectors(),
                          CopyData(0),
                          MeshWorker::assemble_own_cells);
    dX.compress(VectorOperation::insert);

    double *faces = dX.begin() + n_fields * owned_nodes.n_elements();
    for (std::size_t k = 0; k < owned_faces.n_elements(); ++k)
      {
        const double ds  = mean_update.begin()[k];
        const double dd  = difference_update.begin()[k];
        faces[2 * k]     = ds + w1 * dd;
        faces[2 * k + 1] = ds + w2 * dd;
      }
  }


  template <int dim>
  void
  HHOProblem<dim>::solve()
  {
    const auto &p = parameters.nonlinear_solver;
    const typename VI::SemismoothNewton<
      TrilinosWrappers::MPI::Vector>::AdditionalData settings(p, C);

    jacobian_solver = std::make_unique<JacobianSolver>(parameters.linear_solver,
                                                       constant_modes,
                                                       degree > 1);
    if (parameters.static_condensation)
      {
        // The mean's face matrix is the same in every Newton step.
        TimerOutput::Scope t(timer, "solve: setup");
        mean_solver = std::make_unique<JacobianSolver>(parameters.linear_solver,
                                                       constant_modes,
                                                       degree > 1);
        mean_solver->initialize(mean_matrix);
      }

    VI::SemismoothNewton<TrilinosWrappers::MPI::Vector> newton(settings);
    newton.residual = [&](const auto &X, auto &R) { return residual(X, R); };
    newton.setup_jacobian      = [&](const auto &X) { setup_jacobian(X); };
    newton.solve_with_jacobian = [&](const auto &rhs, auto &dX) {
      return solve_with_jacobian(rhs, dX);
    };
    newton.active_set = [&](const auto &X, const bool first) {
      return contact_rows.linearised_active_set(C, X, active_rows, !first);
    };
    if (parameters.output.verbose)
      newton.monitor = [&](const VI::NewtonStep &step) {
        pcout << "      k = " << std::setw(2) << step.iteration << ": "
              << VI::describe(step, "CG") << std::endl;
      };

    newton_report = newton.solve(solution);
    mean_solver.reset();
    jacobian_solver.reset();
  }


  // ------------------------------------------------------------------------
  // Results.

  // The cell unknowns as FE_DGP functions: u_alpha,K = sum_j (T X_alpha)_j
  // P_j, lambda_h with coefficients M^{-1} V^T X3 (from X3 = T^T M c), and
  // the nodes in contact.
  template <int dim>
  void
  HHOProblem<dim>::postprocess()
  {
    TimerOutput::Scope            t(timer, "postprocess");
    const unsigned int            n_c = cell_fe.n_dofs_per_cell();
    TrilinosWrappers::MPI::Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      gap(owned_nodes, comm), lambda(owned_nodes, comm),
      indicator(owned_nodes, comm);

    std::vector<types::global_dof_index> nodes(n_c);
    Vector<double>                       x(n_c), c(n_c), Vx(n_c);
    FullMatrix<double>                   M_inverse;
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          Vector<double> c_alpha[2] = {Vector<double>(n_c),
                                       Vector<double>(n_c)};
          for (unsigned int alpha = 0; alpha < 2; ++alpha)
            {
              for (unsigned int I = 0; I < n_c; ++I)
                x(I) = solution(index(nodes[I], alpha));
              T.vmult(c_alpha[alpha], x);
            }
          for (unsigned int I = 0; I < n_c; ++I)
            x(I) = solution(index(nodes[I], multiplier));
          V.Tvmult(Vx, x);
          M_inverse = local_matrices_of(cell).mass;
          M_inverse.gauss_jordan();
          M_inverse.vmult(c, Vx);
          for (unsigned int j = 0; j < n_c; ++j)
            {
              u1(nodes[j])     = c_alpha[0](j);
              u2(nodes[j])     = c_alpha[1](j);
              gap(nodes[j])    = c_alpha[0](j) - c_alpha[1](j);
              lambda(nodes[j]) = c(j);
            }
        }
    for (auto *v : {&u1, &u2, &gap, &lambda})
      v->compress(VectorOperation::insert);
    ghosted_nodes.copy(u1, u1_h);
    ghosted_nodes.copy(u2, u2_h);
    ghosted_nodes.copy(gap, gap_h);
    ghosted_nodes.copy(lambda, lambda_h);

    // Nodes where u1 = u2 is enforced, and their share on each cell.
    n_contact_nodes = contact_rows.contact_set(solution, indicator);
    contact_fraction.reinit(triangulation.n_active_cells());
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(nodes);
          double in_contact = 0;
          for (const auto i : nodes)
            in_contact += indicator(i);
          contact_fraction(cell->active_cell_index()) = in_contact / n_c;
        }
  }


  // The energy error of the slides, |||u - u_h|||^2 = sum_K mu1 |u1 -
  // u1,K|^2_{1,K} + mu2 |u2 - u2,K|^2_{1,K} with the cell polynomials, and the
  // L2 error of the multiplier.
  template <int dim>
  void
  HHOProblem<dim>::compute_errors()
  {
    if (!data.has_exact_solution())
      return;
    TimerOutput::Scope t(timer, "errors");

    const QGauss<dim> quadrature(degree + 3);
    Vector<float>     cellwise(triangulation.n_active_cells());
    const auto        error = [&](const TrilinosWrappers::MPI::Vector &uh,
                           const Function<dim>                 &exact,
                           const VectorTools::NormType          norm) {
      VectorTools::integrate_difference(
        *mapping, cell_dof_handler, uh, exact, cellwise, quadrature, norm);
      return VectorTools::compute_global_error(triangulation, cellwise, norm);
    };
    const double e1 = error(u1_h, *data.exact_u1, VectorTools::H1_seminorm);
    const double e2 = error(u2_h, *data.exact_u2, VectorTools::H1_seminorm);
    error_energy    = std::sqrt(data.mu1 * e1 * e1 + data.mu2 * e2 * e2);
    if (data.exact_lambda)
      error_multiplier =
        error(lambda_h, *data.exact_lambda, VectorTools::L2_norm);
  }


  // The cell unknowns for ParaView: u1, u2, gap = u1 - u2 and lambda as
  // discontinuous P_p functions, the share of each cell's nodes in contact,
  // and the owning process.
  template <int dim>
  void
  HHOProblem<dim>::output_results(const unsigned int cycle) const
  {
    if (!parameters.output.write_vtu)
      return;
    TimerOutput::Scope t(timer, "output");

    DataOut<dim> data_out;
    data_out.attach_dof_handler(cell_dof_handler);
    data_out.add_data_vector(u1_h, "u1");
    data_out.add_data_vector(u2_h, "u2");
    data_out.add_data_vector(gap_h, "gap");
    data_out.add_data_vector(lambda_h, "lambda");
    data_out.add_data_vector(contact_fraction,
                             "contact",
                             DataOut<dim>::type_cell_data);
    Vector<float> subdomain(triangulation.n_active_cells());
    subdomain = triangulation.locally_owned_subdomain();
    data_out.add_data_vector(subdomain,
                             "partition",
                             DataOut<dim>::type_cell_data);
    data_out.build_patches(*mapping,
                           degree,
                           VI::has_curved_cells(geometry) ?
                             DataOut<dim>::curved_inner_cells :
                             DataOut<dim>::curved_boundary);
    data_out.write_vtu_with_pvtu_record(
      parameters.output.directory + "/", "solution", cycle, comm, 2, 8);
  }


  // Global refinement; with nested iteration the cell polynomials u1,K,
  // u2,K and lambda_h are carried to the new mesh by SolutionTransfer.
  template <int dim>
  void
  HHOProblem<dim>::refine_mesh()
  {
    TimerOutput::Scope t(timer, "refinement");
    for (const auto &cell : triangulation.active_cell_iterators())
      if (cell->is_locally_owned())
        cell->set_refine_flag();
    triangulation.prepare_coarsening_and_refinement();

    if (parameters.nonlinear_solver.nested_iteration)
      {
        solution_transfer =
          std::make_unique<parallel::distributed::SolutionTransfer<
            dim,
            TrilinosWrappers::MPI::Vector>>(cell_dof_handler);
        solution_transfer->prepare_for_coarsening_and_refinement(
          std::vector<const TrilinosWrappers::MPI::Vector *>{&u1_h,
                                                             &u2_h,
                                                             &lambda_h});
      }
    triangulation.execute_coarsening_and_refinement();
  }


  template <int dim>
  void
  HHOProblem<dim>::record_cycle(const unsigned int cycle)
  {
    const double wall = run_record.cycle_seconds();

    // Unknowns as counted in the seed: 2 (cells dim P_p + interior faces
    // dim P_{p-1}) + cells dim P_p (the multiplier) without static
    // condensation, 2 (interior faces) dim P_{p-1} with it; the fixed
    // boundary face values are not unknowns.
    const types::global_dof_index dofs_condensed =
      2 * (face_dof_handler.n_dofs() - n_boundary_face_dofs);
    const types::global_dof_index dofs =
      n_fields * cell_dof_handler.n_dofs() + dofs_condensed;

    table.add_value("cycle", cycle);
    table.add_value("cells", triangulation.n_global_active_cells());
    table.add_value("dofs", dofs);
    table.add_value("dofs_condensed", dofs_condensed);
    table.add_value("newton", newton_report.iterations);
    table.add_value("linear", newton_report.linear_iterations);
    table.add_value("contact", n_contact_nodes);
    if (data.has_exact_solution())
      {
        table.add_value("error_energy", error_energy);
        table.set_scientific("error_energy", true);
        table.set_precision("error_energy", 4);
        if (data.exact_lambda)
          {
            table.add_value("error_lambda", error_multiplier);
            table.set_scientific("error_lambda", true);
            table.set_precision("error_lambda", 4);
          }
      }
    table.add_value("wall_s", wall);
    table.set_precision("wall_s", 3);

    VI::Json record             = VI::Json::object();
    record["cycle"]             = cycle;
    record["cells"]             = triangulation.n_global_active_cells();
    record["dofs"]              = dofs;
    record["dofs_condensed"]    = dofs_condensed;
    record["dofs_cell"]         = n_fields * cell_dof_handler.n_dofs();
    record["newton_iterations"] = newton_report.iterations;
    record["linear_iterations"] = newton_report.linear_iterations;
    record["contact_nodes"]     = n_contact_nodes;
    if (data.has_exact_solution())
      record["error_energy"] = error_energy;
    if (data.exact_lambda)
      record["error_lambda_l2"] = error_multiplier;
    record["wall_seconds"] = wall;

    // The TimerOutput sections of this cycle.
    record["timing"] = run_record.cycle_timing();

    VI::Json iterations = VI::Json::array();
    for (const VI::NewtonStep &step : newton_report.steps)
      {
        VI::Json it                    = VI::Json::object();
        it["k"]                        = step.iteration;
        it["i"]                        = step.linear_iterations;
        it["residual_equations"]       = step.residual.equations;
        it["residual_complementarity"] = step.residual.complementarity;
        it["step_length"]              = step.step_length;
        iterations.push_back(it);
      }
    record["iterations"] = iterations;
    run_record.add(record);
  }


  // The convergence table, with rates in h (from the DoF counts, d = 2):
  // to the screen with the linear iterations and the wall time, and to
  // convergence.txt without them, so that the file is reproducible on any
  // number of processes (AMG, and with it the CG iteration count, depends
  // on the partition) and diffable.
  template <int dim>
  void
  HHOProblem<dim>::write_tables() const
  {
    std::vector<std::string> errors;
    if (data.has_exact_solution())
      errors.push_back("error_energy");
    if (data.exact_lambda)
      errors.push_back("error_lambda");

    ConvergenceTable with_rates = table;
    for (const std::string &key : errors)
      with_rates.evaluate_convergence_rates(
        key, "dofs", ConvergenceTable::reduction_rate_log2, dim);
    pcout << std::endl;
    if (Utilities::MPI::this_mpi_process(comm) == 0)
      {
        with_rates.write_text(std::cout, TableHandler::org_mode_table);
        std::ofstream file(parameters.output.directory + "/convergence.txt");
        std::vector<std::string> columns = {
          "cycle", "cells", "dofs", "dofs_condensed", "newton", "contact"};
        columns.insert(columns.end(), errors.begin(), errors.end());
        ConvergenceTable file_table = with_rates;
        file_table.set_column_order(columns);
        file_table.write_text(file, TableHandler::org_mode_table);
      }
  }


  template <int dim>
  std::string
  HHOProblem<dim>::description() const
  {
    const auto        &linear = parameters.linear_solver;
    std::ostringstream line;
    line << "Test case " << data.name << " on the " << parameters.mesh.geometry
         << ", HHO cells P" << degree << " / faces P" << degree - 1
         << ", Newton-" << C.name()
         << (parameters.nonlinear_solver.nested_iteration ? " with" :
                                                            " without")
         << " nested iteration, "
         << (parameters.static_condensation ?
               "static condensation, " + linear.solver +
                 (linear.solver == "cg" ? " + " + linear.preconditioner :
                                          std::string()) +
                 " on the faces" :
               "no static condensation, direct solver");
    return line.str();
  }


  // On each mesh: set up, assemble the local HHO operators, solve by
  // semismooth Newton with static condensation in every step, measure the
  // error, write, refine.
  template <int dim>
  void
  HHOProblem<dim>::run()
  {
    run_record.start(prm, description());
    make_grid();
    check_data();
    VI::prepare_output_directory(parameters.output.directory, comm);

    for (unsigned int cycle = 0; cycle < parameters.mesh.cycles; ++cycle)
      {
        run_record.start_cycle();
        if (cycle > 0)
          refine_mesh();
        setup_system();
        assemble_system();
        initialize_iterate();

        const types::global_dof_index dofs_condensed =
          2 * (face_dof_handler.n_dofs() - n_boundary_face_dofs);
        pcout << "Cycle " << cycle << ": "
              << triangulation.n_global_active_cells() << " cells, "
              << n_fields * cell_dof_handler.n_dofs() + dofs_condensed
              << " unknowns, " << dofs_condensed << " after condensation"
              << std::endl;
        run_record.guard([&] { solve(); });
        postprocess();
        compute_errors();
        output_results(cycle);
        run_record.stop_cycle();

        VI::CycleLine line;
        line.solver            = "Newton-" + C.name();
        line.newton_iterations = newton_report.iterations;
        if (newton_report.linear_iterations > 0)
          {
            line.linear_iterations = newton_report.linear_iterations;
            line.linear_solver     = "CG";
          }
        line.contact_nodes = n_contact_nodes;
        if (data.has_exact_solution())
          line.error = error_energy;
        line.seconds = run_record.cycle_seconds();
        pcout << VI::to_string(line) << std::endl;
        record_cycle(cycle);
      }

    write_tables();
    run_record.finish(
      "solution_*.pvtu (ParaView), convergence.txt, summary.json");
  }


  template class HHOProblem<2>;
} // namespace StepHHO
