#pragma once

#include <deal.II/base/point.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/tria.h>

#include <memory>
#include <string>

namespace VI
{
  /**
   * The domains of the membrane programs ("Mesh/Geometry"):
   * - square: (0,1)^2, the seed's domain;
   * - disk: the unit disk centred at the origin, with a spherical manifold
   *   on the boundary and transfinite interpolation inside, so that refined
   *   meshes follow the circle; used with a mapping of the element's degree;
   * - L-shape: (-1,1)^2 without (0,1)^2, with its re-entrant corner at the
   *   origin;
   * - square-circle: (0,1)^2 again, meshed so that the circle of radius 1/3
   *   about (0.5, 0.5) is a line of cell faces at every refinement (a
   *   spherical manifold on it, transfinite interpolation in the cells),
   *   used with a mapping of the element's degree. The seed tests' contact
   *   set ends on that circle and the multiplier of the jump test is
   *   discontinuous across it: on a mesh that cuts the circle, the data
   *   oscillation of the cut cells (order h^(3/2) in the estimate) ends up
   *   dominating the error of degree p >= 2 (order h^p).
   */
  enum class Geometry
  {
    square,
    disk,
    L_shape,
    square_circle
  };

  Geometry
  geometry_from_name(const std::string &name);

  /// Whether cells are curved (and need a mapping of higher degree, and
  /// curved inner cells in the output).
  bool
  has_curved_cells(const Geometry geometry);

  /// Coarse mesh of the domain (to be refined by the caller).
  template <int dim>
  void
  make_coarse_mesh(const Geometry geometry, dealii::Triangulation<dim> &tria);

  /// The point the seed test cases are centred on: (0.5, 0.5) or the origin.
  template <int dim>
  dealii::Point<dim>
  geometry_center(const Geometry geometry);

  /// Diameter h_Omega of the domain.
  double
  geometry_diameter(const Geometry geometry);

  /**
   * An upper bound of the Friedrichs constant C_F of the domain,
   * |v| <= C_F |grad v| for v in H^1_0, i.e. 1/sqrt(lambda_1) with lambda_1
   * the first Dirichlet eigenvalue of -Lap: 2 pi^2 for the unit square,
   * j_{0,1}^2 = 5.78318... for the unit disk, 9.63972... for the L-shape
   * (Fox, Henrici, Moler 1967; Trefethen, Betcke 2006); the eigenvalues are
   * rounded down, so the constants are rounded up.
   */
  double
  friedrichs_constant(const Geometry geometry);

  /**
   * Mapping for the domain and element degree p: Q1 on polygons (exact),
   * Q_p where cells are curved, so that the curves do not limit the rate.
   */
  template <int dim>
  std::unique_ptr<dealii::Mapping<dim>>
  make_mapping(const Geometry geometry, const unsigned int fe_degree);
} // namespace VI
