// The a posteriori estimate of step-hho (doc/reference.md, "A posteriori
// estimate of HHO"): a guaranteed bound of the energy error of the cell
// polynomials,
//
//   |||u - u_T|||_h^2 = sum_K mu1 |grad(u1 - u1,K)|_K^2 + mu2 |grad(u2 -
//   u2,K)|_K^2,
//
// from the bound of the broken (dG) case, VI::estimate_dg_contact_error,
// with three HHO ingredients:
// - the broken iterate: the cell polynomials u_alpha,K and lambda_h, written
//   in FE_DGQ(p) (P_p is in Q_p, so exactly);
// - the potential: the Oswald interpolate of u_T, averaged where s1 < s2;
// - the flux: HHO is locally conservative. Testing the cell rows with
//   q in P_p(K) and the face rows with v_F in P_{p-1}(F) gives
//
//     -(sigma_K, grad q)_K + (Phi_K, q)_dK = (f_alpha -/+ lambda_h, q)_K,
//     sum_{K containing F} Pi_F Phi_KF = 0,
//
//   with sigma_K = -mu G_K u and the numerical flux Phi_KF = -mu (G_K u . n_K
//   + h_K^(-1) Pi_F (u_F - u_K)) (the second part from the stabilisation).
//   So phi_KF = Pi_F Phi_KF, in P_{p-1}(F), is single-valued across F and
//   sum_F (phi_KF, 1)_F = (f -/+ lambda_h, 1)_K: it is the normal trace of
//   an equilibrated H(div) flux. On each cell, sigma in RT_p(K) takes the
//   normal trace phi_KF, the divergence Pi_{Q_p}(f -/+ lambda_h) and is
//   otherwise closest to -mu grad u_K: a mixed problem of the cell alone.
// - An iterate whose face rows are not solved (CG stopped early, a damped
//   Newton step) has two traces on a face, phi_KF + phi_K'F = delta_F, with
//   (delta_F, v)_F = -R_F(v) the face rows of its residual. The flux takes
//   their mean, phi_KF - delta_F / 2, which is single-valued (on a free
//   boundary face delta_F = phi_KF, and the flux takes 0), and each cell
//   keeps its imbalance as r_K = mean of (f -/+ lambda_h - div sigma) on K,
//   the remainder r_h of the broken bound (eta_alg = C_F |r_h|, weighted
//   by the tensions). Once the face rows vanish, r_h = 0 and the flux is
//   that of the solved system.

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_raviart_thomas.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>

#include <vi/dg_reconstruction.h>
#include <vi/estimators.h>
#include <vi/interior_penalty.h>
#include <vi/same_cell.h>

#include "cell_flux.h"
#include "hho_problem.h"
#include "local_operators.h"

#include <array>
#include <map>

namespace StepHHO
{
  namespace
  {
    using MPIVector = TrilinosWrappers::MPI::Vector;

    /// A DoFHandler on the mesh with its owned and relevant index sets.
    template <int dim>
    struct Space
    {
      Space(const Triangulation<dim> &tria, const FiniteElement<dim> &fe)
          : dofs(tria)
      {
        dofs.distribute_dofs(fe);
        owned    = dofs.locally_owned_dofs();
        relevant = DoFTools::extract_locally_relevant_dofs(dofs);
      }

      MPIVector
      ghosted(const MPIVector &owned_vector) const
      {
        MPIVector v(owned, relevant, owned_vector.get_mpi_communicator());
        v = owned_vector;
        return v;
      }

      DoFHandler<dim> dofs;
      IndexSet        owned, relevant;
    };


    /// The matrices [A_0, ..., A_{N-1}] of a linear map (x_0, ..., x_{N-1})
    /// -> sum_b A_b x_b to R^n, from its values on the unit vectors (x_b of
    /// size sizes[b]).
    template <std::size_t N, typename Map>
    std::array<FullMatrix<double>, N>
    linear_maps(const unsigned int                 n,
                const std::array<unsigned int, N> &sizes,
                const Map                         &map)
    {
      std::array<FullMatrix<double>, N> matrices;
      std::array<Vector<double>, N>     inputs;
      for (unsigned int b = 0; b < N; ++b)
        {
          matrices[b].reinit(n, sizes[b]);
          inputs[b].reinit(sizes[b]);
        }
      for (unsigned int b = 0; b < N; ++b)
        for (unsigned int j = 0; j < sizes[b]; ++j)
          {
            inputs[b](j)                = 1;
            const Vector<double> column = map(inputs);
            for (unsigned int i = 0; i < n; ++i)
              matrices[b](i, j) = column(i);
            inputs[b](j) = 0;
          }
      return matrices;
    }


    /**
     * The flux of one membrane on one cell from the cell's HHO unknowns: the
     * normal traces phi_KF - d_F on its faces, with phi_KF = -mu Pi_F (G_K u
     * . n_K + h_K^(-1) (u_F - u_K)) (the first comment of this file) and a
     * correction d_F in P_{p-1}(F), completed inside by CellFlux.
     */
    template <int dim>
    class CellSigma
    {
    public:
      using CellIterator = typename DoFHandler<dim>::active_cell_iterator;

      CellSigma(const Mapping<dim>              &mapping,
                const FiniteElement<dim>        &cell_fe,
                const FiniteElement<dim>        &face_fe,
                const FiniteElement<dim>        &flux_fe,
                const std::vector<unsigned int> &gradient_basis,
                const Quadrature<dim>           &quadrature,
                const Quadrature<dim - 1>       &face_quadrature,
                const unsigned int               p)
          : cell_values(mapping,
                        cell_fe,
                        quadrature,
                        update_values | update_gradients |
                          update_quadrature_points | update_JxW_values)
          , trace_values(mapping,
                         cell_fe,
                         face_quadrature,
                         update_values | update_quadrature_points |
                           update_normal_vectors | update_JxW_values)
          , face_values(mapping, face_fe, face_quadrature, update_values)
          , cell_flux(mapping, flux_fe, quadrature, face_quadrature, p)
          , gradient_basis(gradient_basis)
          , Gu(dim * gradient_basis.size())
          , phi(GeometryInfo<dim>::faces_per_cell,
                std::vector<double>(face_quadrature.size()))
          , mu_grad_u(quadrature.size())
      {
      }

      /// Prepare `cell` (G_K) and its copy `flux_cell` (CellFlux).
      void
      reinit(const CellIterator &cell, const CellIterator &flux_cell)
      {
        this->cell = cell;
        LocalOperators::gradient_reconstruction(cell,
                                                cell_values,
                                                trace_values,
                                                face_values,
                                                gradient_basis,
                                                G,
                                                gradient_mass);
        cell_flux.reinit(flux_cell);
      }

      /// The coefficients of sigma for the tension mu, the local vector
      /// (u_K in FE_DGP's basis, u_dK), the source f -/+ lambda_h at the
      /// quadrature points and the moments (d_F, v_k)_F at the face DoFs.
      Vector<double>
      compute(const double               mu,
              const Vector<double>      &local,
              const std::vector<double> &source,
              const Vector<double>      &correction)
      {
        G.vmult(Gu, local);
        normal_fluxes(mu, local, correction);
        const unsigned int n_c = cell_values.get_fe().n_dofs_per_cell();
        std::fill(mu_grad_u.begin(), mu_grad_u.end(), Tensor<1, dim>());
        for (const unsigned int q : cell_values.quadrature_point_indices())
          for (unsigned int i = 0; i < n_c; ++i)
            mu_grad_u[q] += mu * local(i) * cell_values.shape_grad(i, q);
        return cell_flux.solve(phi, mu_grad_u, source);
      }

    private:
      // phi[f][q] = phi_KF - d_F at the points of the face quadrature.
      void
      normal_fluxes(const double          mu,
                    const Vector<double> &local,
                    const Vector<double> &correction)
      {
        const FiniteElement<dim> &face_fe = face_values.get_fe();
        const unsigned int        n_c = cell_values.get_fe().n_dofs_per_cell();
        const unsigned int        n_g = gradient_basis.size();
        const double              inverse_h = 1. / cell->diameter();
        for (const unsigned int face : cell->face_indices())
          {
            trace_values.reinit(cell, face);
            face_values.reinit(cell, face);
            const unsigned int        n_F = face_fe.n_dofs_per_face(face);
            std::vector<unsigned int> dofs(n_F);
            for (unsigned int k = 0; k < n_F; ++k)
              dofs[k] = face_fe.face_to_cell_index(k, face);
            // The L2 projection onto P_{p-1}(F) of w = G_K u . n + (u_F -
            // u_K)/h_K.
            FullMatrix<double> M(n_F, n_F);
            Vector<double>     b(n_F), c(n_F);
            for (const unsigned int q : trace_values.quadrature_point_indices())
              {
                double w = 0;
                for (unsigned int d = 0; d < dim; ++d)
                  for (unsigned int m = 0; m < n_g; ++m)
                    w += Gu(d * n_g + m) *
                         trace_values.shape_value(gradient_basis[m], q) *
                         trace_values.normal_vector(q)[d];
                for (unsigned int i = 0; i < n_c; ++i)
                  w -= inverse_h * local(i) * trace_values.shape_value(i, q);
                for (const unsigned int i : dofs)
                  w +=
                    inverse_h * local(n_c + i) * face_values.shape_value(i, q);
                const double ds = trace_values.JxW(q);
                for (unsigned int k = 0; k < n_F; ++k)
                  {
                    const double psi_k = face_values.shape_value(dofs[k], q);
                    b(k) += w * psi_k * ds;
                    for (unsigned int l = 0; l < n_F; ++l)
                      M(k, l) +=
                        psi_k * face_values.shape_value(dofs[l], q) * ds;
                  }
              }
            // c = -mu Pi_F w - d_F in the face's basis.
            M.gauss_jordan();
            M.vmult(c, b);
            c *= -mu;
            for (unsigned int k = 0; k < n_F; ++k)
              b(k) = -correction(dofs[k]);
            M.vmult_add(c, b);
            for (const unsigned int q : trace_values.quadrature_point_indices())
              {
                phi[face][q] = 0;
                for (unsigned int k = 0; k < n_F; ++k)
                  phi[face][q] += c(k) * face_values.shape_value(dofs[k], q);
              }
          }
      }

      FEValues<dim>                    cell_values;
      FEFaceValues<dim>                trace_values, face_values;
      CellFlux<dim>                    cell_flux;
      const std::vector<unsigned int> &gradient_basis;
      CellIterator                     cell;
      FullMatrix<double>               G, gradient_mass;
      Vector<double>                   Gu;
      std::vector<std::vector<double>> phi;
      std::vector<Tensor<1, dim>>      mu_grad_u;
    };
  } // namespace


  // The cell polynomials u1,K, u2,K and lambda_h in FE_DGQ(p) on `broken`,
  // and lambda_h^+: lambda_h scaled towards its cell mean (if that is
  // positive; else 0) until it is nonnegative at the points of `quadrature`,
  // where the estimate evaluates it. Vectors of the owned entries.
  template <int dim>
  void
  HHOProblem<dim>::broken_fields(const DoFHandler<dim> &broken,
                                 const Quadrature<dim> &quadrature,
                                 TrilinosWrappers::MPI::Vector (&u)[2],
                                 TrilinosWrappers::MPI::Vector &lambda,
                                 TrilinosWrappers::MPI::Vector &positive) const
  {
    const FiniteElement<dim> &broken_fe = broken.get_fe();
    const IndexSet            owned     = broken.locally_owned_dofs();
    for (MPIVector *v : {&u[0], &u[1], &lambda, &positive})
      v->reinit(owned, comm);
    FEValues<dim>       at_nodes(*mapping,
                           cell_fe,
                           Quadrature<dim>(broken_fe.get_unit_support_points()),
                           update_values);
    FEValues<dim>       at_points(*mapping,
                            cell_fe,
                            quadrature,
                            update_values | update_JxW_values);
    std::vector<double> nodal(broken_fe.n_dofs_per_cell()),
      lambda_nodal(nodal.size()), lambda_points(quadrature.size());
    std::vector<types::global_dof_index> indices(nodal.size());
    const MPIVector                     *u_h[2] = {&u1_h, &u2_h};
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          VI::same_cell(cell, broken)->get_dof_indices(indices);
          at_nodes.reinit(cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              at_nodes.get_function_values(*u_h[a], nodal);
              for (unsigned int i = 0; i < nodal.size(); ++i)
                u[a](indices[i]) = nodal[i];
            }
          at_nodes.get_function_values(lambda_h, lambda_nodal);
          at_points.reinit(cell);
          at_points.get_function_values(lambda_h, lambda_points);
          double integral = 0, area = 0;
          for (const unsigned int q : at_points.quadrature_point_indices())
            {
              integral += lambda_points[q] * at_points.JxW(q);
              area += at_points.JxW(q);
            }
          const double mean  = integral / area;
          double       theta = mean > 0 ? 1. : 0.;
          for (const double value : lambda_points)
            if (value < 0 && mean > 0)
              theta = std::min(theta, mean / (mean - value));
          for (unsigned int i = 0; i < nodal.size(); ++i)
            {
              lambda(indices[i]) = lambda_nodal[i];
              positive(indices[i]) =
                std::max(mean, 0.) + theta * (lambda_nodal[i] - mean);
            }
        }
    for (MPIVector *v : {&u[0], &u[1], &lambda, &positive})
      v->compress(VectorOperation::insert);
  }


  // The equilibrated fluxes sigma_1, sigma_2 in RT_p on `flux`, cell by cell
  // (CellSigma), from the mean normal traces: d_F = delta_F / 2 is taken off
  // each side of an interior face, all of delta_F = phi_KF off a free
  // boundary face, whose flux must vanish (the rows of the clamped faces are
  // 0). And what each cell leaves unbalanced, r_alpha,K = ((f_alpha -/+
  // lambda_h, 1)_K - (div sigma_alpha, 1)_K) / |K| on `broken`, so that div
  // sigma_alpha = Pi_{Q_p}(f_alpha -/+ lambda_h) - r_alpha: with the cell
  // rows R_I of the residual, sum_I R_I = sum_F (phi_KF, 1)_F - (f_alpha -/+
  // lambda_h, 1)_K (the nodal basis sums to 1, and a_K(u, (1, 1)) = 0), so
  // r_alpha,K |K| = sum_F (d_F, 1)_F - sum_I R_I: what the rows of the
  // iterate leave unsolved, and no quadrature error of the data. Vectors of
  // the owned entries.
  template <int dim>
  void
  HHOProblem<dim>::equilibrated_fluxes(
    const DoFHandler<dim>     &flux,
    const DoFHandler<dim>     &broken,
    const Quadrature<dim>     &quadrature,
    const Quadrature<dim - 1> &face_quadrature,
    TrilinosWrappers::MPI::Vector (&sigma)[2],
    TrilinosWrappers::MPI::Vector (&r)[2]) const
  {
    const unsigned int n_c   = cell_fe.n_dofs_per_cell();
    const unsigned int n_f   = face_fe.n_dofs_per_cell();
    const unsigned int n_q   = quadrature.size();
    const unsigned int n_rt  = flux.get_fe().n_dofs_per_cell();
    const double       mu[2] = {data.mu1, data.mu2};
    const IndexSet     owned = flux.locally_owned_dofs();
    for (MPIVector &v : sigma)
      v.reinit(owned, comm);
    for (MPIVector &v : r)
      v.reinit(broken.locally_owned_dofs(), comm);
    MPIVector X, residual_rows, R;
    ghosted_system.copy(solution, X);
    // The face rows of the residual, R_F(v_k) = -(delta_F, v_k)_F.
    R.reinit(solution);
    equation_residual(solution, R);
    ghosted_system.copy(R, residual_rows);

    CellSigma<dim> cell_sigma(*mapping,
                              cell_fe,
                              face_fe,
                              flux.get_fe(),
                              gradient_basis,
                              quadrature,
                              face_quadrature,
                              degree);

    // sigma is linear in (mu local, source, correction). Where many cells
    // share a shape (translates, see compute_local_matrices()), its three
    // matrices are computed once, on the first of them, column by column.
    using Maps = std::array<FullMatrix<double>, 3>;
    std::map<unsigned int, unsigned int> cells_of_shape;
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        ++cells_of_shape[cell_shape[cell->active_cell_index()]];
    std::map<unsigned int, Maps> maps;
    const auto                   map_of = [&](const CellIterator &cell,
                            const CellIterator &flux_cell) -> const Maps                   *{
      const unsigned int shape = cell_shape[cell->active_cell_index()];
      if (cells_of_shape[shape] <= n_c + 2 * n_f + n_q)
        return nullptr;
      auto [it, added] = maps.try_emplace(shape);
      if (added)
        {
          cell_sigma.reinit(cell, flux_cell);
          it->second = linear_maps<3>(
            n_rt,
            {{n_c + n_f, n_q, n_f}},
            [&](const std::array<Vector<double>, 3> &unit) {
              return cell_sigma.compute(1.,
                                        unit[0],
                                        std::vector<double>(unit[1].begin(),
                                                            unit[1].end()),
                                        unit[2]);
            });
        }
      return &it->second;
    };

    const Function<dim> *f[2]   = {data.f1.get(), data.f2.get()};
    const MPIVector     *u_h[2] = {&u1_h, &u2_h};
    FEValues<dim>        source_values(*mapping,
                                cell_fe,
                                quadrature,
                                update_values | update_quadrature_points |
                                  update_JxW_values);
    Vector<double>       local(n_c + n_f), correction(n_f), coefficients(n_rt),
      source_vector(n_q);
    std::vector<double>                  source(n_q), lambda_values(n_q);
    std::vector<types::global_dof_index> cell_dofs(n_c), flux_dofs(n_rt),
      broken_dofs(broken.get_fe().n_dofs_per_cell());
    std::vector<unsigned int> face_of_dof(n_f);
    for (const unsigned int face : GeometryInfo<dim>::face_indices())
      for (unsigned int k = 0; k < face_fe.n_dofs_per_face(face); ++k)
        face_of_dof[face_fe.face_to_cell_index(k, face)] = face;
    for (const auto &cell : cell_dof_handler.active_cell_iterators())
      if (cell->is_locally_owned())
        {
          const auto unknowns  = local_unknowns(cell);
          const auto flux_cell = VI::same_cell(cell, flux);
          flux_cell->get_dof_indices(flux_dofs);
          cell->get_dof_indices(cell_dofs);
          VI::same_cell(cell, broken)->get_dof_indices(broken_dofs);
          source_values.reinit(cell);
          source_values.get_function_values(lambda_h, lambda_values);
          const Maps *map = map_of(cell, flux_cell);
          if (!map)
            cell_sigma.reinit(cell, flux_cell);
          for (unsigned int a = 0; a < 2; ++a)
            {
              for (unsigned int i = 0; i < n_c; ++i)
                local(i) = (*u_h[a])(cell_dofs[i]);
              for (unsigned int k = 0; k < n_f; ++k)
                {
                  const auto unknown = unknowns[n_fields * n_c + a * n_f + k];
                  local(n_c + k)     = X(unknown);
                  correction(k)      = -imbalance_share(cell, face_of_dof[k]) *
                                  residual_rows(unknown);
                }
              // f_alpha -/+ lambda_h (membrane 1 is pushed up by lambda,
              // membrane 2 down).
              f[a]->value_list(source_values.get_quadrature_points(), source);
              for (unsigned int q = 0; q < n_q; ++q)
                source[q] += (a == 0 ? 1. : -1.) * lambda_values[q];
              if (map)
                {
                  std::copy(source.begin(),
                            source.end(),
                            source_vector.begin());
                  (*map)[1].vmult(coefficients, source_vector);
                  (*map)[2].vmult_add(coefficients, correction);
                  local *= mu[a];
                  (*map)[0].vmult_add(coefficients, local);
                }
              else
                coefficients =
                  cell_sigma.compute(mu[a], local, source, correction);
              for (unsigned int i = 0; i < n_rt; ++i)
                if (owned.is_element(flux_dofs[i]))
                  sigma[a](flux_dofs[i]) = coefficients(i);

              double imbalance = 0, area = 0;
              for (unsigned int k = 0; k < n_f; ++k)
                imbalance += correction(k);
              for (unsigned int I = 0; I < n_c; ++I)
                imbalance -= residual_rows(unknowns[a * n_c + I]);
              for (const unsigned int q :
                   source_values.quadrature_point_indices())
                area += source_values.JxW(q);
              for (const types::global_dof_index i : broken_dofs)
                r[a](i) = imbalance / area;
            }
        }
    for (MPIVector *v : {&sigma[0], &sigma[1], &r[0], &r[1]})
      v->compress(VectorOperation::insert);
  }


  template <int dim>
  VI::DGContactEstimate
  HHOProblem<dim>::estimate() const
  {
    TimerOutput::Scope          t(timer, "estimators");
    const unsigned int          p = degree;
    const FE_DGQ<dim>           broken_fe(p);
    const FE_Q<dim>             continuous_fe(p);
    const FE_RaviartThomas<dim> flux_fe(p);
    const Space<dim>            broken(triangulation, broken_fe),
      continuous(triangulation, continuous_fe), flux(triangulation, flux_fe);
    // The rule of the conforming estimate (at least p + 3 points per
    // direction, even: symmetric about the cell's centre lines), so that
    // the data and the nonsmooth parts are integrated alike.
    const unsigned int    n_points = p + 3 + (p + 3) % 2;
    const QGauss<dim>     quadrature(n_points);
    const QGauss<dim - 1> face_quadrature(n_points);

    MPIVector u_owned[2], lambda_owned, positive_owned;
    broken_fields(
      broken.dofs, quadrature, u_owned, lambda_owned, positive_owned);
    const MPIVector u[2]     = {broken.ghosted(u_owned[0]),
                                broken.ghosted(u_owned[1])};
    const MPIVector lambda   = broken.ghosted(lambda_owned),
                    positive = broken.ghosted(positive_owned);

    // The potential: Oswald interpolates with the nodal values of g on the
    // clamped boundary, averaged where s1 < s2, continuous at hanging nodes.
    AffineConstraints<double> hanging_nodes(continuous.relevant);
    DoFTools::make_hanging_node_constraints(continuous.dofs, hanging_nodes);
    hanging_nodes.close();
    const Function<dim> *g[2] = {data.g1.get(), data.g2.get()};
    MPIVector            oswald[2], averaged[2];
    for (unsigned int a = 0; a < 2; ++a)
      {
        oswald[a].reinit(continuous.owned, comm);
        averaged[a].reinit(continuous.owned, comm);
        VI::oswald_interpolation(*mapping,
                                 broken.dofs,
                                 u[a],
                                 continuous.dofs,
                                 g[a],
                                 oswald[a],
                                 &domain,
                                 &hanging_nodes);
      }
    VI::average_at_violated_nodes(
      data.mu1, data.mu2, oswald[0], oswald[1], averaged[0], averaged[1]);
    for (MPIVector &v : averaged)
      hanging_nodes.distribute(v);
    const MPIVector s[2] = {continuous.ghosted(averaged[0]),
                            continuous.ghosted(averaged[1])};
    // The averaging changes the Oswald interpolates only where the nodal
    // complementarity fails, so its part of eta_nonc1 goes to Newton's error
    // (eta_lin) and vanishes once Newton has converged.
    const MPIVector unaveraged[2] = {continuous.ghosted(oswald[0]),
                                     continuous.ghosted(oswald[1])};

    MPIVector sigma_owned[2], r_owned[2];
    equilibrated_fluxes(flux.dofs,
                        broken.dofs,
                        quadrature,
                        face_quadrature,
                        sigma_owned,
                        r_owned);
    const MPIVector sigma[2] = {flux.ghosted(sigma_owned[0]),
                                flux.ghosted(sigma_owned[1])};
    const MPIVector r[2]     = {broken.ghosted(r_owned[0]),
                                broken.ghosted(r_owned[1])};

    // The jumps of u_T are reported with the weight of SIPG's default
    // penalty; the bound of the cell polynomials does not use them.
    const VI::InteriorPenalty penalty(
      VI::InteriorPenalty::Type::sipg,
      VI::InteriorPenalty::default_penalty_constant,
      p);
    VI::DGContactEstimatorInput<dim> in;
    in.mapping         = mapping.get();
    in.broken          = &broken.dofs;
    in.continuous      = &continuous.dofs;
    in.flux            = &flux.dofs;
    in.quadrature      = &quadrature;
    in.face_quadrature = &face_quadrature;
    in.penalty         = &penalty;
    in.set_problem(data, domain);
    in.u1                 = &u[0];
    in.u2                 = &u[1];
    in.lambda             = &lambda;
    in.lambda_nonnegative = &positive;
    in.r1                 = &r[0];
    in.r2                 = &r[1];
    in.s1                 = &s[0];
    in.s2                 = &s[1];
    in.oswald1            = &unaveraged[0];
    in.oswald2            = &unaveraged[1];
    in.sigma1             = &sigma[0];
    in.sigma2             = &sigma[1];
    return VI::estimate_dg_contact_error(in);
  }


  template void
  HHOProblem<2>::broken_fields(const DoFHandler<2> &,
                               const Quadrature<2> &,
                               TrilinosWrappers::MPI::Vector (&)[2],
                               TrilinosWrappers::MPI::Vector &,
                               TrilinosWrappers::MPI::Vector &) const;
  template void
  HHOProblem<2>::equilibrated_fluxes(
    const DoFHandler<2> &,
    const DoFHandler<2> &,
    const Quadrature<2> &,
    const Quadrature<1> &,
    TrilinosWrappers::MPI::Vector (&)[2],
    TrilinosWrappers::MPI::Vector (&)[2]) const;
  template VI::DGContactEstimate
  HHOProblem<2>::estimate() const;
} // namespace StepHHO
