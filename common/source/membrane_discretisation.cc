// The conforming discretisation of two membranes shared by step-membranes
// and step-parabolic: nodes, constraints, matrices and the cell assembly.

#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/estimators.h>
#include <vi/field_output.h>
#include <vi/flux_reconstruction.h>
#include <vi/membrane_discretisation.h>
#include <vi/nodal_fields.h>
#include <vi/parameters.h>

#include <map>

namespace VI
{
  using namespace dealii;


  template <int dim>
  MembraneDiscretisation<dim>::MembraneDiscretisation(const Geometry geometry,
                                                      const unsigned int degree,
                                                      const MPI_Comm     comm)
      : comm(comm)
      , geometry(geometry)
      , triangulation(comm)
      , geometry_mapping(make_mapping<dim>(geometry, degree))
      , mapping(std::make_unique<MappingQCache<dim>>(
          dynamic_cast<const MappingQ<dim> &>(*geometry_mapping).get_degree()))
      , fe(degree)
      , dof_handler(triangulation)
      , quadrature(FluxReconstruction<dim>::quadrature_points(degree))
  {
  }


  template <int dim>
  MembraneDiscretisation<dim>::MembraneDiscretisation(
    const DomainParameters         &mesh,
    const DiscretizationParameters &discretization,
    const MPI_Comm                  comm)
      : MembraneDiscretisation(geometry_from_name(mesh.geometry),
                               discretization.degree,
                               comm)
  {
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::make_grid(const unsigned int refinements)
  {
    make_coarse_mesh(geometry, triangulation);
    triangulation.refine_global(refinements);
    mapping->initialize(*geometry_mapping, triangulation);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::distribute_nodes()
  {
    mapping->initialize(*geometry_mapping, triangulation);
    dof_handler.distribute_dofs(fe);
    owned_nodes = dof_handler.locally_owned_dofs();
    DoFTools::extract_locally_relevant_dofs(dof_handler, relevant_nodes);
    ghosted_nodes.reinit(owned_nodes, relevant_nodes, comm);
    owned_system    = NodalFields::system_index_set(owned_nodes);
    relevant_system = NodalFields::system_index_set(relevant_nodes);

    hanging_node_constraints.clear();
    hanging_node_constraints.reinit(relevant_nodes);
    DoFTools::make_hanging_node_constraints(dof_handler,
                                            hanging_node_constraints);
    hanging_node_constraints.close();

    for (auto *field : {&u1_h, &u2_h, &gap_h, &lambda_h, &contact_set})
      field->reinit(owned_nodes, relevant_nodes, comm);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::make_constraints(const Function<dim> &g1,
                                                const Function<dim> &g2)
  {
    const auto make_dirichlet = [&](const Function<dim>       &g,
                                    AffineConstraints<double> &constraints) {
      constraints.clear();
      constraints.reinit(relevant_nodes);
      constraints.merge(hanging_node_constraints);
      std::map<types::boundary_id, const Function<dim> *> boundary_data;
      for (const types::boundary_id id : triangulation.get_boundary_ids())
        boundary_data[id] = &g;
      VectorTools::interpolate_boundary_values(*mapping,
                                               dof_handler,
                                               boundary_data,
                                               constraints);
      constraints.close();
    };
    make_dirichlet(g1, u1_constraints);
    make_dirichlet(g2, u2_constraints);
    NodalFields::make_system_constraints(u1_constraints,
                                         u2_constraints,
                                         relevant_system,
                                         system_constraints);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::reinit_matrices(ContactSystem &contact_system)
  {
    // A has the sparsity of S in each of its 3 x 3 node blocks; the
    // constrained rows of S are left out (they are copied as identities).
    DynamicSparsityPattern scalar_pattern(relevant_nodes);
    DoFTools::make_sparsity_pattern(dof_handler,
                                    scalar_pattern,
                                    u1_constraints,
                                    /*keep_constrained_dofs=*/false);
    contact_system.reinit_matrix(scalar_pattern, relevant_nodes);
    stiffness_matrix.reinit(owned_nodes, owned_nodes, scalar_pattern, comm);

    if (fe.degree > 1)
      {
        DynamicSparsityPattern mass_pattern(relevant_nodes);
        DoFTools::make_sparsity_pattern(dof_handler,
                                        mass_pattern,
                                        hanging_node_constraints,
                                        false);
        SparsityTools::distribute_sparsity_pattern(mass_pattern,
                                                   owned_nodes,
                                                   comm,
                                                   relevant_nodes);
        mass_matrix.reinit(owned_nodes, owned_nodes, mass_pattern, comm);
      }
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::make_vertex_dofs()
  {
    vertex_dofs = NodalFields::vertex_nodes(dof_handler);
  }


  template <int dim>
  MembraneDiscretisation<dim>::CellSystem::CellSystem(const unsigned int n_dofs,
                                                      const unsigned int n_q)
      : MeshWorker::CopyData<2, 3, 1>(n_dofs)
      , loads{std::vector<double>(n_q), std::vector<double>(n_q)}
  {
  }


  template <int dim>
  typename MembraneDiscretisation<dim>::Vector
  MembraneDiscretisation<dim>::assemble_cells(
    const CellLoads                               &cell_loads,
    const UpdateFlags                              load_flags,
    const bool                                     mass_term,
    const std::function<void(const CellSystem &)> &copy_system)
  {
    const bool with_mass_matrix = fe.degree > 1;
    const bool cell_mass        = mass_term || with_mass_matrix;
    Vector     lumped_mass(owned_nodes, comm);
    if (with_mass_matrix)
      mass_matrix = 0;

    // mesh_loop calls the copier for every cell of the range it is given,
    // so the range is filtered to the locally owned cells.
    const auto owned_cells =
      dof_handler.active_cell_iterators() | IteratorFilters::LocallyOwnedCell();
    MeshWorker::ScratchData<dim> scratch(*mapping,
                                         fe,
                                         quadrature,
                                         update_values | update_gradients |
                                           update_JxW_values | load_flags);
    CellSystem sample(fe.n_dofs_per_cell(), quadrature.size());

    const auto cell_worker = [&](const CellIterator           &cell,
                                 MeshWorker::ScratchData<dim> &scratch,
                                 CellSystem                   &copy) {
      const FEValues<dim> &fe_values = scratch.reinit(cell);
      for (auto &m : copy.matrices)
        m = 0;
      for (auto &v : copy.vectors)
        v = 0;
      cell->get_dof_indices(copy.local_dof_indices[0]);
      cell_loads(cell, fe_values, copy.loads);

      for (const unsigned int q : fe_values.quadrature_point_indices())
        {
          const double l1 = copy.loads[0][q];
          const double l2 = copy.loads[1][q];
          const double dx = fe_values.JxW(q);
          for (const unsigned int i : fe_values.dof_indices())
            {
              const double phi_i = fe_values.shape_value(i, q);
              for (const unsigned int j : fe_values.dof_indices())
                copy.matrices[0](i, j) +=
                  fe_values.shape_grad(i, q) * fe_values.shape_grad(j, q) * dx;
              if (cell_mass)
                for (const unsigned int j : fe_values.dof_indices())
                  copy.matrices[1](i, j) +=
                    phi_i * fe_values.shape_value(j, q) * dx;
              copy.vectors[0](i) += l1 * phi_i * dx;
              copy.vectors[1](i) += l2 * phi_i * dx;
              copy.vectors[2](i) += phi_i * dx;
            }
        }
    };

    const auto copier = [&](const CellSystem &copy) {
      copy_system(copy);
      const auto &dofs = copy.local_dof_indices[0];
      hanging_node_constraints.distribute_local_to_global(copy.vectors[2],
                                                          dofs,
                                                          lumped_mass);
      if (with_mass_matrix)
        hanging_node_constraints.distribute_local_to_global(copy.matrices[1],
                                                            dofs,
                                                            mass_matrix);
    };

    MeshWorker::mesh_loop(owned_cells,
                          cell_worker,
                          copier,
                          scratch,
                          sample,
                          MeshWorker::assemble_own_cells);
    lumped_mass.compress(VectorOperation::add);
    if (with_mass_matrix)
      mass_matrix.compress(VectorOperation::add);
    return lumped_mass;
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::set_coupling(ContactSystem &contact_system,
                                            const Vector  &lumped_mass) const
  {
    std::vector<types::global_dof_index> constrained_nodes;
    for (const types::global_dof_index i : owned_nodes)
      if (u1_constraints.is_constrained(i))
        constrained_nodes.push_back(i);
    contact_system.set_coupling(
      [&](const types::global_dof_index i) {
        return fe.degree == 1 ? lumped_mass(i) : 1.;
      },
      constrained_nodes);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::potentials(
    const Vector &X,
    const double  mu1,
    const double  mu2,
    Vector (&owned)[4],
    const std::array<Vector *, 4> &ghosted) const
  {
    for (Vector &v : owned)
      v.reinit(owned_nodes, comm);
    auto &[u1, u2, s1, s2] = owned;
    NodalFields::extract(X, NodalFields::u1, u1);
    NodalFields::extract(X, NodalFields::u2, u2);
    hanging_node_constraints.distribute(u1);
    hanging_node_constraints.distribute(u2);
    average_at_violated_nodes(mu1, mu2, u1, u2, s1, s2);
    hanging_node_constraints.distribute(s1);
    hanging_node_constraints.distribute(s2);
    for (unsigned int k = 0; k < 4; ++k)
      ghosted_nodes.copy(owned[k], *ghosted[k]);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::residual_functions(
    const ContactSystem      &contact_system,
    const MultiplierFunction &multiplier_function,
    const Vector             &X,
    Vector                   &r1,
    Vector                   &r2) const
  {
    Vector R(owned_system, comm);
    contact_system.matrix.vmult(R, X);
    R.sadd(-1., 1., contact_system.rhs);
    Vector  moments(owned_nodes, comm), function(owned_nodes, comm);
    Vector *r[2] = {&r1, &r2};
    for (const unsigned int field : {NodalFields::u1, NodalFields::u2})
      {
        NodalFields::extract(R, field, moments);
        for (const types::global_dof_index i : owned_nodes)
          if (u1_constraints.is_constrained(i))
            moments(i) = 0;
        moments.compress(VectorOperation::insert);
        multiplier_function.from_moments(moments, function);
        ghosted_nodes.copy(function, *r[field]);
      }
  }


  template <int dim>
  types::global_dof_index
  MembraneDiscretisation<dim>::make_solution_fields(
    const ContactSystem      &contact_system,
    const MultiplierFunction &multiplier_function,
    const Vector             &X)
  {
    Vector u1(owned_nodes, comm), u2(owned_nodes, comm),
      field(owned_nodes, comm), lambda(owned_nodes, comm);
    NodalFields::extract(X, NodalFields::u1, u1);
    NodalFields::extract(X, NodalFields::u2, u2);
    u1_h = u1;
    u2_h = u2;
    u1 -= u2;
    gap_h = u1;

    // lambda_h from its moments <lambda_h, psi_i>_h = D_i X3_i.
    NodalFields::extract(X, NodalFields::multiplier, field);
    field.scale(contact_system.coupling());
    multiplier_function.from_moments(field, lambda);
    lambda_h = lambda;

    const types::global_dof_index n_contact_nodes =
      contact_system.contact_rows().contact_set(X, field);
    contact_set = field;
    return n_contact_nodes;
  }


  template <int dim>
  MultiplierFunction
  MembraneDiscretisation<dim>::make_multiplier_function(
    const ContactSystem &contact_system) const
  {
    return MultiplierFunction(fe.degree,
                              contact_system.contact_rows(),
                              contact_system.coupling(),
                              mass_matrix,
                              hanging_node_constraints,
                              ghosted_nodes);
  }


  template <int dim>
  FieldOutput<dim>
  MembraneDiscretisation<dim>::solution_output() const
  {
    return FieldOutput<dim>(*mapping,
                            geometry,
                            dof_handler,
                            {u1_h, u2_h, gap_h, lambda_h, &contact_set});
  }


  template <int dim>
  double
  MembraneDiscretisation<dim>::global_error(
    const Vector               &uh,
    const Function<dim>        &exact,
    const VectorTools::NormType norm) const
  {
    dealii::Vector<double> per_cell(triangulation.n_active_cells());
    VectorTools::integrate_difference(*mapping,
                                      dof_handler,
                                      uh,
                                      exact,
                                      per_cell,
                                      QGauss<dim>(fe.degree + 3),
                                      norm);
    return VectorTools::compute_global_error(triangulation, per_cell, norm);
  }


  template <int dim>
  std::function<double(const unsigned int, const unsigned int)>
  MembraneDiscretisation<dim>::lumped_sources(const Vector &lambda,
                                              const Vector &r1,
                                              const Vector &r2) const
  {
    return [this, &lambda, r = std::array<const Vector *, 2>{{&r1, &r2}}](
             const unsigned int vertex, const unsigned int alpha) {
      const types::global_dof_index node = vertex_dofs[vertex];
      const double                  sign = alpha == 0 ? -1. : 1.; // (-1)^alpha
      return -sign * lambda(node) - (*r[alpha])(node);
    };
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::equilibrate_fluxes(
    const FluxReconstruction<dim> &fluxes,
    const double                   mu1,
    const double                   mu2,
    const Function<dim> *const (&f)[2],
    const Vector *const (&dt_u)[2],
    MembraneIterate &it) const
  {
    const bool                          lumped = fe.degree == 1;
    const std::array<const Vector *, 2> potential{{&it.u1, &it.u2}};
    const std::array<const Vector *, 2> residual{{&it.r1, &it.r2}};
    const std::array<double, 2>         mu{{mu1, mu2}};

    typename FluxReconstruction<dim>::Sources sources;
    sources.n_fields = 2;
    // Per thread: the potential's FEValues at the fluxes' quadrature points
    // and the values of lambda_h, r_alpha,h and d_t u_alpha,h there.
    sources.make_cell_values = [&]() {
      const Quadrature<dim> &points = fluxes.get_quadrature();
      auto                   fe_values =
        std::make_shared<FEValues<dim>>(*mapping,
                                        fe,
                                        points,
                                        update_values | update_gradients |
                                          update_quadrature_points);
      std::vector<double> work(points.size());
      return [&,
              fe_values,
              multiplier      = work,
              residual_values = work,
              time_derivative =
                work](const auto &cell, auto &flux, auto &source) mutable {
        fe_values->reinit(typename DoFHandler<dim>::active_cell_iterator(
          &triangulation, cell->level(), cell->index(), &dof_handler));
        if (!lumped)
          fe_values->get_function_values(it.lambda, multiplier);
        for (unsigned int alpha = 0; alpha < 2; ++alpha)
          {
            fe_values->get_function_gradients(*potential[alpha], flux[alpha]);
            for (Tensor<1, dim> &F : flux[alpha])
              F *= mu[alpha];
            std::vector<double> &s = source[alpha];
            f[alpha]->value_list(fe_values->get_quadrature_points(), s);
            if (dt_u[alpha])
              fe_values->get_function_values(*dt_u[alpha], time_derivative);
            if (!lumped)
              fe_values->get_function_values(*residual[alpha], residual_values);
            const double sign = alpha == 0 ? -1. : 1.; // (-1)^alpha
            for (unsigned int q = 0; q < s.size(); ++q)
              {
                if (dt_u[alpha])
                  s[q] -= time_derivative[q];
                if (!lumped)
                  s[q] -= sign * multiplier[q] + residual_values[q];
              }
          }
      };
    };
    if (lumped)
      sources.vertex_source = lumped_sources(it.lambda, it.r1, it.r2);
    fluxes.reconstruct(sources, {&it.sigma1, &it.sigma2});
  }


  template <int dim>
  ContactEstimatorInput<dim>
  MembraneDiscretisation<dim>::discretisation_input(
    const FluxReconstruction<dim> &fluxes) const
  {
    ContactEstimatorInput<dim> in;
    in.mapping    = mapping.get();
    in.potential  = &dof_handler;
    in.flux       = &fluxes.get_dof_handler();
    in.quadrature = &fluxes.get_quadrature();
    in.flux_signs = &fluxes.get_piola_signs();
    return in;
  }


  template class MembraneDiscretisation<2>;
} // namespace VI
