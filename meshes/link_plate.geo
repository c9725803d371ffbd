// Small link plate with two pin bores (SI units, metres).
// Link frame: x along the plate from bore A (at the origin) to bore B,
// plate mid-plane z = 0, thickness t along z, rounded (half-round) ends.
// Physical surfaces bore_A, bore_B name the bore surfaces; used by the
// `geo` mesh recipe (pipeline.meshing.recipes.geo_file).
SetFactory("OpenCASCADE");

L = 0.12;      // pin spacing
w = 0.03;      // plate width
t = 0.006;     // thickness
rA = 0.006;    // bore radii
rB = 0.005;

// stadium outline: a strip between the pin centres plus half-round ends
Rectangle(1) = {0, -w/2, -t/2, L, w};
Disk(2) = {0, 0, -t/2, w/2};
Disk(3) = {L, 0, -t/2, w/2};
s() = BooleanUnion{ Surface{1}; Delete; }{ Surface{2, 3}; Delete; };
v() = Extrude {0, 0, t} { Surface{s()}; };

Cylinder(10) = {0, 0, -t, 0, 0, 2*t, rA};
Cylinder(11) = {L, 0, -t, 0, 0, 2*t, rB};
BooleanDifference(20) = { Volume{v(1)}; Delete; }{ Volume{10, 11}; Delete; };

eps = 1e-6;
boreA() = Surface In BoundingBox{-rA-eps, -rA-eps, -t/2-eps, rA+eps, rA+eps, t/2+eps};
boreB() = Surface In BoundingBox{L-rB-eps, -rB-eps, -t/2-eps, L+rB+eps, rB+eps, t/2+eps};
Physical Surface("bore_A") = {boreA()};
Physical Surface("bore_B") = {boreB()};
Physical Volume("plate") = {20};
