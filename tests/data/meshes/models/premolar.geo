// A maxillary second premolar at real size, with enamel, dentin and pulp. Modelled in
// millimetres and written in metres (Mesh.ScalingFactor), like tooth_premolar.geo. The long
// axis is +z: the root apex at z = 0, the cemento-enamel junction (CEJ) at z = 14 mm on the
// buccal and lingual sides (1 mm higher mesially and distally), the buccal and lingual cusp
// tips at z = 22.5 mm; x is mesio-distal, y bucco-lingual (buccal +y), the central fissure
// along x between the two cusps.
//
// Dimensions (Wheeler's Dental Anatomy, Physiology and Occlusion, S. J. Nelson and M. M. Ash,
// 9th ed., Saunders Elsevier 2010, Table 1-1, maxillary second premolar): crown 8.5 mm long,
// root 14.0 mm; crown 7.0 mm mesio-distally (5.0 mm at the cervix) and 9.0 mm
// bucco-lingually (8.0 mm at the cervix); the cervical line curves 1.0 mm mesially. Two cusps
// of nearly the same height, a single root with a blunt apex, a pulp chamber with a horn
// under each cusp and one ribbon-shaped canal (same source, chapter 9).
//
// Physical volumes (the mesh's region labels):
//   1 enamel: a shell on the crown, about 1.9 mm over the cusps, 1.3 mm under the fissure,
//             about 1 mm on the sides, ending in a thin edge at the CEJ;
//   2 dentin: the body of crown and root;
//   3 pulp:   the chamber with its two horns and the canal, closed 1.5 mm above the apex.
//
// Regenerate with scripts/make-premolar.sh.
SetFactory("OpenCASCADE");
Geometry.OCCBoundsUseStl = 1;

// An ellipse at height z with half-axes a (x) and b (y), as a curve loop: a unit circle
// dilated (OpenCASCADE turns it into a B-spline).
Macro Section
  c = newc;
  Circle(c) = {0, 0, sz, 1};
  Dilate {{0, 0, sz}, {sa, sb, 1}} { Curve{c}; }
  w = newcl;
  Curve Loop(w) = {c};
Return

// The outer surface of crown and root: sections 1 mm apart (evenly, so the smooth loft
// through them does not overshoot), lofted from the apex to the occlusal table. The root
// tapers from the cervix (5 x 8 mm at z = 14) to a blunt apex; the crown bulges to its height
// of contour (7 x 9 mm at z = 18) and narrows to the occlusal table at z = 20.8.
wires[] = {};
For i In {0 : 20}
  sz = 0.8 + i;
  If (sz <= 14)
    s = (sz - 0.8) / 13.2;
    sa = 0.55 + 1.95 * s^0.6;
    sb = 0.8 + 3.2 * s^0.6;
  ElseIf (sz <= 18)
    sa = 3.5 - 1.0 * ((18 - sz) / 4)^2;
    sb = 4.5 - 0.5 * ((18 - sz) / 4)^2;
  Else
    sa = 3.5 - 0.7 * ((sz - 18) / 2.8)^2;
    sb = 4.5 - 0.8 * ((sz - 18) / 2.8)^2;
  EndIf
  Call Section;
  wires[] += w;
EndFor
body = newv;
ThruSections(body) = wires[];
// The blunt apex.
apex = newv;
Sphere(apex) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {0.5, 0.75, 0.9}} { Volume{apex}; }
Translate {0, 0, 0.9} { Volume{apex}; }
// The buccal and lingual cusps, tips at z = 22.5 mm.
cusp_b = newv;
Sphere(cusp_b) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {2.8, 1.9, 1.9}} { Volume{cusp_b}; }
Translate {0, 1.85, 20.6} { Volume{cusp_b}; }
cusp_l = newv;
Sphere(cusp_l) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {2.8, 1.9, 1.9}} { Volume{cusp_l}; }
Translate {0, -1.85, 20.6} { Volume{cusp_l}; }
tooth0 = newv;
BooleanUnion(tooth0) = { Volume{body}; Delete; }{ Volume{apex, cusp_b, cusp_l}; Delete; };
// The central fissure between the cusps, down to z = 20.75 mm, ending before the marginal
// ridges.
fissure = newv;
Sphere(fissure) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {2.3, 0.35, 0.45}} { Volume{fissure}; }
Translate {0, 0, 21.2} { Volume{fissure}; }
tooth = newv;
BooleanDifference(tooth) = { Volume{tooth0}; Delete; }{ Volume{fissure}; Delete; };

// The dentin-enamel junction (DEJ): a smaller loft with a dentin horn under each cusp. It
// lies 0.1-0.15 mm inside the outer surface at the CEJ (the enamel's thin edge) and about
// 1 mm inside at the height of contour.
dej_z[] = {13.0, 14.0, 16.0, 18.0, 19.5};
dej_a[] = {2.3, 2.38, 2.45, 2.55, 2.2};
dej_b[] = {3.75, 3.87, 3.55, 3.45, 3.1};
wires[] = {};
For i In {0 : #dej_z[] - 1}
  sz = dej_z[i]; sa = dej_a[i]; sb = dej_b[i];
  Call Section;
  wires[] += w;
EndFor
dej_body = newv;
ThruSections(dej_body) = wires[];
horn_b = newv;
Sphere(horn_b) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.7, 1.3, 1.4}} { Volume{horn_b}; }
Translate {0, 1.6, 19.3} { Volume{horn_b}; }
horn_l = newv;
Sphere(horn_l) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.7, 1.3, 1.4}} { Volume{horn_l}; }
Translate {0, -1.6, 19.3} { Volume{horn_l}; }
dej = newv;
BooleanUnion(dej) = { Volume{dej_body}; Delete; }{ Volume{horn_b, horn_l}; Delete; };

// The CEJ: enamel only above the cervical line, z = 14 mm buccally and lingually, rising
// about 1 mm on the mesial and distal surfaces (the lower arc of a cylinder along y of radius
// 4.5 mm: 1 mm up at x = 2.85 mm).
cej_r = 4.5;
above = newv;
Box(above) = {-6, -6, 14 + cej_r, 12, 12, 10};
arc = newv;
Cylinder(arc) = {0, -6, 14 + cej_r, 0, 12, 0, cej_r};
crown_side = newv;
BooleanUnion(crown_side) = { Volume{above}; Delete; }{ Volume{arc}; Delete; };

// Pulp: a chamber wide bucco-lingually, a horn under each cusp (tips at z = 18.6 mm) and a
// canal narrowing to the apex.
chamber = newv;
Sphere(chamber) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {1.0, 2.0, 1.2}} { Volume{chamber}; }
Translate {0, 0, 16.3} { Volume{chamber}; }
phorn_b = newv;
Sphere(phorn_b) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {0.55, 0.5, 1.3}} { Volume{phorn_b}; }
Translate {0, 1.3, 17.3} { Volume{phorn_b}; }
phorn_l = newv;
Sphere(phorn_l) = {0, 0, 0, 1};
Dilate {{0, 0, 0}, {0.55, 0.5, 1.3}} { Volume{phorn_l}; }
Translate {0, -1.3, 17.3} { Volume{phorn_l}; }
// The canal: sections 1 mm apart from its closed end 1.5 mm above the apex (0.24 x 0.4 mm)
// into the chamber (1.2 x 2.4 mm at z = 16.3).
wires[] = {};
For i In {0 : 14}
  sz = 1.5 + i * 14.8 / 14;
  sa = 0.12 + 0.48 * i / 14;
  sb = 0.2 + 1.0 * i / 14;
  Call Section;
  wires[] += w;
EndFor
canal = newv;
ThruSections(canal) = wires[];
pulp_all = newv;
BooleanUnion(pulp_all) = { Volume{chamber}; Delete; }{ Volume{phorn_b, phorn_l, canal}; Delete; };

// Enamel = (tooth above the CEJ) minus the DEJ's solid.
enamel0 = newv;
BooleanIntersection(enamel0) = { Volume{tooth}; }{ Volume{crown_side}; Delete; };
enamel1 = newv;
BooleanDifference(enamel1) = { Volume{enamel0}; Delete; }{ Volume{dej}; Delete; };

// Split the tooth by enamel and pulp so the three volumes share their faces (one conforming
// mesh). The fragments are renumbered; find them by where they lie: the enamel is the one
// piece wholly above z = 13.9 mm, the pulp the one piece within its box, the dentin the rest.
BooleanFragments{ Volume{tooth}; Delete; }{ Volume{enamel1}; Volume{pulp_all}; Delete; }
enamel() = Volume In BoundingBox {-6, -6, 13.9, 6, 6, 25};
pulp() = Volume In BoundingBox {-1.2, -2.2, 1.4, 1.2, 2.2, 18.8};
dentin() = Volume{:};
dentin() -= enamel();
dentin() -= pulp();
If (#enamel() != 1 || #pulp() != 1 || #dentin() != 1)
  Error("premolar: expected one enamel, one pulp and one dentin volume, got %g, %g, %g",
        #enamel(), #pulp(), #dentin());
EndIf
Physical Volume("enamel", 1) = enamel();
Physical Volume("dentin", 2) = dentin();
Physical Volume("pulp", 3) = pulp();

Mesh.MeshSizeMax = 0.6;
Mesh.MeshSizeMin = 0.1;
Mesh.MeshSizeFromCurvature = 12;
Mesh.Algorithm3D = 1;
Mesh.Optimize = 1;
Mesh.ScalingFactor = 0.001;
