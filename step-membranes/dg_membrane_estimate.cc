// step-membranes, interior penalty dG: the multiplier from its moments,
// the potential and flux reconstructions of an iterate and its guaranteed
// estimate.

#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>

#include <vi/estimators.h>
#include <vi/nodal_fields.h>
#include <vi/reduced_tension.h>
#include <vi/transmitted_load.h>

#include "dg_membrane_problem.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace StepMembranes
{

  // v = M_K^{-1} moments on every owned cell: the broken function whose
  // L2 moments against the nodal basis are the given ones. The mass matrix
  // is integrated with the quadrature of the flux reconstruction, so that
  // (v, psi)_K computed there reproduces the moments exactly.
  template <int dim>
  void
  DGMembraneProblem<dim>::function_from_moments(const Vector &moments,
                                                Vector       &v) const
  {
    const unsigned int     n = fe.n_dofs_per_cell();
    FullMatrix<double>     mass(n, n);
    dealii::Vector<double> local(n), coefficients(n);
    Vector                 owned(owned_nodes, comm);
    for_each_owned_cell(quadrature, [&](const auto &values, const auto &dofs) {
      mass = 0;
      for (const unsigned int q : values.quadrature_point_indices())
        for (unsigned int i = 0; i < n; ++i)
          for (unsigned int j = 0; j < n; ++j)
            mass(i, j) += values.shape_value(i, q) * values.shape_value(j, q) *
                          values.JxW(q);
      mass.gauss_jordan();
      for (unsigned int i = 0; i < n; ++i)
        local(i) = moments(dofs[i]);
      mass.vmult(coefficients, local);
      for (unsigned int i = 0; i < n; ++i)
        owned(dofs[i]) = coefficients(i);
    });
    owned.compress(VectorOperation::insert);
    ghosted_nodes.copy(owned, v);
  }


  template <int dim>
  void
  DGMembraneProblem<dim>::for_each_owned_cell(
    const Quadrature<dim> &quadrature,
    const std::function<void(const FEValues<dim> &,
                             const std::vector<types::global_dof_index> &)>
      &local) const
  {
    FEValues<dim>                        values(*mapping,
                         fe,
                         quadrature,
                         update_values | update_JxW_values);
    std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          cell->get_dof_indices(dofs);
          local(values, dofs);
        }
  }


  template <int dim>
  bool
  DGMembraneProblem<dim>::mass_lumped() const
  {
    return fe.degree == 1;
  }


  // lambda_h from its coefficients X3 in the dual basis: the nodal values
  // for the lumped bracket of p = 1, M_K^{-1} X3 for the L2 bracket.
  template <int dim>
  void
  DGMembraneProblem<dim>::multiplier_function(const Vector &X3,
                                              Vector       &lambda) const
  {
    if (mass_lumped())
      ghosted_nodes.copy(X3, lambda);
    else
      function_from_moments(X3, lambda);
  }


  // On every owned cell: the nodal values v(x_I) of `function` or, without
  // it, lambda_N(x_I) = m_I / (psi_I, 1)_K; either has the cell mean sum_I
  // m_I / |K|. Where v + g < 0 at a point of the estimator's quadrature (g
  // the transmitted load there, if given) and the mean + g is positive at
  // the points, lambda = mean + theta (v - mean) with the largest theta in
  // [0, 1] that keeps lambda + g >= 0 at those points (the limiter of
  // Zhang and Shu); otherwise the mean.
  template <int dim>
  void
  DGMembraneProblem<dim>::limited_function(const Vector              &moments,
                                           const Vector              *function,
                                           const std::vector<double> *load,
                                           Vector &lambda) const
  {
    const unsigned int  n   = fe.n_dofs_per_cell();
    const unsigned int  n_q = flux_reconstruction->get_quadrature().size();
    std::vector<double> nodal(n);
    Vector              owned(owned_nodes, comm);
    for_each_owned_cell(
      flux_reconstruction->get_quadrature(),
      [&](const auto &values, const auto &dofs) {
        const double *g =
          load ? load->data() + values.get_cell()->active_cell_index() * n_q :
                 nullptr;
        double sum = 0, volume = 0;
        for (unsigned int i = 0; i < n; ++i)
          {
            nodal[i] = function ? (*function)(dofs[i]) :
                                  moments(dofs[i]) / lumped_mass(dofs[i]);
            sum += moments(dofs[i]);
          }
        for (const unsigned int q : values.quadrature_point_indices())
          volume += values.JxW(q);
        const double mean  = sum / volume;
        double       theta = 1.;
        const auto   limit = [&](const double value, const double g_x) {
          if (value + g_x >= 0)
            return;
          theta = mean + g_x <= 0 ?
                      0. :
                      std::min(theta, (mean + g_x) / (mean - value));
        };
        if (!g)
          for (unsigned int i = 0; i < n; ++i)
            limit(nodal[i], 0.);
        for (const unsigned int q : values.quadrature_point_indices())
          {
            double value = 0;
            for (unsigned int i = 0; i < n; ++i)
              value += nodal[i] * values.shape_value(i, q);
            limit(value, g ? g[q] : 0.);
          }
        for (unsigned int i = 0; i < n; ++i)
          owned(dofs[i]) = mean + theta * (nodal[i] - mean);
      });
    owned.compress(VectorOperation::insert);
    ghosted_nodes.copy(owned, lambda);
  }


  // On every owned cell, the Q1 function v with (v, psi_v)_K = sum_I m_I
  // psi_v(x_I) for the vertex functions psi_v of K (the L2 projection onto
  // Q1(K) of M_K^{-1} m), written in the broken space (Q1 in Q_p). Summed
  // over the cells, (v, psi_a) = <lambda_h, psi_a>_h for every vertex hat
  // psi_a, which is all the patch problems of the flux reconstruction ask
  // for: they equilibrate v itself. v[j] for moments[j], with one inverse
  // Q1 mass matrix per cell for all of them.
  template <int dim>
  void
  DGMembraneProblem<dim>::vertex_moment_functions(
    const std::vector<const Vector *> &moments,
    const std::vector<Vector *>       &v) const
  {
    AssertDimension(moments.size(), v.size());
    const unsigned int n = fe.n_dofs_per_cell();
    const FE_Q<dim>    q1(1);
    const unsigned int n_v = q1.n_dofs_per_cell();
    FullMatrix<double> psi(n_v, n); // psi_v(x_I)
    for (unsigned int k = 0; k < n_v; ++k)
      for (unsigned int i = 0; i < n; ++i)
        psi(k, i) = q1.shape_value(k, fe.get_unit_support_points()[i]);
    FEValues<dim>          q1_values(*mapping,
                            q1,
                            quadrature,
                            update_values | update_JxW_values);
    FullMatrix<double>     mass(n_v, n_v);
    dealii::Vector<double> vertex_moments(n_v), coefficients(n_v);
    std::vector<Vector>    owned(moments.size(), Vector(owned_nodes, comm));
    for_each_owned_cell(quadrature, [&](const auto &values, const auto &dofs) {
      q1_values.reinit(
        typename Triangulation<dim>::cell_iterator(values.get_cell()));
      mass = 0;
      for (const unsigned int q : q1_values.quadrature_point_indices())
        for (unsigned int k = 0; k < n_v; ++k)
          for (unsigned int l = 0; l < n_v; ++l)
            mass(k, l) += q1_values.shape_value(k, q) *
                          q1_values.shape_value(l, q) * q1_values.JxW(q);
      mass.gauss_jordan();
      for (unsigned int j = 0; j < moments.size(); ++j)
        {
          vertex_moments = 0;
          for (unsigned int k = 0; k < n_v; ++k)
            for (unsigned int i = 0; i < n; ++i)
              vertex_moments(k) += psi(k, i) * (*moments[j])(dofs[i]);
          mass.vmult(coefficients, vertex_moments);
          for (unsigned int i = 0; i < n; ++i)
            {
              double value = 0;
              for (unsigned int k = 0; k < n_v; ++k)
                value += coefficients(k) * psi(k, i);
              owned[j](dofs[i]) = value;
            }
        }
    });
    for (unsigned int j = 0; j < moments.size(); ++j)
      {
        owned[j].compress(VectorOperation::insert);
        ghosted_nodes.copy(owned[j], *v[j]);
      }
  }


  template <int dim>
  void
  DGMembraneProblem<dim>::moments_of_function(const Vector &v,
                                              Vector       &moments) const
  {
    std::vector<double> v_values(quadrature.size());
    moments = 0;
    for_each_owned_cell(quadrature, [&](const auto &values, const auto &dofs) {
      values.get_function_values(v, v_values);
      for (unsigned int i = 0; i < dofs.size(); ++i)
        {
          double moment = 0;
          for (const unsigned int q : values.quadrature_point_indices())
            moment += v_values[q] * values.shape_value(i, q) * values.JxW(q);
          moments(dofs[i]) = moment;
        }
    });
    moments.compress(VectorOperation::insert);
  }


  // The conforming potentials of the broken pair u (ghosted): the Oswald
  // interpolates with the nodal values of g on the boundary (conforming at
  // hanging nodes), the same averaged at the nodes where s1 < s2, and the
  // liftings L of the jumps of u.
  template <int dim>
  void
  DGMembraneProblem<dim>::reconstruct_potentials(const Vector (&u)[2],
                                                 Vector (&oswald)[2],
                                                 Vector (&averaged)[2],
                                                 Vector (&L)[2]) const
  {
    const Function<dim> *g[2] = {data.g1.get(), data.g2.get()};
    for (unsigned int a = 0; a < 2; ++a)
      {
        oswald[a].reinit(owned_continuous, comm);
        averaged[a].reinit(owned_continuous, comm);
        VI::oswald_interpolation(*mapping,
                                 dof_handler,
                                 u[a],
                                 continuous_dof_handler,
                                 g[a],
                                 oswald[a],
                                 &domain,
                                 &continuous_hanging_nodes);
        lifting->compute(dof_handler, u[a], *g[a], L[a], &domain);
      }
    VI::average_at_violated_nodes(
      data.mu1, data.mu2, oswald[0], oswald[1], averaged[0], averaged[1]);
    for (Vector &v : averaged)
      continuous_hanging_nodes.distribute(v);
  }


  // The estimate of the iterate X (doc/step-membranes.md, dG section):
  // - lambda_h and r_h: the broken functions with moments X3 and F - E X;
  // - s_h: Oswald interpolation into FE_Q(p) with the nodal values of g on
  //   the boundary, averaged where s1 < s2;
  // - sigma_alpha: the vertex-patch reconstruction of the flux
  //   -mu_alpha (grad_h u_alpha,h + epsilon L(u_alpha,h)), L the lifting of
  //   the jumps, in equilibrium with f_alpha -/+ lambda_h - r_alpha,h.
  template <int dim>
  VI::DGContactEstimate
  DGMembraneProblem<dim>::estimate(const Vector &X) const
  {
    TimerOutput::Scope t(timer, "estimators");
    Vector             field(owned_nodes, comm), nodal[2];
    Vector             u[2], r[2], lambda, lambda_nonnegative;
    for (const unsigned int a : {VI::NodalFields::u1, VI::NodalFields::u2})
      {
        nodal[a].reinit(owned_nodes, comm);
        VI::NodalFields::extract(X, a, nodal[a]);
        ghosted_nodes.copy(nodal[a], u[a]);
      }
    Vector R(owned_system, comm);
    contact_system.matrix.vmult(R, X);
    R.sadd(-1., 1., contact_system.rhs);
    for (const unsigned int a : {VI::NodalFields::u1, VI::NodalFields::u2})
      {
        VI::NodalFields::extract(R, a, field);
        function_from_moments(field, r[a]);
      }

    Vector s_owned[2], s_averaged[2], s[2], L[2];
    reconstruct_potentials(u, s_owned, s_averaged, L);
    Vector moments(owned_nodes, comm);
    VI::NodalFields::extract(X, multiplier, moments);
    moments.scale(contact_system.coupling());
    // (the contact set of X decides the cells of the transmitted load)
    const bool transmits =
      parameters.estimators.transmits_load(data.mu1, data.mu2);
    Vector contact;
    if (transmits)
      {
        Vector owned(owned_nodes, comm);
        contact_system.contact_rows().contact_set(X, owned);
        ghosted_nodes.copy(owned, contact);
        join_at_contact_cells(contact, moments, s_averaged);
        for (Vector &v : s_averaged)
          continuous_hanging_nodes.distribute(v);
      }
    Vector oswald[2]; // (before the averaging)
    for (unsigned int a = 0; a < 2; ++a)
      {
        s[a].reinit(owned_continuous, relevant_continuous, comm);
        s[a] = s_averaged[a];
        oswald[a].reinit(owned_continuous, relevant_continuous, comm);
        oswald[a] = s_owned[a];
      }

    Vector                    lambda_source;
    const std::vector<double> transmitted =
      estimate_multiplier(moments,
                          transmits ? &contact : nullptr,
                          s,
                          lambda,
                          lambda_nonnegative,
                          lambda_source);

    const double         epsilon = penalty.symmetry();
    const double         mu[2]   = {data.mu1, data.mu2};
    const double         sign[2] = {-1., 1.}; // (-1)^alpha
    const Function<dim> *f[2]    = {data.f1.get(), data.f2.get()};

    typename VI::FluxReconstruction<dim>::Sources sources;
    sources.n_fields         = 2;
    sources.make_cell_values = [&]() {
      // per thread: FEValues of u_h and of the lifting, value arrays
      const unsigned int n_q = quadrature.size();
      return [&,
              values_of = std::make_shared<FEValues<dim>>(
                *mapping,
                fe,
                flux_reconstruction->get_quadrature(),
                update_values | update_gradients | update_quadrature_points),
              lifting_values_of =
                std::shared_ptr<FEValues<dim>>(lifting->make_cell_values()),
              lambda_values = std::vector<double>(n_q),
              no_load       = std::vector<double>(n_q, 0.),
              n_q,
              r_values       = std::vector<double>(n_q),
              lifting_values = std::vector<Tensor<1, dim>>(
                n_q)](const auto &cell, auto &flux, auto &source) mutable {
        const typename DoFHandler<dim>::active_cell_iterator dof_cell(
          &triangulation, cell->level(), cell->index(), &dof_handler);
        FEValues<dim> &values = *values_of;
        values.reinit(dof_cell);
        values.get_function_values(lambda_source, lambda_values);
        const double *g =
          transmitted.empty() ?
            no_load.data() :
            transmitted.data() + cell->active_cell_index() * n_q;
        for (unsigned int a = 0; a < 2; ++a)
          {
            values.get_function_gradients(u[a], flux[a]);
            lifting->values(cell, L[a], *lifting_values_of, lifting_values);
            for (unsigned int q = 0; q < flux[a].size(); ++q)
              flux[a][q] = mu[a] * (flux[a][q] + epsilon * lifting_values[q]);
            f[a]->value_list(values.get_quadrature_points(), source[a]);
            values.get_function_values(r[a], r_values);
            for (unsigned int q = 0; q < source[a].size(); ++q)
              source[a][q] -= sign[a] * (lambda_values[q] + g[q]) + r_values[q];
          }
      };
    };
    Vector sigma[2];
    flux_reconstruction->reconstruct(sources, {&sigma[0], &sigma[1]});

    VI::DGContactEstimatorInput<dim> in;
    in.mapping         = mapping.get();
    in.broken          = &dof_handler;
    in.continuous      = &continuous_dof_handler;
    in.flux            = &flux_reconstruction->get_dof_handler();
    in.quadrature      = &flux_reconstruction->get_quadrature();
    in.face_quadrature = &face_quadrature;
    in.penalty         = &penalty;
    in.set_problem(data, domain);
    in.mass_lumped     = true; // the nodal multiplier, see above
    in.complementarity = VI::nodal_complementarity(moments, nodal[0], nodal[1]);
    in.u1              = &u[0];
    in.u2              = &u[1];
    in.lambda          = &lambda;
    in.lambda_nonnegative = &lambda_nonnegative;
    in.r1                 = &r[0];
    in.r2                 = &r[1];
    in.s1                 = &s[0];
    in.s2                 = &s[1];
    in.oswald1 = transmits ? nullptr : &oswald[0]; // (joined s: no split)
    in.oswald2 = transmits ? nullptr : &oswald[1];
    in.sigma1  = &sigma[0];
    in.sigma2  = &sigma[1];
    if (!transmitted.empty())
      in.transmitted_load = &transmitted;
    return VI::estimate_dg_contact_error(in);
  }


  // The multiplier of the estimate: on every cell, the nodal function
  // lambda_N(x_I) = <lambda_h, psi_I>_h / (psi_I, 1)_K (the discrete
  // lambda_h itself for p = 1), scaled towards its cell mean where it is
  // negative at a quadrature point (positivity-preserving limiter). It has
  // the cell means of the L2 representative lambda* = M_K^{-1}
  // (<lambda_h, psi_I>_h)_I, which the fluxes equilibrate (compatibility),
  // and that is all the theorem needs (doc/step-membranes.md).
  // With tensions far apart, the transmitted load g 1_J on the cells at
  // the contact set takes its moments G off the multiplier (see the
  // conforming method and VI::TransmittedLoad: the broken nodes are the
  // cells' own, so J and G are cellwise), and the rest is the cellwise Q1
  // function of its vertex moments, which the fluxes equilibrate exactly.
  // Returns g 1_J (empty without `contact`).
  template <int dim>
  std::vector<double>
  DGMembraneProblem<dim>::estimate_multiplier(Vector        moments,
                                              const Vector *contact,
                                              const Vector (&s)[2],
                                              Vector &lambda,
                                              Vector &lambda_nonnegative,
                                              Vector &lambda_source) const
  {
    Vector nonnegative(moments);
    for (double &m : nonnegative)
      m = std::max(m, 0.);
    if (!contact)
      {
        function_from_moments(moments, lambda_source);
        limited_function(moments, nullptr, nullptr, lambda);
        limited_function(nonnegative, nullptr, nullptr, lambda_nonnegative);
        return {};
      }

    // With the transmitted load: the nodal function differs within the
    // cells from the L2 representative M_K^{-1} m that the fluxes would
    // equilibrate, and that misfit, divided by mu1^(1/2) in the residual
    // term, dominated the estimate for p >= 2. The Q1 function of the
    // vertex moments is equilibrated exactly, and limited only where it
    // and the transmitted load are negative together.
    Vector                    G(owned_nodes, comm), nonnegative_function;
    const std::vector<double> transmitted = transmitted_load(*contact, s, G);
    moments -= G;
    nonnegative -= G;
    vertex_moment_functions({&moments, &nonnegative},
                            {&lambda_source, &nonnegative_function});
    limited_function(moments, &lambda_source, &transmitted, lambda);
    limited_function(nonnegative,
                     &nonnegative_function,
                     &transmitted,
                     lambda_nonnegative);
    return transmitted;
  }


  // The broken nodes of a cell at the contact set carry their moments on
  // the cell itself: where the membranes part within such a cell (at the
  // free boundary), lambda_h meets a gap of the cone reconstruction, and
  // the contact term 2 (lambda_h^+, s~1 - s~2)_K is of the size of the
  // data, whatever the tensions. With tensions far apart the membranes of
  // s~ are joined at the nodes of such a cell (both values replaced by the
  // tension-weighted mean, which leaves s~ in the cone) where that costs
  // less: the contact term vanishes there, for the price of m^(1/2)
  // |grad(s~1 - s~2)| in the non-conformity (m = mu1 mu2 / (mu1 + mu2)),
  // the size of the error in the gap, estimated by m sum_i gap_i^2
  // |grad phi_i|_K^2 (times the cells at x_i). Dirichlet nodes keep the
  // boundary data. `moments` are those of lambda_h.
  template <int dim>
  void
  DGMembraneProblem<dim>::join_at_contact_cells(const Vector &contact,
                                                const Vector &moments,
                                                Vector (&s)[2]) const
  {
    Vector m;
    ghosted_nodes.copy(moments, m);
    Vector gap(s[0]);
    gap -= s[1];
    Vector ghosted_gap(owned_continuous, relevant_continuous, comm);
    ghosted_gap = gap;

    const Quadrature<dim> &points = flux_reconstruction->get_quadrature();
    FEValues<dim>          broken_values(*mapping, fe, points, update_values);
    FEValues<dim>          continuous_values(*mapping,
                                    fe_continuous,
                                    points,
                                    update_values | update_gradients |
                                      update_JxW_values);
    std::vector<types::global_dof_index> broken(fe.n_dofs_per_cell()),
      nodes(fe_continuous.n_dofs_per_cell()), marked;
    std::vector<double> gap_values(points.size());
    const double        tension = VI::reduced_tension(data.mu1, data.mu2);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          cell->get_dof_indices(broken);
          if (std::none_of(broken.begin(), broken.end(), [&](const auto i) {
                return contact(i) > 0;
              }))
            continue;
          const typename DoFHandler<dim>::active_cell_iterator continuous_cell(
            &triangulation,
            cell->level(),
            cell->index(),
            &continuous_dof_handler);
          continuous_cell->get_dof_indices(nodes);
          broken_values.reinit(cell);
          continuous_values.reinit(continuous_cell);
          continuous_values.get_function_values(ghosted_gap, gap_values);
          // lambda_N(x_I) = m_I / (psi_I, 1)_K at the points
          double contact_term = 0;
          for (const unsigned int q :
               continuous_values.quadrature_point_indices())
            {
              double lambda = 0;
              for (unsigned int i = 0; i < broken.size(); ++i)
                lambda += m(broken[i]) / lumped_mass(broken[i]) *
                          broken_values.shape_value(i, q);
              contact_term += 2. * std::max(lambda, 0.) *
                              std::max(gap_values[q], 0.) *
                              continuous_values.JxW(q);
            }
          double joining = 0;
          for (unsigned int i = 0; i < nodes.size(); ++i)
            {
              const double cells_at_node =
                fe_continuous.get_associated_geometry_primitive(i) ==
                    GeometryPrimitive::vertex ?
                  (1U << dim) :
                  2.;
              double stiffness = 0;
              for (const unsigned int q :
                   continuous_values.quadrature_point_indices())
                stiffness += continuous_values.shape_grad(i, q).norm_square() *
                             continuous_values.JxW(q);
              joining += tension * std::pow(ghosted_gap(nodes[i]), 2) *
                         stiffness * cells_at_node;
            }
          if (joining < contact_term)
            marked.insert(marked.end(), nodes.begin(), nodes.end());
        }
    Vector joined(owned_continuous, comm);
    joined.add(marked, std::vector<double>(marked.size(), 1.));
    joined.compress(VectorOperation::add);
    std::set<types::boundary_id> clamped;
    for (const types::boundary_id id : triangulation.get_boundary_ids())
      if (domain.is_clamped(id))
        clamped.insert(id);
    const IndexSet boundary =
      DoFTools::extract_boundary_dofs(continuous_dof_handler,
                                      ComponentMask(),
                                      clamped);
    const double theta = data.mu1 / (data.mu1 + data.mu2);
    for (const types::global_dof_index i : owned_continuous)
      if (joined(i) > 0 && !boundary.is_element(i))
        {
          const double mean = theta * s[0](i) + (1. - theta) * s[1](i);
          s[0](i)           = mean;
          s[1](i)           = mean;
        }
    for (unsigned int a = 0; a < 2; ++a)
      s[a].compress(VectorOperation::insert);
  }


  // g 1_J and G = (g 1_J, psi_I)_K of VI::TransmittedLoad for an iterate
  // with the contact set `contact` and the cone reconstruction s
  // (continuous; both ghosted): J holds the cells all of whose nodes are in
  // contact, and those at the contact set that the data decide.
  template <int dim>
  std::vector<double>
  DGMembraneProblem<dim>::transmitted_load(const Vector &contact,
                                           const Vector (&s)[2],
                                           Vector &G) const
  {
    const Quadrature<dim> &points = flux_reconstruction->get_quadrature();
    const unsigned int     n_q    = points.size();
    std::vector<double>    loads[2];
    for (unsigned int a = 0; a < 2; ++a)
      loads[a].assign(triangulation.n_active_cells() * n_q, 0.);
    FEValues<dim>        values(*mapping, fe, points, update_quadrature_points);
    const Function<dim> *f[2] = {data.f1.get(), data.f2.get()};
    std::vector<double>  cell_values(n_q);
    for (const auto &cell : dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          values.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              f[a]->value_list(values.get_quadrature_points(), cell_values);
              std::copy(cell_values.begin(),
                        cell_values.end(),
                        loads[a].begin() + cell->active_cell_index() * n_q);
            }
        }

    // (no node of the broken space is constrained: the boundary data are
    // imposed weakly)
    AffineConstraints<double> none;
    none.close();
    // (s on the broken nodes, for the cost of the contact term on a cell)
    Vector s_broken[2], owned(owned_nodes, comm);
    for (unsigned int a = 0; a < 2; ++a)
      {
        owned = 0;
        FETools::interpolate(continuous_dof_handler, s[a], dof_handler, owned);
        ghosted_nodes.copy(owned, s_broken[a]);
      }
    VI::TransmittedLoad<dim> load;
    load.reinit(
      *mapping, dof_handler, none, points, domain.friedrichs_constant());
    typename VI::TransmittedLoad<dim>::Split split;
    load.split(data.mu1,
               data.mu2,
               loads[0],
               loads[1],
               contact,
               s_broken[0],
               s_broken[1],
               split);
    G = split.node_moments;
    return std::move(split.values);
  }


  // Explicit instantiations of this file's members.
  template void
  DGMembraneProblem<2>::function_from_moments(const Vector &moments,
                                              Vector       &v) const;
  template bool
  DGMembraneProblem<2>::mass_lumped() const;
  template void
  DGMembraneProblem<2>::multiplier_function(const Vector &X3,
                                            Vector       &lambda) const;
  template void
  DGMembraneProblem<2>::limited_function(const Vector &,
                                         const Vector *,
                                         const std::vector<double> *,
                                         Vector &) const;
  template void
  DGMembraneProblem<2>::vertex_moment_functions(
    const std::vector<const Vector *> &,
    const std::vector<Vector *> &) const;
  template void
  DGMembraneProblem<2>::moments_of_function(const Vector &v,
                                            Vector       &moments) const;
  template void
  DGMembraneProblem<2>::for_each_owned_cell(
    const Quadrature<2> &quadrature,
    const std::function<void(const FEValues<2> &,
                             const std::vector<types::global_dof_index> &)>
      &local) const;
  template void
  DGMembraneProblem<2>::reconstruct_potentials(const Vector (&u)[2],
                                               Vector (&oswald)[2],
                                               Vector (&averaged)[2],
                                               Vector (&L)[2]) const;
  template VI::DGContactEstimate
  DGMembraneProblem<2>::estimate(const Vector &X) const;
  template std::vector<double>
  DGMembraneProblem<2>::estimate_multiplier(Vector        moments,
                                            const Vector *contact,
                                            const Vector (&s)[2],
                                            Vector &lambda,
                                            Vector &lambda_nonnegative,
                                            Vector &lambda_source) const;
  template void
  DGMembraneProblem<2>::join_at_contact_cells(const Vector &contact,
                                              const Vector &moments,
                                              Vector (&s)[2]) const;
  template std::vector<double>
  DGMembraneProblem<2>::transmitted_load(const Vector &contact,
                                         const Vector (&s)[2],
                                         Vector &G) const;
} // namespace StepMembranes
