// The conforming discretisation of two membranes shared by step-membranes
// and step-parabolic: nodes, constraints, matrices and the cell assembly;
// the loads, the multiplier and the fluxes its estimates take.

#include <deal.II/base/parallel.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/filtered_iterator.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/meshworker/mesh_loop.h>
#include <deal.II/meshworker/scratch_data.h>
#include <deal.II/numerics/vector_tools.h>

#include <vi/cell_function_values.h>
#include <vi/estimators.h>
#include <vi/field_output.h>
#include <vi/flux_reconstruction.h>
#include <vi/membrane_discretisation.h>
#include <vi/nodal_fields.h>
#include <vi/parameters.h>
#include <vi/reduced_tension.h>

#include <map>

namespace VI
{
  using namespace dealii;


  template <int dim>
  MembraneDiscretisation<dim>::MembraneDiscretisation(
    const Domain      &domain,
    const unsigned int degree,
    const unsigned int flux_degree,
    const MPI_Comm     comm)
      : comm(comm)
      , domain(domain)
      , triangulation(comm)
      , geometry_mapping(domain.make_mapping<dim>(degree))
      , mapping(std::make_unique<MappingQCache<dim>>(
          dynamic_cast<const MappingQ<dim> &>(*geometry_mapping).get_degree()))
      , fe(degree)
      , dof_handler(triangulation)
      , quadrature(
          FluxReconstruction<dim>::quadrature_points(degree, flux_degree))
  {
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::make_grid(const unsigned int refinements)
  {
    domain.make_coarse_mesh(triangulation);
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
                                                const Function<dim> &g2,
                                                const Function<dim> *obstacle,
                                                const bool smooth_obstacle)
  {
    this->obstacle            = obstacle;
    this->smooth_obstacle     = smooth_obstacle;
    const auto make_dirichlet = [&](const Function<dim>       &g,
                                    AffineConstraints<double> &constraints) {
      constraints.clear();
      constraints.reinit(relevant_nodes);
      constraints.merge(hanging_node_constraints);
      std::map<types::boundary_id, const Function<dim> *> boundary_data;
      for (const types::boundary_id id : triangulation.get_boundary_ids())
        if (domain.is_clamped(id))
          boundary_data[id] = &g;
      VectorTools::interpolate_boundary_values(*mapping,
                                               dof_handler,
                                               boundary_data,
                                               constraints);
      constraints.close();
    };
    make_dirichlet(g1, u1_constraints);
    if (obstacle)
      {
        // u2 = I_h obstacle: every node but the hanging ones, which follow.
        Vector owned(owned_nodes, comm), values;
        VectorTools::interpolate(*mapping, dof_handler, *obstacle, owned);
        ghosted_nodes.copy(owned, values);
        u2_constraints.clear();
        u2_constraints.reinit(relevant_nodes);
        u2_constraints.merge(hanging_node_constraints);
        for (const types::global_dof_index i : relevant_nodes)
          if (!u2_constraints.is_constrained(i))
            {
              u2_constraints.add_line(i);
              u2_constraints.set_inhomogeneity(i, values(i));
            }
        u2_constraints.close();
      }
    else
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
                                            const Vector  &lumped_mass,
                                            const double   mu1,
                                            const double   mu2) const
  {
    std::vector<types::global_dof_index> constrained_nodes;
    for (const types::global_dof_index i : owned_nodes)
      if (u1_constraints.is_constrained(i))
        constrained_nodes.push_back(i);
    contact_system.set_coupling(
      [&](const types::global_dof_index i) {
        return fe.degree == 1 ? lumped_mass(i) : 1.;
      },
      constrained_nodes,
      /*fixed_second_field=*/obstacle != nullptr);

    // The multiplier of p >= 2 is a force: (psi_i, 1) per unit density.
    const double mu_gap = obstacle != nullptr ? mu1 : reduced_tension(mu1, mu2);
    contact_system.set_gap_stiffness(
      ContactRows::gap_stiffness(mu_gap,
                                 domain.friedrichs_constant(),
                                 fe.degree == 1 ? 1. :
                                                  lumped_mass.linfty_norm()));
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
    // (a rigid obstacle does not give way: the weights 0 and 1 of the
    // limit mu2 -> infinity put both at the obstacle)
    if (obstacle)
      average_at_violated_nodes(0., 1., u1, u2, s1, s2);
    else
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
                            domain.has_curved_cells(),
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
  void
  MembraneDiscretisation<dim>::tabulate_loads(const Function<dim> &f1,
                                              const Function<dim> &f2)
  {
    const unsigned int n_q = quadrature.size();
    for (unsigned int a = 0; a < 2; ++a)
      load_values[a].assign(triangulation.n_active_cells() * n_q, 0.);
    std::vector<CellIterator> cells;
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        cells.push_back(cell);
    // (a parsed expression costs more than the rest of a cell's work in an
    // estimate: the threads share the cells)
    parallel::apply_to_subranges(
      std::size_t(0),
      cells.size(),
      [&](const std::size_t begin, const std::size_t end) {
        const Function<dim> *f[2] = {&f1, &f2};
        FEValues<dim> where(*mapping, fe, quadrature, update_quadrature_points);
        std::vector<double> values(n_q);
        for (std::size_t c = begin; c < end; ++c)
          {
            where.reinit(cells[c]);
            for (unsigned int a = 0; a < 2; ++a)
              {
                f[a]->value_list(where.get_quadrature_points(), values);
                std::copy(values.begin(),
                          values.end(),
                          load_values[a].begin() +
                            cells[c]->active_cell_index() * n_q);
              }
          }
      },
      /*grainsize=*/1024);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::loads_of_step(
    const Vector *const (&dt_u)[2],
    std::vector<double> (&loads)[2]) const
  {
    const unsigned int  n_q = quadrature.size();
    FEValues<dim>       values(*mapping, fe, quadrature, update_values);
    std::vector<double> time_derivative(n_q);
    for (unsigned int a = 0; a < 2; ++a)
      loads[a] = load_values[a];
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          const std::size_t first = cell->active_cell_index() * n_q;
          for (unsigned int a = 0; a < 2; ++a)
            {
              values.get_function_values(*dt_u[a], time_derivative);
              for (unsigned int q = 0; q < n_q; ++q)
                loads[a][first + q] -= time_derivative[q];
            }
        }
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::setup_estimate_multiplier(
    const EstimatorParameters                         &parameters,
    const double                                       mu1,
    const double                                       mu2,
    const Quadrature<dim>                             &points,
    const typename TransmittedLoad<dim>::BoundaryCells boundary_cells)
  {
    // (the transmitted load distributes the moments the cellwise way, on
    // the cells of J, also for p = 1)
    // (not over an obstacle: it transmits the load of no second membrane)
    const bool transmitted =
      !obstacle &&
      parameters.uses_transmitted_load(
        mu1,
        mu2,
        fe.degree,
        boundary_cells == TransmittedLoad<dim>::BoundaryCells::all);
    cell_multiplier.reset();
    if ((fe.degree > 1 && parameters.multiplier ==
                            EstimatorParameters::Multiplier::contact_cells) ||
        transmitted)
      {
        cell_multiplier = std::make_unique<CellMultiplier<dim>>();
        cell_multiplier->reinit(*mapping, dof_handler, u1_constraints, points);
      }
    transmitted_load.reset();
    if (transmitted)
      {
        transmitted_load = std::make_unique<TransmittedLoad<dim>>();
        transmitted_load->reinit(*mapping,
                                 dof_handler,
                                 u1_constraints,
                                 points,
                                 domain.friedrichs_constant(),
                                 boundary_cells);
      }
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::contact_nodes(
    const ContactSystem &contact_system,
    const Vector        &X,
    Vector              &indicator) const
  {
    Vector owned(owned_nodes, comm);
    contact_system.contact_rows().contact_set(X, owned);
    indicator.reinit(owned_nodes, relevant_nodes, comm);
    indicator = owned;
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::describe_multiplier(
    const ContactSystem      &contact_system,
    const MultiplierFunction &multiplier_function,
    const Vector             &X,
    const Vector (&owned)[4],
    const Vector &contact,
    const std::vector<double> (&loads)[2],
    const double     mu1,
    const double     mu2,
    MembraneIterate &it) const
  {
    // lambda_h: <lambda_h, psi_i>_h = D_i X3_i = m_i.
    Vector moments(owned_nodes, comm);
    NodalFields::extract(X, NodalFields::multiplier, moments);
    moments.scale(contact_system.coupling());

    // The transmitted load g on the cells J takes its moments G from
    // lambda_h.
    typename TransmittedLoad<dim>::Split split;
    const Vector                        *offset = nullptr;
    Vector                               load_nodes;
    it.transmitted_load.clear();
    if (transmitted_load)
      {
        transmitted_load->split(
          mu1, mu2, loads[0], loads[1], contact, it.s1, it.s2, split);
        offset              = &split.node_moments;
        it.transmitted_load = std::move(split.values);
        // (the moments shared on the cells of J)
        ghosted_nodes.copy(split.load_nodes, load_nodes);
      }

    // (Newton's part of the contact term)
    it.complementarity = nodal_complementarity(moments, owned[0], owned[1]);
    if (!cell_multiplier)
      {
        multiplier_function.with_nonnegative_part(moments,
                                                  it.lambda,
                                                  it.lambda_nonnegative,
                                                  offset);
        return;
      }
    Vector m, shifted(moments);
    if (offset)
      shifted -= *offset;
    ghosted_nodes.copy(shifted, m);
    // (on the cells of J with the transmitted load)
    const Vector &share_on = transmitted_load ? load_nodes : contact;
    cell_multiplier->distribute(m, share_on, it.lambda_cells);
    for (double &value : moments)
      value = std::max(value, 0.);
    if (offset)
      moments -= *offset;
    ghosted_nodes.copy(moments, m);
    cell_multiplier->distribute(m, share_on, it.lambda_nonnegative_cells);
  }


  template <int dim>
  void
  MembraneDiscretisation<dim>::equilibrate_fluxes(
    const FluxReconstruction<dim> &fluxes,
    const double                   mu1,
    const double                   mu2,
    const Vector *const (&dt_u)[2],
    MembraneIterate &it) const
  {
    // p = 1 lumps the residual, and lambda_h unless it is cellwise.
    const bool          lumped               = fe.degree == 1;
    const bool          multiplier_at_points = cell_multiplier || !lumped;
    const Vector *const u[2]                 = {&it.u1, &it.u2};
    const Vector *const r[2]                 = {&it.r1, &it.r2};
    const double        mu[2]                = {mu1, mu2};
    const double        sign[2]              = {-1., 1.}; // (-1)^alpha
    const unsigned int  n_q                  = quadrature.size();
    Assert(fluxes.get_quadrature().size() == n_q, ExcInternalError());

    typename FluxReconstruction<dim>::Sources sources;
    sources.n_fields = 2;
    // Per thread: the potential's FEValues at the fluxes' quadrature points
    // and the values of lambda~ (with g 1_J), r_alpha,h and d_t u_alpha,h
    // there.
    sources.make_cell_values = [&]() {
      return
        [&,
         values_of =
           std::make_shared<FEValues<dim>>(*mapping,
                                           fe,
                                           fluxes.get_quadrature(),
                                           update_values | update_gradients),
         lambda       = std::vector<double>(n_q),
         work         = std::vector<double>(n_q),
         coefficients = std::vector<double>()](const auto &cell,
                                               auto       &flux,
                                               auto       &source) mutable {
          const CellIterator dof_cell(&triangulation,
                                      cell->level(),
                                      cell->index(),
                                      &dof_handler);
          FEValues<dim>     &values = *values_of;
          values.reinit(dof_cell);
          const unsigned int index = cell->active_cell_index();
          std::fill(lambda.begin(), lambda.end(), 0.);
          if (cell_multiplier)
            cell_multiplier->values(it.lambda_cells, index, lambda);
          else if (!lumped)
            cell_function_values(
              values, dof_cell, it.lambda, coefficients, &lambda);
          if (transmitted_load)
            for (unsigned int q = 0; q < n_q; ++q)
              lambda[q] += it.transmitted_load[index * n_q + q];
          for (unsigned int a = 0; a < 2; ++a)
            {
              cell_function_values(
                values, dof_cell, *u[a], coefficients, nullptr, &flux[a]);
              for (auto &F : flux[a])
                F *= mu[a];
              std::copy_n(load_values[a].begin() + index * n_q,
                          n_q,
                          source[a].begin());
              for (unsigned int q = 0; q < n_q; ++q)
                source[a][q] -= sign[a] * lambda[q];
              if (!lumped)
                {
                  cell_function_values(
                    values, dof_cell, *r[a], coefficients, &work);
                  for (unsigned int q = 0; q < n_q; ++q)
                    source[a][q] -= work[q];
                }
              if (dt_u[a])
                {
                  cell_function_values(
                    values, dof_cell, *dt_u[a], coefficients, &work);
                  for (unsigned int q = 0; q < n_q; ++q)
                    source[a][q] -= work[q];
                }
            }
        };
    };
    if (lumped)
      sources.vertex_source = [&](const unsigned int vertex,
                                  const unsigned int alpha) {
        const types::global_dof_index node = vertex_dofs[vertex];
        return -(*r[alpha])(node) -
               (multiplier_at_points ? 0. : sign[alpha] * it.lambda(node));
      };
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
