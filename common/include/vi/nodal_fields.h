#pragma once

#include <deal.II/base/index_set.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vector>

namespace dealii
{
  template <int dim, int spacedim>
  class DoFHandler;
} // namespace dealii

namespace VI
{
  /**
   * Storage of the unknowns X = (X1, X2, X3) of the two-membrane problems:
   * X1, X2 are the nodal values of u1h, u2h and X3 the multiplier
   * coefficients, all three attached to the nodes (scalar DoFs i) of one
   * scalar finite element. They are interleaved node by node,
   *
   *   X[3 i + alpha],  alpha = 0 (u1), 1 (u2), 2 (multiplier),
   *
   * so that the complementarity pair (X1_i - X2_i, X3_i) of node i lives on
   * the process that owns i, each process owns one contiguous range of X, and
   * the three fields are plain scalar finite element functions for assembly,
   * output and estimators.
   */
  namespace NodalFields
  {
    using dealii::types::global_dof_index;

    constexpr unsigned int n_fields = 3;

    enum Field : unsigned int
    {
      u1         = 0,
      u2         = 1,
      multiplier = 2
    };

    inline global_dof_index
    index(const global_dof_index node, const unsigned int field)
    {
      return n_fields * node + field;
    }

    /// {3 i + alpha : i in nodes, alpha = 0, 1, 2}.
    dealii::IndexSet
    system_index_set(const dealii::IndexSet &nodes);

    /**
     * Constraints on X: those of u1 and u2 (hanging nodes, Dirichlet data g1,
     * g2) for their fields, and X3 = 0 wherever u1 is constrained (boundary
     * and hanging nodes carry no multiplier).
     */
    void
    make_system_constraints(
      const dealii::AffineConstraints<double> &u1_constraints,
      const dealii::AffineConstraints<double> &u2_constraints,
      const dealii::IndexSet                  &relevant_system_indices,
      dealii::AffineConstraints<double>       &system_constraints);

    /**
     * The node at each vertex of the mesh (a Q_p node of the first field
     * component), invalid at vertices no cell of this process sees: the
     * centres of the vertex patches of the flux reconstruction.
     */
    template <int dim>
    std::vector<dealii::types::global_dof_index>
    vertex_nodes(const dealii::DoFHandler<dim, dim> &dof_handler);

    /**
     * Sparsity of the saddle-point matrix from the scalar pattern of the
     * Laplacian (rows of the locally owned nodes): the u1-u1 and u2-u2 blocks,
     * and at each owned node the coupling (u_alpha, X3) and the constraint row
     * (X3 ; u1, u2, X3).
     */
    void
    make_system_sparsity(const dealii::DynamicSparsityPattern &scalar_pattern,
                         const dealii::IndexSet               &owned_nodes,
                         dealii::DynamicSparsityPattern       &system_pattern);

    /// field_values = X_field on the locally owned nodes (no ghosts).
    void
    extract(const dealii::TrilinosWrappers::MPI::Vector &X,
            const unsigned int                           field,
            dealii::TrilinosWrappers::MPI::Vector       &field_values);

    /// X_field = field_values on the locally owned nodes.
    void
    insert(const dealii::TrilinosWrappers::MPI::Vector &field_values,
           const unsigned int                           field,
           dealii::TrilinosWrappers::MPI::Vector       &X);

    /// X1 = u1 and X2 = u2 on the locally owned nodes (X3 is left as is).
    void
    insert_displacements(const dealii::TrilinosWrappers::MPI::Vector &u1,
                         const dealii::TrilinosWrappers::MPI::Vector &u2,
                         dealii::TrilinosWrappers::MPI::Vector       &X);

    /**
     * The names the files of a program on these unknowns use everywhere
     * (`using namespace VI::NodalFields::vocabulary;`): index(node, field),
     * the field `multiplier` and n_fields.
     */
    namespace vocabulary
    {
      using NodalFields::index;
      using NodalFields::multiplier;
      using NodalFields::n_fields;
    } // namespace vocabulary
  }   // namespace NodalFields
} // namespace VI
