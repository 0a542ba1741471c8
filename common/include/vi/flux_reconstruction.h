#pragma once

#include <deal.II/base/array_view.h>
#include <deal.II/base/geometry_info.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_dgq.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_raviart_thomas.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/ghosted_copy.h>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <unordered_map>
#include <vector>

namespace dealii::Utilities::MPI
{
  class Partitioner;
}

namespace VI
{
  /**
   * Equilibrated flux reconstruction on vertex patches (Destuynder-Metivet,
   * Braess-Schoeberl, Ern-Vohralik): for one field, given on every cell a
   * flux F (e.g. mu grad u_h) and a source s (e.g. f - (-1)^alpha lambda_h -
   * r_h), find sigma = sum_a sigma^a in RT_p(Omega), where for each vertex a
   * with hat function psi_a and patch omega_a, (sigma^a, gamma^a) in
   * RT_p(omega_a) x Q_p(omega_a) solves the mixed problem
   *
   *   (sigma^a, tau) - (gamma^a, div tau) = -(psi_a F, tau),
   *   (div sigma^a, q)                    = ((s + c_a) psi_a - F.grad psi_a,
   * q),
   *
   * with sigma^a . n = 0 on the boundary of omega_a (except on the boundary of
   * Omega for boundary vertices) and, for interior vertices, mean-zero
   * q and gamma^a. c_a is an optional constant per vertex (the mass-lumped
   * multiplier and algebraic residual of p = 1). Then, when the data satisfy
   * the discrete equations (the patch problems of interior vertices are
   * compatible), div sigma = Pi_p (s + sum_a c_a psi_a) on every cell: the
   * flux is in H(div) and in equilibrium with the source, cell by cell.
   *
   * RT_p is FE_RaviartThomas(p), whose divergence lies in Q_p, and Q_p is
   * FE_DGQ(p). Each patch problem is solved on the divergence-free fluxes
   * of the patch (a kernel basis of the divergence block, which does not
   * depend on the geometry beyond signs, computed once per distinct block)
   * plus a particular flux: sigma^a is the same, the mean-value condition
   * and gamma^a are not needed (see the .cc file).
   *
   * The energy that selects sigma^a among the equilibrated fluxes is that
   * of the parallelogram with the cell's mean Jacobian J: (tau_i, tau_j)
   * is replaced by s_i s_j int (J tau^_i) . (J tau^_j) / det J on the
   * reference cell, and the right-hand side -(psi_a F, tau) by the same
   * product with the Piola pull-back of psi_a F, so that a flux of RT_p is
   * reproduced exactly. On parallelograms this is the L2 product; on other
   * cells it is a close, equivalent one. The equilibration, which is all
   * the guaranteed bound needs of sigma, does not depend on it (the
   * divergence block is topological), and the estimators measure sigma in
   * the true L2 norm; what the choice buys is that the patch energies are
   * linear combinations of a few products prepared once per patch layout
   * (dim (dim + 1) / 2 numbers per cell: the entries of J^T J / det J),
   * instead of cell mass matrices integrated on every cell. They are invariant
   * under scaling and shared by the patches of equal metrics (on uniformly
   * refined meshes a handful for the whole hierarchy; on curved meshes,
   * where no two patches are alike, the search stops after the first
   * thousand).
   *
   * On meshes with hanging nodes psi_a is the conforming hat function of a
   * regular vertex a (the hanging vertices, whose values are constrained,
   * carry no patch): on a cell it is the Q1 function with value 1 at a and
   * the constraint weight (1/2) at the hanging vertices that depend on a,
   * so omega_a also contains the fine cells that touch those hanging
   * vertices; RT_p(omega_a) is made H(div)-conforming across the hanging
   * faces by the hanging node constraints of FE_RaviartThomas.
   *
   * In parallel, the process that owns the degree of freedom of psi_a
   * solves the patch of a, and every cell's part of it (its share of the
   * patch matrix and of the right-hand sides) is computed by the cell's
   * owner and sent there. With hanging nodes a patch can reach two cells
   * beyond the ones at a, past the ghost layer; no process needs to see a
   * patch whole.
   */
  template <int dim>
  class FluxReconstruction
  {
  public:
    using CellIterator =
      typename dealii::Triangulation<dim>::active_cell_iterator;

    /**
     * The data equilibrated, for one or several fields at once (the two
     * membranes share the patch matrices and the cell loop).
     */
    struct Sources
    {
      /// Fills flux[c][q] = F and source[c][q] = s of field c at the points
      /// of get_quadrature() on `cell`, a locally owned cell (each cell is
      /// evaluated once per reconstruction); the vectors are sized.
      using CellValues = std::function<
        void(const CellIterator &,
             std::vector<std::vector<dealii::Tensor<1, dim>>> &flux,
             std::vector<std::vector<double>>                 &source)>;

      unsigned int n_fields = 1;
      /// Makes the CellValues of one thread. The cells are evaluated
      /// concurrently (WorkStream, on the threads of MultithreadInfo), each
      /// thread with the function made for it: that function may keep its
      /// own scratch (FEValues, value arrays), and must only read what it
      /// shares with the others (vectors, data tables).
      std::function<CellValues()> make_cell_values;
      /// Optional: c_a of field c for the global vertex index a.
      std::function<double(const unsigned int vertex, const unsigned int field)>
        vertex_source;
    };

    /**
     * Fluxes in RT_k x Q_k with k = `degree`, equilibrating the data of a
     * potential of degree `potential_degree` (>= k; by default k), whose
     * quadrature they share: Gauss with `n_points` per direction, by
     * default quadrature_points(potential_degree, degree). With k = p - 1 <
     * p the patch problems are smaller and div sigma = Pi_(p-1) of the
     * source: still an equilibrated flux, the projection's remainder going
     * to the residual estimator.
     */
    FluxReconstruction(
      const dealii::Mapping<dim> &mapping,
      const unsigned int          degree,
      const unsigned int          potential_degree =
        dealii::numbers::invalid_unsigned_int,
      const unsigned int n_points = dealii::numbers::invalid_unsigned_int);

    /**
     * Gauss points per direction of the quadrature for a potential of
     * degree p and fluxes in RT_k (by default k = p), rounded up to an even
     * number. An even rule has no point on the midlines of the cell, nor on
     * the other lines of Gauss-Lobatto nodes; there the positive and
     * negative parts of finite element functions that vanish on a line of
     * nodes would depend on round-off. The load vector of the problem must
     * be integrated with the same rule.
     *
     * k = p: at least p + 3, exact for the patch matrices and right-hand
     * sides on affine cells and accurate for data of degree p times hats.
     * k = p - 1: at least p + 1, which on affine cells is exact for every
     * polynomial integrand of the problem and of the estimate: the
     * stiffness and |grad u_h + sigma|^2 (degree 2p per direction), the
     * Raviart-Thomas mass (2k + 2 = 2p), (psi_a grad u_h, tau) (1 + p + k +
     * 1 = 2p + 1) and data of degree p times hats against Q_k (2p). For Q1
     * with RT_0 that is 2 x 2 points instead of 4 x 4.
     */
    static unsigned int
    quadrature_points(
      const unsigned int potential_degree,
      const unsigned int flux_degree = dealii::numbers::invalid_unsigned_int);
    ~FluxReconstruction();

    /**
     * Build the Raviart-Thomas space and the patches of the vertices owned
     * by this process, on the mesh of `potential` (the mesh may have
     * hanging nodes). The cells' data, the patches (in chunks of
     * consecutive ones) and their factorisations are computed on the
     * threads of MultithreadInfo and gathered in a fixed order: the patches
     * do not depend on the number of threads. On the boundary faces of
     * `free_boundary_ids` (where the membranes are free) sigma . n = 0.
     */
    void
    reinit(const dealii::DoFHandler<dim>              &potential,
           const std::set<dealii::types::boundary_id> &free_boundary_ids = {});

    /// sigma[c] = sum_a sigma_c^a for every field c, with ghost entries.
    /// The cells' right-hand sides and the patch problems are computed on
    /// the threads of MultithreadInfo; they are summed in a fixed order, so
    /// the result does not depend on the number of threads (to the last bit
    /// between runs on several threads; on one, deal.II's FEValues may
    /// reuse the geometry of a translated cell, which moves the last bits
    /// of JxW on uniform meshes). The second
    /// call on a mesh keeps products for the later ones (see the .cc
    /// file): calls must not overlap.
    void
    reconstruct(
      const Sources                                              &sources,
      const std::vector<dealii::TrilinosWrappers::MPI::Vector *> &sigma) const;

    const dealii::DoFHandler<dim> &
    get_dof_handler() const;

    const dealii::Quadrature<dim> &
    get_quadrature() const;

    const dealii::IndexSet &
    locally_owned_dofs() const;

    /// The Piola signs s_i of the Raviart-Thomas functions of the locally
    /// owned cells, [active cell index * dofs per cell + i] (see
    /// PiolaDivergence).
    const std::vector<std::int8_t> &
    get_piola_signs() const;

    const dealii::IndexSet &
    locally_relevant_dofs() const;

    /// Number of patches on this process, and of distinct patch matrices.
    std::pair<unsigned int, unsigned int>
    statistics() const;

  private:
    struct DivergenceBasis;
    struct PatchLayout;
    struct LocalSolver;
    struct CellTable;
    /// FNV-1a over the entries of a key.
    struct KeyHash
    {
      std::size_t
      operator()(const std::vector<std::int64_t> &key) const
      {
        std::uint64_t hash = 14695981039346656037ull;
        for (const std::int64_t entry : key)
          hash = (hash ^ static_cast<std::uint64_t>(entry)) * 1099511628211ull;
        return hash;
      }
    };
    using Layouts = std::unordered_map<std::vector<std::int64_t>,
                                       std::shared_ptr<const PatchLayout>,
                                       KeyHash>;
    struct Shares;
    struct CellScratch;
    struct CellShare;
    /// The phases of reinit() and what they hand on to each other (see
    /// flux_reconstruction_setup.cc).
    struct Setup;

    /// The right-hand sides of a locally owned cell's parts in its patches
    /// (thread-safe: writes only to the scratch and the share).
    void
    cell_share(const CellIterator &cell,
               CellScratch        &scratch,
               CellShare          &share) const;

    /// A vertex patch solved here: its unknowns sigma^a are the Raviart-Thomas
    /// dofs patch_positions[dofs_start ...] (as many as the layout of its
    /// solver says), and (psi_a, q_k)_K of its cells are hat_mass[0 ...],
    /// cell by cell (in hat_masses).
    struct Patch
    {
      unsigned int                       vertex;
      std::size_t                        dofs_start;
      const double                      *hat_mass;
      std::shared_ptr<const LocalSolver> solver;
    };

    static constexpr unsigned int n_vertices =
      dealii::GeometryInfo<dim>::vertices_per_cell;

    /// An owned cell's part in a patch: the patch is solved by `rank`;
    /// here it is patch number `index` with the cell at `position`,
    /// elsewhere `index` numbers the cell's right-hand side among those
    /// sent to `rank`. psi_a on the cell is the Q1 shape function of its
    /// vertex `hat` if hat < n_vertices (a = that vertex), and otherwise
    /// has the values hanging_hats[hat - n_vertices] at the vertices (a
    /// cell with hanging vertices that depend on a): 16 bytes for the four
    /// parts of almost every cell, which the reconstruction keeps per mesh.
    struct Membership
    {
      unsigned int rank;
      unsigned int index;
      unsigned int position;
      unsigned int hat;
    };

    /// The parts of the owned cell `cell` in patches.
    dealii::ArrayView<const Membership>
    parts_of(const CellIterator &cell) const;

    /// The layout shared by the patches of the connectivity of `layout`
    /// and the Piola signs of its cells, with its divergence basis and its
    /// energy products: looked up in the thread's `cache`, then in
    /// `layouts` (shared by the threads, under `mutex`), or made and added
    /// to both. `key` is scratch space.
    std::shared_ptr<const PatchLayout>
    shared_layout(const PatchLayout                      &layout,
                  const std::vector<const std::int8_t *> &signs,
                  Layouts                                &cache,
                  Layouts                                &layouts,
                  std::mutex                             &mutex,
                  std::vector<std::int64_t>              &key) const;

    /// Assemble and factorise the patch matrix of `solver` (its layout and
    /// its cells' metrics J^T J / det J set).
    void
    factorise(LocalSolver &solver) const;

    /// Compute and keep the products C = Z^T A B^+ of all patch solvers.
    void
    keep_products() const;

    /// The right-hand sides of the patches solved here, one column per
    /// field from rhs + rhs_start[p] on for patch p (zeroed): the cells'
    /// parts, computed here or received, and the vertices' constants c_a.
    void
    assemble_right_hand_sides(const Sources                  &sources,
                              const std::vector<std::size_t> &rhs_start,
                              double *const                   rhs) const;

    /// sigma[f] = the sum of the patch fluxes (the heads of the columns
    /// from rhs + rhs_start[p] on), with the fluxes of the constrained dofs
    /// and ghost entries.
    void
    sum_patch_fluxes(
      const std::vector<std::size_t>                             &rhs_start,
      const double                                               *rhs,
      const std::vector<dealii::TrilinosWrappers::MPI::Vector *> &sigma) const;

    /// Add one cell's right-hand sides (all fields; layout of reconstruct())
    /// to those of patch p, column-major from rhs on.
    void
    add_cell_share(const unsigned int p,
                   const unsigned int position,
                   const double      *values,
                   const unsigned int n_fields,
                   double *const      rhs) const;

    const dealii::Mapping<dim>   &mapping;
    dealii::FE_RaviartThomas<dim> fe_flux;
    dealii::FE_DGQ<dim>           fe_divergence;
    dealii::FE_Q<dim>             fe_hat;
    dealii::QGauss<dim>           quadrature;
    /// q^_k at the quadrature points [q n_q + k], and (div^ tau^_i, q^_k)
    /// [k n_tau + i], on the reference cell
    std::vector<double> q_reference, divergence_reference;
    /// tau^_i at the quadrature points [(q n_tau + i) dim + d], times the
    /// weight w_q
    std::vector<double> weighted_flux_reference;
    /// Number of entries of a symmetric dim x dim metric (a <= b), and the
    /// reference products int tau^_i^a tau^_j^b (+ the transposed product
    /// for a < b), [(m n_tau + i) n_tau + j] for the m-th pair (a, b)
    static constexpr unsigned int n_metric = dim * (dim + 1) / 2;
    std::vector<double>           metric_reference;
    /// The nonzero entries of the reference products, value = entry (i, j)
    /// of the m-th
    struct MetricEntry
    {
      unsigned int m, i, j;
      double       value;
    };
    std::vector<MetricEntry> metric_entries;
    /// The Piola signs s_i of the owned cells' Raviart-Thomas functions
    /// [active cell index n_tau + i], and the cells' metrics G = J^T J /
    /// det J of their mean Jacobian [active cell index n_metric + m]
    std::vector<std::int8_t> piola_signs;
    std::vector<double>      cell_metric;
    dealii::DoFHandler<dim>  dof_handler;
    dealii::IndexSet         owned_dofs, relevant_dofs;
    /// Copies the owned fluxes into ghosted ones.
    GhostedCopy        ghosted_fluxes;
    std::vector<Patch> patches;
    /// The unknowns of all patches, as local indices of flux_partitioner,
    /// and their cells' (psi_a, q_k)_K, in blocks of consecutive patches.
    std::vector<unsigned int>        patch_positions;
    std::vector<std::vector<double>> hat_masses;
    /// For every active cell c (owned ones only): its parts in patches,
    /// memberships[membership_start[c] ... membership_start[c + 1] - 1].
    std::vector<std::size_t>                    membership_start;
    std::vector<Membership>                     memberships;
    std::vector<std::array<double, n_vertices>> hanging_hats;
    /// The owned cells with parts in patches, in the order of the mesh.
    std::vector<CellIterator> cells_with_shares;
    /// Right-hand sides sent to each rank per reconstruction, and for those
    /// received from each rank, the (patch, position) they belong to.
    std::map<unsigned int, unsigned int> n_sent;
    std::map<unsigned int, std::vector<std::pair<unsigned int, unsigned int>>>
      received;
    /// Where the patch fluxes are summed: the owned dofs and, as ghosts, the
    /// others that patches solved here write (relevant ones and, with
    /// hanging nodes in parallel, a few beyond) or that the hanging node
    /// constraints of owned dofs read.
    std::shared_ptr<const dealii::Utilities::MPI::Partitioner> flux_partitioner;
    /// The hanging node constraints of the owned dofs in local indices of
    /// flux_partitioner: dof constrained_dofs[c] is the sum of w x_i over
    /// the (i, w) of constraint_entries[constraint_start[c] ...
    /// constraint_start[c + 1] - 1].
    std::vector<unsigned int>                    constrained_dofs;
    std::vector<unsigned int>                    constraint_start;
    std::vector<std::pair<unsigned int, double>> constraint_entries;
    /// The patch solvers (a few shared by all patches on uniformly refined
    /// meshes, one per patch on others), and their cells' metrics and
    /// factors, one array per mesh.
    std::vector<LocalSolver *> local_solvers;
    std::unique_ptr<double[]>  solver_storage;
    /// The reconstructions on this mesh so far, and the products C of the
    /// solvers, kept from the second on (see the .cc file).
    mutable unsigned int              n_reconstructions = 0;
    mutable std::unique_ptr<double[]> product_storage;
  };
} // namespace VI
