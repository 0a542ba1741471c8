// The node-interleaved layout X[3 i + alpha] of the membrane unknowns.
#include <deal.II/base/index_set.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_vector.h>

#include <vi/contact_rows.h>
#include <vi/nodal_fields.h>

#include <gtest/gtest.h>

using namespace dealii;
namespace NodalFields = VI::NodalFields;

TEST(NodalFields, SystemIndexSetInterleavesTheFields)
{
  IndexSet nodes(10);
  nodes.add_range(0, 3);
  nodes.add_index(7);
  nodes.compress();
  const IndexSet system = NodalFields::system_index_set(nodes);
  EXPECT_EQ(system.size(), 30u);
  EXPECT_EQ(system.n_elements(), 12u);
  for (const types::global_dof_index i : {0, 1, 2, 7})
    for (unsigned int field = 0; field < 3; ++field)
      EXPECT_TRUE(system.is_element(NodalFields::index(i, field)));
  EXPECT_FALSE(system.is_element(9));
}


TEST(NodalFields, SystemConstraintsCarryDataAndRemoveTheMultiplier)
{
  IndexSet nodes(4);
  nodes.add_range(0, 4);
  AffineConstraints<double> u1(nodes), u2(nodes), system;
  u1.add_line(0);
  u1.set_inhomogeneity(0, 2.);
  u1.add_line(2);
  u1.add_entry(2, 1, 0.5);
  u1.add_entry(2, 3, 0.5);
  u1.close();
  u2.add_line(0);
  u2.set_inhomogeneity(0, -1.);
  u2.add_line(2);
  u2.add_entry(2, 1, 0.5);
  u2.add_entry(2, 3, 0.5);
  u2.close();
  NodalFields::make_system_constraints(u1,
                                       u2,
                                       NodalFields::system_index_set(nodes),
                                       system);
  EXPECT_EQ(system.get_inhomogeneity(NodalFields::index(0, 0)), 2.);
  EXPECT_EQ(system.get_inhomogeneity(NodalFields::index(0, 1)), -1.);
  EXPECT_TRUE(system.is_constrained(NodalFields::index(0, 2)));
  EXPECT_EQ(system.get_inhomogeneity(NodalFields::index(0, 2)), 0.);
  // The hanging node 2 = (node 1 + node 3)/2 within each membrane.
  const auto *entries = system.get_constraint_entries(NodalFields::index(2, 1));
  ASSERT_NE(entries, nullptr);
  ASSERT_EQ(entries->size(), 2u);
  EXPECT_EQ((*entries)[0].first, NodalFields::index(1, 1));
  EXPECT_EQ((*entries)[1].first, NodalFields::index(3, 1));
  // No multiplier where u1 is constrained.
  EXPECT_TRUE(system.is_constrained(NodalFields::index(2, 2)));
  EXPECT_EQ(system.get_constraint_entries(NodalFields::index(2, 2))->size(),
            0u);
  EXPECT_FALSE(system.is_constrained(NodalFields::index(1, 2)));
}


TEST(NodalFields, ExtractAndInsertRoundTrip)
{
  const unsigned int n = 5;
  IndexSet           nodes(n);
  nodes.add_range(0, n);
  TrilinosWrappers::MPI::Vector X(NodalFields::system_index_set(nodes),
                                  MPI_COMM_WORLD),
    field(nodes, MPI_COMM_WORLD);
  for (unsigned int i = 0; i < 3 * n; ++i)
    X(i) = i;
  X.compress(VectorOperation::insert);
  NodalFields::extract(X, NodalFields::u2, field);
  for (unsigned int i = 0; i < n; ++i)
    EXPECT_EQ(field(i), 3. * i + 1.);
  field *= -1.;
  NodalFields::insert(field, NodalFields::multiplier, X);
  for (unsigned int i = 0; i < n; ++i)
    {
      EXPECT_EQ(X(3 * i + 2), -(3. * i + 1.));
      EXPECT_EQ(X(3 * i), 3. * i);
    }
}


namespace
{
  /// Nodes 0..3; node 0 on the boundary (constrained), no contact row there.
  VI::ContactRows
  rows_of_four_nodes(IndexSet &nodes)
  {
    nodes = IndexSet(4);
    nodes.add_range(0, 4);
    AffineConstraints<double> u1(nodes);
    u1.add_line(0);
    u1.close();
    VI::ContactRows rows;
    rows.reinit(nodes, u1);
    return rows;
  }
} // namespace


TEST(ContactRows, ResidualAndJacobianRowsOfTheComplementarity)
{
  const unsigned int n = 4;
  IndexSet           nodes;
  VI::ContactRows    rows = rows_of_four_nodes(nodes);
  ASSERT_EQ(rows.nodes().size(), 3u);

  TrilinosWrappers::MPI::Vector X(NodalFields::system_index_set(nodes),
                                  MPI_COMM_WORLD),
    R(X), indicator(nodes, MPI_COMM_WORLD);
  // (u1, u2, X3) per node: 1 separated, 2 in contact, 3 violating u1 >= u2.
  const double values[4][3] = {{5, 0, 7}, {1, 0, 0}, {2, 2, 3}, {0, 1, 0}};
  for (unsigned int i = 0; i < n; ++i)
    for (unsigned int a = 0; a < 3; ++a)
      X(3 * i + a) = values[i][a];
  X.compress(VectorOperation::insert);

  const VI::ComplementarityFunction min;
  VI::ResidualNorms                 norms;
  rows.evaluate(min, X, 1., R, norms);
  const double residual = norms.complementarity;
  EXPECT_EQ(norms.smoothed_complementarity, residual); // no smoothing
  EXPECT_EQ(R(3 * 1 + 2), 0.);
  EXPECT_EQ(R(3 * 2 + 2), 0.);
  EXPECT_EQ(R(3 * 3 + 2), -1.);
  // Scaled by U = max |u| = 2 and B = max(max X3, 1) = 3: |min(-1/2, 0)|.
  EXPECT_DOUBLE_EQ(residual, 0.5);
  EXPECT_EQ(rows.contact_set(X, indicator), 2u);
  EXPECT_EQ(indicator(0), 0.);
  EXPECT_EQ(indicator(1), 0.);
  EXPECT_EQ(indicator(2), 1.);
  EXPECT_EQ(indicator(3), 1.);

  // The active set of the linearisation: the rows on the u1 = u2 branch of
  // the generalised Jacobian, nodes 2 and 3 for both C-functions.
  const VI::ComplementarityFunction fb(
    VI::ComplementarityFunction::Type::fischer_burmeister);
  std::vector<bool> active;
  for (const auto *C : {&min, &fb})
    {
      const VI::ActiveSetChange first =
        rows.linearised_active_set(*C, X, active, false);
      EXPECT_EQ(first.active, 2u);
      EXPECT_EQ(first.switched, 0u);
      EXPECT_EQ(active, (std::vector<bool>{false, true, true}));
    }
  // Node 2 leaves the contact set (negative multiplier): one switch.
  X(3 * 2 + 2) = -1.;
  X.compress(VectorOperation::insert);
  const VI::ActiveSetChange next =
    rows.linearised_active_set(min, X, active, true);
  EXPECT_EQ(next.active, 1u);
  EXPECT_EQ(next.switched, 1u);
}


TEST(ContactRows, SmoothedRowsScaleTheMultiplierByTheGapStiffness)
{
  IndexSet                      nodes;
  VI::ContactRows               rows = rows_of_four_nodes(nodes);
  TrilinosWrappers::MPI::Vector X(NodalFields::system_index_set(nodes),
                                  MPI_COMM_WORLD);
  // As above: over the contact rows U = 2 and max X3 = 3.
  const double values[4][3] = {{5, 0, 7}, {1, 0, 0}, {2, 2, 3}, {0, 1, 0}};
  for (unsigned int i = 0; i < 4; ++i)
    for (unsigned int a = 0; a < 3; ++a)
      X(3 * i + a) = values[i][a];
  X.compress(VectorOperation::insert);

  // B = max(max X3, factor k U): with k = 0.01, 200 * 0.01 * 2 = 4.
  const VI::ComplementarityFunction min;
  const double                      mu = 0.1, k = 0.01;
  ASSERT_EQ(VI::ContactRows::path_stiffness_factor, 200.);
  rows.set_smoothing(mu, X, k);
  EXPECT_DOUBLE_EQ(rows.row_value(min, 1., 0.5),
                   2. * min.smoothed_value(0.5, 0.5 / 4., mu));
  rows.set_smoothing(mu / 2, X, 1.); // frozen while the smoothing lasts
  EXPECT_DOUBLE_EQ(rows.row_value(min, 1., 0.5),
                   2. * min.smoothed_value(0.5, 0.5 / 4., mu / 2));
  rows.set_smoothing(0., X, k);
  EXPECT_EQ(rows.row_value(min, 1., 0.5), 0.5);
  // A softer gap: B = max X3 = 3.
  rows.set_smoothing(mu, X, k / 10);
  EXPECT_DOUBLE_EQ(rows.row_value(min, 1., 0.5),
                   2. * min.smoothed_value(0.5, 0.5 / 3., mu));
  rows.set_smoothing(0., X, k);
}


TEST(ContactRows, ColdStartLinearisesOnTheFreeSide)
{
  IndexSet                      nodes;
  VI::ContactRows               rows = rows_of_four_nodes(nodes);
  TrilinosWrappers::MPI::Vector X(NodalFields::system_index_set(nodes),
                                  MPI_COMM_WORLD);
  // The zero guess with boundary data at the constrained node 0 only.
  X(0) = 1.;
  X.compress(VectorOperation::insert);

  const VI::ComplementarityFunction fb(
    VI::ComplementarityFunction::Type::fischer_burmeister);
  std::vector<bool> active;
  for (const VI::ComplementarityFunction C :
       {VI::ComplementarityFunction(), fb})
    {
      // Every row at the origin: the free side, no row in the active set.
      rows.set_linearisation_point(X);
      EXPECT_EQ(rows.linearised_active_set(C, X, active, false).active, 0u);
      EXPECT_EQ(rows.row_gradient(C, 0., 0.), C.free_side_gradient_at_origin());
      // One row off the origin (a data guess): the others are at the kink's
      // contact side again.
      X(3 * 3) = 0.5;
      X.compress(VectorOperation::insert);
      rows.set_linearisation_point(X);
      EXPECT_EQ(rows.linearised_active_set(C, X, active, false).active, 2u);
      EXPECT_EQ(rows.row_gradient(C, 0., 0.), C.generalized_gradient(0., 0.));
      X(3 * 3) = 0.;
      X.compress(VectorOperation::insert);
    }
}
