// blade.geo -- parametric compressor blade for nlmodes (gmsh >= 4.8, OpenCASCADE kernel).
//
// A twisted, cambered, tapered blade with a NACA 4-digit section, stacked radially on a rotor,
// after the blade of Laxalde, Legrand & Pierre (ASME DETC2009-87387, Sec. 4 and Fig. 2).
//
// Coordinate convention (SI units: metres, degrees for angles):
//   * rotor axis = global x axis through the origin: point (0,0,0), direction (1,0,0);
//   * the blade is stacked radially along +z, from z = hub_radius (root face) to
//     z = hub_radius + span (tip face); both faces are planes z = const;
//   * at the root the chord lies along +y (leading edge at -y, trailing edge at +y) and the section
//     thickness along x; section k is rotated about the z stacking axis by twist_deg * (z - hub)/span
//     (linear twist, positive counter-clockwise seen from +z) and its chord varies linearly from
//     chord_root to chord_tip. Sections are stacked at the chord point stack_pos (fraction of chord
//     from the leading edge), which lies on the z axis;
//   * the radial unit vector of a point is (0, y, z) / |(0, y, z)|.
//
// Section: NACA 4-digit thickness law with the closed-trailing-edge coefficient (-0.1036), so the
// trailing edge is a sharp edge; camber line m, p (NACA "mpxx": camber = m, camber_pos = p).
// The upper (suction, +thickness) and lower (pressure) sides are interpolating splines through
// cosine-spaced stations; ThruSections (OCC) lofts n_sections such sections into the solid.
//
// Physical groups (names are the contract with the nlmodes mesh reader):
//   Physical Volume("blade")    the solid;
//   Physical Surface("root")    the clamped hub face z = hub_radius;
//   Physical Surface("tip")     the tip face z = hub_radius + span;
//   Physical Point("tip_edge")  the contact nodes: n_contact geometry points on the suction-side edge
//                               of the tip face, from the leading edge (included) to the trailing edge
//                               (included), evenly spaced in chord fraction x_i = i/(n_contact-1).
//                               They are mesh vertices (the volume is fragmented with them), and
//                               point elements carry one node each, so the group holds exactly
//                               n_contact nodes for order 1 and order 2 meshes alike. The order of
//                               the point entities in the .msh is NOT leading to trailing edge (the
//                               two corner vertices come first): sort the nodes by their coordinate
//                               along the tip chord, (p - p_LE) . (p_TE - p_LE), to get that order.
//
// Parameters (override with gmsh -setnumber NAME value):
//   hub_radius  0.25    m     radius of the root face
//   span        0.12    m     radial height of the blade
//   chord_root  0.065   m     chord at the root
//   chord_tip   0.050   m     chord at the tip
//   thickness   0.07    -     max thickness / chord (NACA "xx" / 100)
//   camber      0.04    -     max camber / chord (NACA "m" / 100)
//   camber_pos  0.4     -     chordwise position of max camber (NACA "p" / 10), in (0, 1)
//   twist_deg   35      deg   twist from root to tip, in (-180, 180)
//   stack_pos   0.45    -     stacking point (fraction of chord from the leading edge)
//   mesh_size   0.002   m     target element size (about 2-3 TET10 through the max thickness)
//   order       2       -     element order: 1 = TET4, 2 = TET10 (sets Mesh.ElementOrder)
//   n_contact   24      -     number of contact nodes on the tip edge (24 in the paper), >= 2
//   n_sections  6       -     number of lofted sections, >= 2
//   n_stations  24      -     cosine stations per side of a section, >= 8 (24: the splines
//                             deviate from the exact NACA section by < 3e-4 chord)
//
// Usage:
//   gmsh -3 -format msh41 meshes/blade.geo -o blade.msh                       (TET10, 31.4k nodes,
//                                                                               94k DOFs, ~15 s)
//   gmsh -3 -format msh41 -setnumber mesh_size 0.012 meshes/blade.geo -o c.msh (coarse, for tests:
//                                                                               2.7k nodes, ~8k DOFs)
//   gmsh -3 -format msh41 -setnumber order 1 meshes/blade.geo -o tet4.msh     (TET4)
// Note: the file sets Mesh.ElementOrder = order, which overrides the command-line `-order`; as
// `-order 1` cannot be told apart from no `-order`, a TET4 mesh needs `-setnumber order 1`
// (`-order 2` is honoured). Invalid parameters print an Error and gmsh exits with status 1.

SetFactory("OpenCASCADE");
// Curving the TET10 mid-edge nodes onto the lofted surfaces projects each of them onto its surface.
// OpenCASCADE's projection builds a sampling grid of the BSpline surface at every call: 5.4 s of
// the 6.1 s this file took to mesh (gmsh 4.8.4, default blade). gmsh's own closest-point search
// takes 0.7 s; on the default blade the nodes it places lie within 4.8e-6 m of OpenCASCADE's
// (2 mm elements) and the first 8 clamped frequencies move by at most 6e-7 relative, against a
// discretization error of about 5e-4 (docs/BENCHMARKS.md, session 11).
Geometry.OCCUseGenericClosestPoint = 1;

If (!Exists(hub_radius)) hub_radius = 0.25; EndIf
If (!Exists(span)) span = 0.12; EndIf
If (!Exists(chord_root)) chord_root = 0.065; EndIf
If (!Exists(chord_tip)) chord_tip = 0.050; EndIf
If (!Exists(thickness)) thickness = 0.07; EndIf
If (!Exists(camber)) camber = 0.04; EndIf
If (!Exists(camber_pos)) camber_pos = 0.4; EndIf
If (!Exists(twist_deg)) twist_deg = 35; EndIf
If (!Exists(stack_pos)) stack_pos = 0.45; EndIf
If (!Exists(mesh_size)) mesh_size = 0.002; EndIf
If (!Exists(order))
  order = 2;
  If (Mesh.ElementOrder > 1) order = Mesh.ElementOrder; EndIf
EndIf
If (!Exists(n_contact)) n_contact = 24; EndIf
If (!Exists(n_sections)) n_sections = 6; EndIf
If (!Exists(n_stations)) n_stations = 24; EndIf

// ---- parameter checks ---------------------------------------------------------------------------
bad = 0;
If (hub_radius <= 0 || span <= 0 || chord_root <= 0 || chord_tip <= 0)
  Error("blade.geo: hub_radius, span, chord_root, chord_tip must be > 0 (got %g, %g, %g, %g)",
        hub_radius, span, chord_root, chord_tip);
  bad = 1;
EndIf
If (thickness <= 0 || thickness > 0.4)
  Error("blade.geo: thickness (fraction of chord) must be in (0, 0.4], got %g", thickness);
  bad = 1;
EndIf
If (camber < 0 || camber > 0.1 || camber_pos <= 0 || camber_pos >= 1)
  Error("blade.geo: camber must be in [0, 0.1] and camber_pos in (0, 1), got %g, %g",
        camber, camber_pos);
  bad = 1;
EndIf
If (Fabs(twist_deg) >= 180)
  Error("blade.geo: |twist_deg| must be < 180, got %g", twist_deg);
  bad = 1;
EndIf
If (mesh_size <= 0)
  Error("blade.geo: mesh_size must be > 0 (metres), got %g", mesh_size);
  bad = 1;
EndIf
If (order != 1 && order != 2)
  Error("blade.geo: order must be 1 (TET4) or 2 (TET10), got %g", order);
  bad = 1;
EndIf
If (n_contact < 2 || n_contact != Round(n_contact))
  Error("blade.geo: n_contact must be an integer >= 2, got %g", n_contact);
  bad = 1;
EndIf
If (n_sections < 2 || n_sections != Round(n_sections) || n_stations < 8 ||
    n_stations != Round(n_stations))
  Error("blade.geo: n_sections must be an integer >= 2 and n_stations >= 8, got %g, %g",
        n_sections, n_stations);
  bad = 1;
EndIf
If (bad)
  Abort;
EndIf

// ---- chord stations -----------------------------------------------------------------------------
// Lower side: cosine stations s_j = (1 - cos(pi j / J)) / 2, j = 1..J-1 (clustered at both edges).
// Upper side: the same, merged with the interior contact stations x_i = i / (n_contact - 1); a
// cosine station closer than 0.4 local spacings to a contact station is dropped, so that the spline
// stays smooth. Contact points are thus interpolation points of the tip section's upper spline and
// lie exactly on the tip edge.
J = n_stations;
st_lo[] = {};
st_up[] = {};
s_prev = 0;
For j In {1:J}
  s = 0.5 * (1 - Cos(Pi * j / J));
  s_next = 0.5 * (1 - Cos(Pi * (j + 1) / J));
  For i In {1:n_contact-2}
    xc = i / (n_contact - 1);
    If (xc >= s_prev && xc < s)
      st_up[] += xc;
    EndIf
  EndFor
  If (j < J)
    st_lo[] += s;
    keep = 1;
    h_loc = s - s_prev;
    If (s_next - s < h_loc) h_loc = s_next - s; EndIf
    For i In {1:n_contact-2}
      xc = i / (n_contact - 1);
      If (Fabs(s - xc) < 0.4 * h_loc) keep = 0; EndIf
    EndFor
    If (keep) st_up[] += s; EndIf
  EndIf
  s_prev = s;
EndFor

// ---- NACA 4-digit point ---------------------------------------------------------------------------
// In: xs (chord fraction), side (+1 upper, -1 lower). Out: pu, pv (chord fractions: along the chord
// from the leading edge, and along the thickness direction).
Macro NacaPoint
  yt = 5 * thickness * (0.2969 * Sqrt(xs) - 0.1260 * xs - 0.3516 * xs^2 + 0.2843 * xs^3
                        - 0.1036 * xs^4);
  If (camber > 0)
    If (xs < camber_pos)
      yc = camber / camber_pos^2 * (2 * camber_pos * xs - xs^2);
      dyc = 2 * camber / camber_pos^2 * (camber_pos - xs);
    Else
      yc = camber / (1 - camber_pos)^2 * ((1 - 2 * camber_pos) + 2 * camber_pos * xs - xs^2);
      dyc = 2 * camber / (1 - camber_pos)^2 * (camber_pos - xs);
    EndIf
  Else
    yc = 0;
    dyc = 0;
  EndIf
  phi = Atan(dyc);
  pu = xs - side * yt * Sin(phi);
  pv = yc + side * yt * Cos(phi);
Return

// In: f (span fraction, 0 at the root, 1 at the tip). Out: r (radius), c (chord), th (twist, rad).
Macro SectionParams
  r = hub_radius + f * span;
  c = chord_root + f * (chord_tip - chord_root);
  th = twist_deg * Pi / 180 * f;
Return

// In: pu, pv (chord fractions), c (chord), th (twist, rad), r (radius). Out: gx, gy, gz.
Macro SectionToGlobal
  lu = (pu - stack_pos) * c;
  lv = pv * c;
  gx = lv * Cos(th) - lu * Sin(th);
  gy = lv * Sin(th) + lu * Cos(th);
  gz = r;
Return

// ---- sections and loft ----------------------------------------------------------------------------
n_up = #st_up[];
n_lo = #st_lo[];
wires[] = {};
interp_pts[] = {};
For k In {0:n_sections-1}
  f = k / (n_sections - 1);
  Call SectionParams;

  pu = 0;
  pv = 0;
  Call SectionToGlobal;
  p_le = newp; Point(p_le) = {gx, gy, gz};
  pu = 1;
  pv = 0;
  Call SectionToGlobal;
  p_te = newp; Point(p_te) = {gx, gy, gz};

  up[] = {};
  side = 1;
  For j In {0:n_up-1}
    xs = st_up[j];
    Call NacaPoint;
    Call SectionToGlobal;
    p = newp; Point(p) = {gx, gy, gz};
    up[] += p;
  EndFor
  lo[] = {};
  side = -1;
  For j In {0:n_lo-1}
    xs = st_lo[j];
    Call NacaPoint;
    Call SectionToGlobal;
    p = newp; Point(p) = {gx, gy, gz};
    lo[] += p;
  EndFor
  c_up = newc; Spline(c_up) = {p_le, up[], p_te};
  c_lo = newc; Spline(c_lo) = {p_le, lo[], p_te};
  w = newll; Wire(w) = {c_up, c_lo};
  wires[] += w;
  interp_pts[] += {up[], lo[]};
EndFor

v_loft = newv;
ThruSections(v_loft) = {wires[]};

// The spline interpolation points are free vertices now: remove them (the contact points are
// recreated below at the same coordinates; the section wires are removed further down).
Delete { Point{interp_pts[]}; }

// ---- contact points on the tip edge ---------------------------------------------------------------
// Coordinates of contact point i (chord fraction i/(n_contact-1) on the upper side of the tip
// section): identical arithmetic to the tip section's spline interpolation points.
f = 1;
Call SectionParams;
side = 1;
cx[] = {}; cy[] = {}; cz[] = {};
For i In {0:n_contact-1}
  xs = i / (n_contact - 1);
  If (i == 0)
    pu = 0;
    pv = 0;
  EndIf
  If (i == n_contact - 1)
    pu = 1;
    pv = 0;
  EndIf
  If (i > 0 && i < n_contact - 1)
    Call NacaPoint;
  EndIf
  Call SectionToGlobal;
  cx[] += gx; cy[] += gy; cz[] += gz;
EndFor
new_pts[] = {};
For i In {1:n_contact-2}
  p = newp; Point(p) = {cx[i], cy[i], cz[i]};
  new_pts[] += p;
EndFor
If (n_contact > 2)
  BooleanFragments{ Volume{v_loft}; Delete; }{ Point{new_pts[]}; Delete; }
EndIf

// Drop anything that is not part of the solid (the section wires and their end points).
all_v[] = Volume{:};
If (#all_v[] != 1)
  Error("blade.geo: expected one volume after the loft, got %g", #all_v[]);
  Abort;
EndIf
bnd_s[] = Boundary{ Volume{all_v[0]}; };
bnd_c[] = Unique(Abs(Boundary{ Surface{bnd_s[]}; }));
all_c[] = Curve{:};
For i In {0:#all_c[]-1}
  used = 0;
  For j In {0:#bnd_c[]-1}
    If (all_c[i] == bnd_c[j]) used = 1; EndIf
  EndFor
  If (!used) Recursive Delete { Curve{all_c[i]}; } EndIf
EndFor

// ---- physical groups ------------------------------------------------------------------------------
eps_p = 1e-5 * chord_tip;
tip_pts[] = {};
For i In {0:n_contact-1}
  q[] = Point In BoundingBox{cx[i] - eps_p, cy[i] - eps_p, cz[i] - eps_p,
                             cx[i] + eps_p, cy[i] + eps_p, cz[i] + eps_p};
  If (#q[] != 1)
    Error("blade.geo: contact point %g at (%g, %g, %g) matched %g geometry points, expected 1",
          i, cx[i], cy[i], cz[i], #q[]);
    Abort;
  EndIf
  tip_pts[] += q[0];
EndFor

big = 10 * (hub_radius + span + chord_root);
eps_z = 1e-4 * span;
s_root[] = Surface In BoundingBox{-big, -big, hub_radius - eps_z, big, big, hub_radius + eps_z};
s_tip[] = Surface In BoundingBox{-big, -big, hub_radius + span - eps_z,
                                 big, big, hub_radius + span + eps_z};
If (#s_root[] != 1 || #s_tip[] != 1)
  Error("blade.geo: expected one root and one tip face, found %g and %g", #s_root[], #s_tip[]);
  Abort;
EndIf

Physical Volume("blade") = {all_v[0]};
Physical Surface("root") = {s_root[0]};
Physical Surface("tip") = {s_tip[0]};
Physical Point("tip_edge") = {tip_pts[]};

// ---- mesh -----------------------------------------------------------------------------------------
// The contact points force edges of length h_c = chord_tip / (n_contact - 1) along the suction side
// of the tip face. Coarse meshes (mesh_size >> h_c) would then put slivers next to the tip's leading
// and trailing edges, which fold once their mid-edge nodes are snapped to the curved surfaces. So
// the size is h_c on the tip face's boundary curves and grows linearly with the distance d from them,
// h_c + (mesh_size - h_c) d / mesh_size, back to mesh_size at d = mesh_size; fine meshes
// (mesh_size <= h_c) are unaffected.
h_c = chord_tip / (n_contact - 1);
If (h_c < mesh_size)
  tip_curves[] = Unique(Abs(Boundary{ Surface{s_tip[0]}; }));
  Field[1] = Distance;
  Field[1].CurvesList = {tip_curves[]};
  Field[1].NumPointsPerCurve = 100;
  Field[2] = Threshold;
  Field[2].InField = 1;
  Field[2].SizeMin = h_c;
  Field[2].SizeMax = mesh_size;
  Field[2].DistMin = 0;
  Field[2].DistMax = mesh_size;
  Background Field = 2;
EndIf

Mesh.MeshSizeMax = mesh_size;
// No curvature-based refinement: the leading-edge nose (radius ~1.1 (t/c)^2 c, 0.3 mm) is carried by
// the curved TET10 faces; refining it to its radius would multiply the element count for a region
// that hardly changes the low frequencies.
Mesh.MeshSizeFromCurvature = 0;
Mesh.ElementOrder = order;
// High-order optimization of the elements whose scaled Jacobian falls below
// Mesh.HighOrderThresholdMin (0.1) after the mid-edge nodes are snapped to the curved surfaces
// (no cost when there is none; it untangles any inverted TET10 next to the thin edges).
Mesh.HighOrderOptimize = 1;
Printf("blade.geo: hub %g m, span %g m, chord %g -> %g m, t/c %g, twist %g deg, mesh_size %g m, order %g, %g contact nodes",
       hub_radius, span, chord_root, chord_tip, thickness, twist_deg, mesh_size, order, n_contact);
