// The domain of a run: the built-in geometries or a mesh file, the clamped
// part of the boundary, and the constants the estimates take from them.
#include <deal.II/base/bounding_box.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_in.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/manifold_lib.h>

#include <vi/domain.h>
#include <vi/errors.h>
#include <vi/parameters.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace VI
{
  using namespace dealii;

  Geometry
  geometry_from_name(const std::string &name)
  {
    if (name == "square")
      return Geometry::square;
    if (name == "disk")
      return Geometry::disk;
    if (name == "L-shape")
      return Geometry::L_shape;
    if (name == "square-circle")
      return Geometry::square_circle;
    if (name == "file")
      return Geometry::file;
    throw InputError(
      "Mesh/Geometry: unknown geometry <" + name +
      ">; accepted values: square|disk|L-shape|square-circle|file");
  }


  namespace
  {
    // The unit square with the circle |x - c| = R, c = (0.5, 0.5), R = 1/3,
    // as cell faces: the twelve-cell disk of radius R inside, the eight-cell
    // square with a hole of radius R outside (their eight vertices on the
    // circle coincide), shifted to c. The faces on the circle follow a
    // spherical manifold (id 0), and every cell a transfinite interpolation
    // of its faces (id 1), which keeps the cells next to the circle regular
    // under refinement on both sides; the boundary of the square is flat.
    template <int dim>
    void
    make_square_circle(Triangulation<dim> &tria)
    {
      static_assert(dim == 2, "square-circle is a two-dimensional domain");
      const double       R = 1. / 3.;
      const Point<dim>   c(0.5, 0.5);
      Triangulation<dim> disk, plate;
      GridGenerator::hyper_ball_balanced(disk, Point<dim>(), R);
      GridGenerator::hyper_cube_with_cylindrical_hole(plate, R, 0.5);
      GridGenerator::merge_triangulations(disk, plate, tria, 1e-12);
      AssertThrow(tria.n_vertices() ==
                    disk.n_vertices() + plate.n_vertices() - 8,
                  ExcInternalError("square-circle: the disk and the square "
                                   "with a hole do not share the eight "
                                   "vertices of their circle"));
      GridTools::shift(c, tria);

      tria.set_all_manifold_ids(1);
      for (const auto &cell : tria.active_cell_iterators())
        for (const unsigned int f : cell->face_indices())
          {
            const auto face = cell->face(f);
            if (face->at_boundary())
              {
                // the square's colours: 0, 1 at x = 0, 1; 2, 3 at y = 0, 1
                const Point<dim> x = face->center();
                for (unsigned int d = 0; d < dim; ++d)
                  for (const unsigned int side : {0u, 1u})
                    if (std::abs(x[d] - side) < 1e-12)
                      face->set_boundary_id(2 * d + side);
                face->set_manifold_id(numbers::flat_manifold_id);
              }
            else if (std::abs(face->vertex(0).distance(c) - R) < 1e-12 &&
                     std::abs(face->vertex(1).distance(c) - R) < 1e-12)
              face->set_manifold_id(0);
          }
      tria.set_manifold(0, SphericalManifold<dim>(c));
      TransfiniteInterpolationManifold<dim> inside;
      inside.initialize(tria);
      tria.set_manifold(1, inside);
    }
  } // namespace


  Domain::Domain(const Geometry geometry)
      : geometry_kind(geometry)
  {
    AssertThrow(geometry != Geometry::file,
                ExcMessage("A file domain is made from the parameters."));
    clamp_everywhere();
  }


  Domain::Domain(const DomainParameters &mesh)
      : geometry_kind(geometry_from_name(mesh.geometry))
  {
    if (geometry_kind == Geometry::file)
      read_mesh_file(mesh.file);
    clamp_everywhere();
  }


  Domain::Domain(const DomainParameters   &mesh,
                 const BoundaryParameters &boundary)
      : Domain(mesh)
  {
    set_clamped_part(boundary);
  }


  // The coarse mesh, made once here: a file's is checked and gives the
  // bounding box; its boundary ids, all clamped.
  void
  Domain::clamp_everywhere()
  {
    Triangulation<2> coarse;
    make_coarse_mesh(coarse);
    if (geometry_kind == Geometry::file)
      check_file_mesh(coarse);
    boundary_ids = coarse.get_boundary_ids();
    std::sort(boundary_ids.begin(), boundary_ids.end());
    clamped_ids = boundary_ids;
    friedrichs  = clamped_constant();
  }


  // The mesh file, read once into memory: the coarse meshes of the run are
  // made from that copy.
  void
  Domain::read_mesh_file(const std::string &file)
  {
    if (file.empty())
      throw InputError("Mesh/File: Mesh/Geometry = file needs a mesh file");
    file_name = file;
    std::ifstream in(file, std::ios::binary);
    if (!in)
      throw InputError("Mesh/File: cannot open the mesh file <" + file + ">");
    std::ostringstream contents;
    contents << in.rdbuf();
    file_contents = contents.str();
  }


  // Quadrilaterals of positive area with finite vertices, and their
  // bounding box.
  void
  Domain::check_file_mesh(const Triangulation<2> &coarse)
  {
    if (!coarse.all_reference_cells_are_hyper_cube())
      throw InputError("Mesh/File: <" + file_name +
                       "> has triangles; the programs need quadrilaterals");
    for (const auto &cell : coarse.active_cell_iterators())
      for (const unsigned int v : cell->vertex_indices())
        if (cell->measure() <= 0 || !std::isfinite(cell->vertex(v).norm()))
          throw InputError("Mesh/File: <" + file_name +
                           "> has a cell of nonpositive area or a vertex "
                           "that is not finite, near (" +
                           std::to_string(cell->center()[0]) + ", " +
                           std::to_string(cell->center()[1]) + ")");
    const BoundingBox<2> box = GridTools::compute_bounding_box(coarse);
    lower                    = box.get_boundary_points().first;
    upper                    = box.get_boundary_points().second;
  }


  void
  Domain::set_clamped_part(const BoundaryParameters &boundary)
  {
    if (!boundary.clamped_everywhere)
      {
        for (const types::boundary_id id : boundary.dirichlet_ids)
          if (!std::binary_search(boundary_ids.begin(), boundary_ids.end(), id))
            {
              std::string have;
              for (const types::boundary_id b : boundary_ids)
                have += (have.empty() ? "" : ", ") + std::to_string(b);
              throw InputError("Problem/Dirichlet boundary ids: the " + name() +
                               " has no boundary id " + std::to_string(id) +
                               " (it has " + have + ")");
            }
        clamped_ids = boundary.dirichlet_ids;
        std::sort(clamped_ids.begin(), clamped_ids.end());
        clamped_ids.erase(std::unique(clamped_ids.begin(), clamped_ids.end()),
                          clamped_ids.end());
      }
    if (clamped_ids.empty())
      throw InputError("Problem/Dirichlet boundary ids: the membranes are "
                       "clamped nowhere, and a membrane free on its whole "
                       "boundary is not determined by the equations (list at "
                       "least one boundary id)");
    if (boundary.friedrichs_constant > 0)
      friedrichs = boundary.friedrichs_constant;
    else if (clamped_everywhere())
      friedrichs = clamped_constant();
    else if (geometry_kind == Geometry::square ||
             geometry_kind == Geometry::square_circle)
      friedrichs = square_constant();
    else
      throw InputError(
        "Problem/Friedrichs constant: no bound of Friedrichs' constant is "
        "known for the free edges of the " +
        name() +
        "; give one (C_F with |v| <= C_F |grad v| for v vanishing on the "
        "clamped edges), or clamp the whole boundary");
  }


  // C_F = lambda_1^(-1/2), lambda_1 the first eigenvalue of -Lap on Omega
  // with zero values on its whole boundary: 2 pi^2 for the unit square,
  // j_{0,1}^2 = 5.78318... for the unit disk, 9.63972... for the L-shape
  // (Fox, Henrici, Moler 1967; Trefethen, Betcke 2006), rounded down, so
  // that the constants are rounded up. A file mesh lies in its bounding box
  // (sides L_1, L_2), whose lambda_1 = pi^2 (1/L_1^2 + 1/L_2^2) is smaller
  // (H^1_0 of the domain lies in that of the box).
  double
  Domain::clamped_constant() const
  {
    switch (geometry_kind)
      {
        case Geometry::square:
        case Geometry::square_circle:
          return 1. / std::sqrt(2. * numbers::PI * numbers::PI);
        case Geometry::disk:
          return 1. / std::sqrt(5.7831);
        case Geometry::L_shape:
          return 1. / std::sqrt(9.6397);
        case Geometry::file:
          {
            const double L1 = upper[0] - lower[0], L2 = upper[1] - lower[1];
            return 1. /
                   (numbers::PI * std::sqrt(1. / (L1 * L1) + 1. / (L2 * L2)));
          }
      }
    return 0.;
  }


  // The unit square clamped on some of its sides (ids 0, 1 at x = 0, 1 and
  // 2, 3 at y = 0, 1): the eigenfunctions separate, and the first
  // eigenvalue is the sum of those of the two directions, pi^2 with both
  // sides of a direction clamped, pi^2 / 4 with one (sin(pi x / 2)), 0 with
  // none (the constants).
  double
  Domain::square_constant() const
  {
    double lambda_1 = 0;
    for (const types::boundary_id side : {0, 2})
      {
        const unsigned int n_clamped = is_clamped(side) + is_clamped(side + 1);
        lambda_1 += n_clamped == 2 ? numbers::PI * numbers::PI :
                    n_clamped == 1 ? numbers::PI * numbers::PI / 4. :
                                     0.;
      }
    // (Rounded up a little, as the constants above.)
    return 1.0001 / std::sqrt(lambda_1);
  }


  Geometry
  Domain::geometry() const
  {
    return geometry_kind;
  }


  std::string
  Domain::name() const
  {
    switch (geometry_kind)
      {
        case Geometry::square:
          return "square";
        case Geometry::disk:
          return "disk";
        case Geometry::L_shape:
          return "L-shape";
        case Geometry::square_circle:
          return "square-circle";
        case Geometry::file:
          return "mesh " + std::filesystem::path(file_name).filename().string();
      }
    return "";
  }


  bool
  Domain::has_curved_cells() const
  {
    return geometry_kind == Geometry::disk ||
           geometry_kind == Geometry::square_circle;
  }


  template <int dim>
  void
  Domain::make_coarse_mesh(Triangulation<dim> &tria) const
  {
    switch (geometry_kind)
      {
        case Geometry::square:
          GridGenerator::hyper_cube(tria, 0., 1., /*colorize=*/true);
          break;
        case Geometry::disk:
          // Twelve cells: the boundary cells are less distorted than with
          // the five-cell hyper_ball.
          GridGenerator::hyper_ball_balanced(tria, Point<dim>(), 1.);
          break;
        case Geometry::L_shape:
          GridGenerator::hyper_L(tria, -1., 1., /*colorize=*/true);
          break;
        case Geometry::square_circle:
          make_square_circle(tria);
          break;
        case Geometry::file:
          read_coarse_mesh(tria);
          break;
      }
  }


  template <int dim>
  void
  Domain::read_coarse_mesh(Triangulation<dim> &tria) const
  {
    const std::string extension =
      std::filesystem::path(file_name).extension().string();
    try
      {
        const auto format = GridIn<dim>::parse_format(
          extension.empty() ? "" : extension.substr(1));
        GridIn<dim>        grid_in(tria);
        std::istringstream in(file_contents);
        grid_in.read(in, format);
      }
    catch (const ExceptionBase &e)
      {
        std::ostringstream info;
        e.print_info(info);
        std::string line = info.str();
        std::replace(line.begin(), line.end(), '\n', ' ');
        throw InputError("Mesh/File: cannot read the mesh <" + file_name +
                         ">: " + line);
      }
    if (tria.n_active_cells() == 0)
      throw InputError("Mesh/File: <" + file_name + "> has no cells");
  }


  template <int dim>
  std::unique_ptr<Mapping<dim>>
  Domain::make_mapping(const unsigned int fe_degree) const
  {
    return std::make_unique<MappingQ<dim>>(
      has_curved_cells() ? std::max(1u, fe_degree) : 1u);
  }


  template <int dim>
  Point<dim>
  Domain::center() const
  {
    Point<dim> center;
    if (geometry_kind == Geometry::square ||
        geometry_kind == Geometry::square_circle)
      for (unsigned int d = 0; d < dim; ++d)
        center[d] = 0.5;
    if (geometry_kind == Geometry::file)
      for (unsigned int d = 0; d < dim; ++d)
        center[d] = (lower[d] + upper[d]) / 2.;
    return center;
  }


  double
  Domain::diameter() const
  {
    switch (geometry_kind)
      {
        case Geometry::square:
        case Geometry::square_circle:
          return std::sqrt(2.);
        case Geometry::disk:
          return 2.;
        case Geometry::L_shape:
          return 2. * std::sqrt(2.);
        case Geometry::file:
          // (the diagonal of the bounding box: an upper bound)
          return lower.distance(upper);
      }
    return 0.;
  }


  double
  Domain::friedrichs_constant() const
  {
    return friedrichs;
  }


  bool
  Domain::is_clamped(const types::boundary_id id) const
  {
    return std::binary_search(clamped_ids.begin(), clamped_ids.end(), id);
  }


  bool
  Domain::clamped_everywhere() const
  {
    return clamped_ids == boundary_ids;
  }


  std::set<types::boundary_id>
  Domain::free_boundary_ids() const
  {
    std::set<types::boundary_id> free;
    for (const types::boundary_id id : boundary_ids)
      if (!is_clamped(id))
        free.insert(id);
    return free;
  }


  template void
  Domain::make_coarse_mesh(Triangulation<2> &) const;
  template Point<2>
  Domain::center() const;
  template std::unique_ptr<Mapping<2>>
  Domain::make_mapping(const unsigned int) const;
} // namespace VI
