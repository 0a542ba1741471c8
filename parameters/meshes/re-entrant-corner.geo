// The square (-1,1)^2 with a V-notch cut from its top edge down to the
// origin: the pentagon (0,0), (-1,1), (-1,-1), (1,-1), (1,1), of area 3.
// The origin is a re-entrant corner of interior angle 3 pi / 2; the two
// notch edges leave it along (-1,1)/sqrt(2) and (1,1)/sqrt(2).
// Meshed with 50 quadrilaterals in two structured blocks, the trapezoids
// left and right of the segment from (0,0) to (0,-1).
//
// Physical line tags (deal.II boundary ids): 0 the two notch edges, 1 the
// three outer edges. Physical surface tag 0 (material id 0).
//
// Regenerate with make-meshes.sh (gmsh, ASCII MSH 2.2 for deal.II's GridIn).

nx = 5;  // segments along the notch edges and the bottom edge halves
ny = 5;  // segments along the vertical edges and the middle segment

Point(1) = {0, 0, 0};    // the re-entrant corner
Point(2) = {-1, 1, 0};
Point(3) = {-1, -1, 0};
Point(4) = {0, -1, 0};
Point(5) = {1, -1, 0};
Point(6) = {1, 1, 0};

Line(1) = {1, 2};  // notch, left
Line(2) = {2, 3};  // x = -1
Line(3) = {3, 4};  // bottom, left half
Line(4) = {4, 1};  // middle segment x = 0 (interior)
Line(5) = {4, 5};  // bottom, right half
Line(6) = {5, 6};  // x = 1
Line(7) = {6, 1};  // notch, right

Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {-4, 5, 6, 7};
Plane Surface(1) = {1};
Plane Surface(2) = {2};

Transfinite Curve{1, 3, 5, 7} = nx + 1;
Transfinite Curve{2, 4, 6} = ny + 1;
Transfinite Surface{1} = {1, 2, 3, 4};
Transfinite Surface{2} = {4, 5, 6, 1};
Recombine Surface{1, 2};

Physical Curve(0) = {1, 7};        // the notch
Physical Curve(1) = {2, 3, 5, 6};  // the outer edges
Physical Surface(0) = {1, 2};

Mesh.RecombineAll = 1;
Mesh.MshFileVersion = 2.2;
