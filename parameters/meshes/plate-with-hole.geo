// The plate (0,2) x (0,1) with a circular hole of radius 0.25 centred at
// (1, 0.5), meshed with 80 quadrilaterals in six structured blocks: four
// blocks between the hole and the square (0.5,1.5) x (0,1) (an O-grid),
// one rectangle (0,0.5) x (0,1) left and one (1.5,2) x (0,1) right of it.
// The hole is the 20-gon through the mesh vertices on the circle: the
// programs attach no curved manifold to it.
//
// Physical line tags (deal.II boundary ids): 0 left edge x = 0, 1 right
// edge x = 2, 2 bottom y = 0, 3 top y = 1, 4 the hole. Physical surface
// tag 0 (material id 0).
//
// Regenerate with make-meshes.sh (gmsh, ASCII MSH 2.2 for deal.II's GridIn).

r  = 0.25;  // radius of the hole
nc = 5;     // segments per quarter of the hole and per side of the square
nr = 3;     // segments between the hole and the square
nx = 2;     // segments across the left and right rectangles

s = r / Sqrt(2);

// hole centre and the four points of the circle at 45, 135, 225, 315 degrees
Point(1) = {1, 0.5, 0};
Point(2) = {1 + s, 0.5 + s, 0};
Point(3) = {1 - s, 0.5 + s, 0};
Point(4) = {1 - s, 0.5 - s, 0};
Point(5) = {1 + s, 0.5 - s, 0};

// corners of the square (0.5,1.5) x (0,1) around the hole
Point(6) = {1.5, 1, 0};
Point(7) = {0.5, 1, 0};
Point(8) = {0.5, 0, 0};
Point(9) = {1.5, 0, 0};

// corners of the plate
Point(10) = {2, 1, 0};
Point(11) = {0, 1, 0};
Point(12) = {0, 0, 0};
Point(13) = {2, 0, 0};

// the hole, counterclockwise
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};

// from the hole to the corners of the square
Line(5) = {2, 6};
Line(6) = {3, 7};
Line(7) = {4, 8};
Line(8) = {5, 9};

// the square
Line(9)  = {6, 7};  // top
Line(10) = {7, 8};  // left, x = 0.5
Line(11) = {8, 9};  // bottom
Line(12) = {9, 6};  // right, x = 1.5

// the left rectangle
Line(13) = {7, 11};  // top
Line(14) = {11, 12}; // x = 0
Line(15) = {12, 8};  // bottom

// the right rectangle
Line(16) = {9, 13};  // bottom
Line(17) = {13, 10}; // x = 2
Line(18) = {10, 6};  // top

Curve Loop(1) = {5, 9, -6, -1};   // above the hole
Curve Loop(2) = {6, 10, -7, -2};  // left of the hole
Curve Loop(3) = {7, 11, -8, -3};  // below the hole
Curve Loop(4) = {8, 12, -5, -4};  // right of the hole
Curve Loop(5) = {-10, 13, 14, 15}; // left rectangle
Curve Loop(6) = {-12, 16, 17, 18}; // right rectangle

For i In {1:6}
  Plane Surface(i) = {i};
EndFor

Transfinite Curve{1, 2, 3, 4, 9, 10, 11, 12, 14, 17} = nc + 1;
Transfinite Curve{5, 6, 7, 8} = nr + 1;
Transfinite Curve{13, 15, 16, 18} = nx + 1;

Transfinite Surface{1} = {2, 6, 7, 3};
Transfinite Surface{2} = {3, 7, 8, 4};
Transfinite Surface{3} = {4, 8, 9, 5};
Transfinite Surface{4} = {5, 9, 6, 2};
Transfinite Surface{5} = {7, 11, 12, 8};
Transfinite Surface{6} = {9, 13, 10, 6};
Recombine Surface{1:6};

Physical Curve(0) = {14};            // left edge x = 0
Physical Curve(1) = {17};            // right edge x = 2
Physical Curve(2) = {15, 11, 16};    // bottom y = 0
Physical Curve(3) = {13, 9, 18};     // top y = 1
Physical Curve(4) = {1, 2, 3, 4};    // the hole
Physical Surface(0) = {1:6};         // the plate

Mesh.RecombineAll = 1;
Mesh.MshFileVersion = 2.2;
