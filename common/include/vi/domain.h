#pragma once

#include <deal.II/base/point.h>
#include <deal.II/base/types.h>
#include <deal.II/fe/mapping.h>
#include <deal.II/grid/tria.h>

#include <memory>
#include <set>
#include <string>
#include <vector>

namespace VI
{
  struct DomainParameters;
  struct BoundaryParameters;

  /**
   * The domains of the membrane programs ("Mesh/Geometry"):
   * - square: (0,1)^2, the seed's domain; boundary ids 0 at x = 0, 1 at
   *   x = 1, 2 at y = 0, 3 at y = 1 (GridGenerator::hyper_cube with
   *   colorize = true);
   * - disk: the unit disk centred at the origin, with a spherical manifold
   *   on the boundary and transfinite interpolation inside, so that refined
   *   meshes follow the circle; used with a mapping of the element's degree;
   *   boundary id 0;
   * - L-shape: (-1,1)^2 without (0,1)^2, with its re-entrant corner at the
   *   origin; boundary ids 0 at x = -1, then counterclockwise 1 at y = -1,
   *   2 at x = 1, 3 at y = 0, 4 at x = 0, 5 at y = 1 (GridGenerator::hyper_L
   *   with colorize = true);
   * - square-circle: (0,1)^2 again, meshed so that the circle of radius 1/3
   *   about (0.5, 0.5) is a line of cell faces at every refinement (a
   *   spherical manifold on it, transfinite interpolation in the cells),
   *   used with a mapping of the element's degree; boundary ids as the
   *   square's. The seed tests' contact set ends on that circle and the
   *   multiplier of the jump test is discontinuous across it: on a mesh that
   *   cuts the circle, the data oscillation of the cut cells (order h^(3/2)
   *   in the estimate) ends up dominating the error of degree p >= 2
   *   (order h^p);
   * - file: the mesh of "Mesh/File" (Gmsh .msh, UCD .inp, VTK .vtk, ... as
   *   GridIn reads them), straight-sided quadrilaterals; its physical line
   *   tags are the boundary ids, its physical surface tags the material ids.
   */
  enum class Geometry
  {
    square,
    disk,
    L_shape,
    square_circle,
    file
  };

  Geometry
  geometry_from_name(const std::string &name);

  /**
   * The domain Omega of a run: its geometry, its coarse mesh, and the part
   * Gamma_D of its boundary where the membranes are clamped (u_alpha =
   * g_alpha); they are free (zero normal derivative) on the rest. With the
   * constants of Omega and Gamma_D that the estimates take: the diameter,
   * and an upper bound of Friedrichs' constant C_F, |v| <= C_F |grad v| for
   * v in H^1(Omega) vanishing on Gamma_D.
   */
  class Domain
  {
  public:
    /// A built-in geometry, clamped on its whole boundary.
    explicit Domain(const Geometry geometry);

    /**
     * From Mesh/Geometry and Mesh/File (read here once: an unreadable or
     * malformed file throws InputError) and Problem/Dirichlet boundary ids
     * and Problem/Friedrichs constant (ids the mesh does not have, an empty
     * Gamma_D, or free edges whose constant is unknown throw InputError).
     */
    Domain(const DomainParameters &mesh, const BoundaryParameters &boundary);

    /// The same, clamped on the whole boundary (for what needs the mesh only).
    explicit Domain(const DomainParameters &mesh);

    Geometry
    geometry() const;

    /// "square", ..., or "mesh " and the mesh file's name.
    std::string
    name() const;

    /// Whether cells are curved (and need a mapping of higher degree, and
    /// curved inner cells in the output).
    bool
    has_curved_cells() const;

    /// Coarse mesh of the domain (to be refined by the caller).
    template <int dim>
    void
    make_coarse_mesh(dealii::Triangulation<dim> &tria) const;

    /**
     * Mapping for the element degree p: Q1 on polygons (exact), Q_p where
     * cells are curved, so that the curves do not limit the rate.
     */
    template <int dim>
    std::unique_ptr<dealii::Mapping<dim>>
    make_mapping(const unsigned int fe_degree) const;

    /// The point the seed test cases are centred on: (0.5, 0.5), the origin,
    /// or the centre of a file mesh's bounding box.
    template <int dim>
    dealii::Point<dim>
    center() const;

    /// Diameter h_Omega of the domain (of a file mesh: the diagonal of its
    /// bounding box, an upper bound).
    double
    diameter() const;

    /// The upper bound of C_F the estimates take (see the .cc file).
    double
    friedrichs_constant() const;

    /// Whether the membranes are clamped on the faces of boundary id `id`.
    bool
    is_clamped(const dealii::types::boundary_id id) const;

    /// Whether they are clamped on the whole boundary.
    bool
    clamped_everywhere() const;

    /// The boundary ids of the mesh where they are free.
    std::set<dealii::types::boundary_id>
    free_boundary_ids() const;

  private:
    void
    clamp_everywhere();
    void
    read_mesh_file(const std::string &file);
    void
    check_file_mesh(const dealii::Triangulation<2> &coarse);
    template <int dim>
    void
    read_coarse_mesh(dealii::Triangulation<dim> &tria) const;
    void
    set_clamped_part(const BoundaryParameters &boundary);
    double
    clamped_constant() const;
    double
    square_constant() const;

    Geometry    geometry_kind;
    std::string file_name;
    std::string file_contents; ///< the mesh file, read once
    std::vector<dealii::types::boundary_id> boundary_ids; ///< of the mesh
    std::vector<dealii::types::boundary_id> clamped_ids;  ///< sorted
    dealii::Point<2> lower, upper; ///< bounding box of a file mesh
    double           friedrichs = 0;
  };
} // namespace VI
