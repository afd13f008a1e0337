// A single-rooted premolar with enamel, dentin and pulp. Modelled in millimetres and written
// in metres (Mesh.ScalingFactor), like pen_tool.geo. The tooth's long axis is +z: the root
// apex at z = 0, the cemento-enamel junction (CEJ) near z = 14.5 mm, the cusps at z = 21.8 mm
// and the occlusal fissure between them at 21.6 mm; x is mesio-distal (crown 7 mm), y
// bucco-lingual (crown 8 mm). About 3,400 tets: coarse enough for a Cortex-M4's drilling
// step, the burr (0.7 mm) about one tet wide.
//
// Physical volumes (the mesh's region labels):
//   1 enamel: a shell on the crown, 1.5 to 1.8 mm over the cusps, 1.1 mm under the fissure,
//             about 1 mm on the sides, thinning towards the CEJ and cut off at z = 15 mm;
//   2 dentin: the body of crown and root;
//   3 pulp:   the pulp chamber in the crown and the canal down the root, closed inside.
//
// Regenerate with scripts/make-tooth.sh.
SetFactory("OpenCASCADE");
// Tight bounding boxes (from a triangulation), used below to tell the pieces apart.
Geometry.OCCBoundsUseStl = 1;

// Crown: an ellipsoid 7 x 8 x 9 mm centred 17.5 mm above the apex, with a mesio-distal
// fissure between the buccal and lingual cusps.
Sphere(1) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {3.5, 4.0, 4.5}} { Volume{1}; }
Translate {0, 0, 17.5} { Volume{1}; }
Cylinder(2) = {-5, 0, 23.6, 10, 0, 0, 2.0};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };

// Root: a tapered cone 14.5 mm long, elliptical (bucco-lingual 1.3 times mesio-distal).
Cone(4) = {0, 0, 0, 0, 0, 14.5, 0.8, 2.4};
Dilate {{0, 0, 0}, {1, 1.3, 1}} { Volume{4}; }

// The tooth: crown and root.
BooleanUnion(5) = { Volume{3}; Delete; }{ Volume{4}; Delete; };

// Dentin-enamel junction: an ellipsoid inside the crown, centred lower, that leaves 1.5 mm or
// more of enamel over the cusps and 1 mm on the sides and meets the crown's surface near the CEJ.
// Enamel is cut off at z = 15 mm, where it is about 0.2 mm thick.
Sphere(6) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {2.7, 3.1, 5.0}} { Volume{6}; }
Translate {0, 0, 15.5} { Volume{6}; }
Box(7) = {-6, -6, 15.0, 12, 12, 10};

// Pulp: a chamber in the crown and a canal that narrows towards the apex.
Sphere(8) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.0, 1.4, 1.6}} { Volume{8}; }
Translate {0, 0, 16.5} { Volume{8}; }
Cone(9) = {0, 0, 1.5, 0, 0, 14.0, 0.25, 0.6};
BooleanUnion(10) = { Volume{8}; Delete; }{ Volume{9}; Delete; };

// Enamel = (tooth above z = 15 mm) minus the dentin-enamel junction's ellipsoid.
BooleanIntersection(11) = { Volume{5}; }{ Volume{7}; Delete; };
BooleanDifference(12) = { Volume{11}; Delete; }{ Volume{6}; Delete; };

// Split the tooth by enamel and pulp so the three volumes share their faces (one conforming
// mesh). The fragments are renumbered; find them by where they lie: the enamel is the one
// piece wholly above z = 14.9 mm, the pulp the one piece within its thin box, the dentin the rest.
BooleanFragments{ Volume{5}; Delete; }{ Volume{12}; Volume{10}; Delete; }
enamel() = Volume In BoundingBox {-6, -6, 14.9, 6, 6, 25};
pulp() = Volume In BoundingBox {-1.1, -1.5, 1.4, 1.1, 1.5, 18.2};
dentin() = Volume{:};
dentin() -= enamel();
dentin() -= pulp();
If (#enamel() != 1 || #pulp() != 1 || #dentin() != 1)
  Error("tooth: expected one enamel, one pulp and one dentin volume");
EndIf
Physical Volume("enamel", 1) = enamel();
Physical Volume("dentin", 2) = dentin();
Physical Volume("pulp", 3) = pulp();

Mesh.MeshSizeMax = 1.2;
Mesh.MeshSizeMin = 0.3;
Mesh.MeshSizeFromCurvature = 4;
Mesh.Algorithm3D = 1;
Mesh.Optimize = 1;
Mesh.ScalingFactor = 0.001;
