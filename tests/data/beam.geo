// beam.geo -- slender box cantilever for the nlmodes beam-theory test (gmsh >= 4.8).
//
// Dimensions (SI units, metres), settable with gmsh -setnumber NAME value:
//   L = 1.0   length along x, from x = 0 (clamped face) to x = L (free face)
//   b = 0.1   width along y, from y = 0 to y = b
//   h = 0.05  height along z, from z = 0 to z = h   (slenderness L/h = 20, L/b = 10)
//   h_mesh = 0.025  target element size (unstructured tetrahedra)
// The first bending mode in the z direction (about the y axis, I = b h^3 / 12) is the softest.
//
// Physical groups: Volume "beam", Surface "clamp" (x = 0), Surface "free" (x = L).
// Element order: gmsh -order 2 (TET10) or -order 1 (TET4); this file does not set it.
//
// Usage: gmsh -3 -order 2 -format msh41 tests/data/beam.geo -o beam.msh
//   TET10 at the default h_mesh: 1984 tets, 3943 nodes, 11.8k DOFs (2 elements through h);
//   -setnumber h_mesh 0.0125: 22.9k nodes, 69k DOFs; -setnumber h_mesh 0.05: 943 nodes, 2.8k DOFs.

SetFactory("OpenCASCADE");

If (!Exists(L)) L = 1.0; EndIf
If (!Exists(b)) b = 0.1; EndIf
If (!Exists(h)) h = 0.05; EndIf
If (!Exists(h_mesh)) h_mesh = 0.025; EndIf

If (L <= 0 || b <= 0 || h <= 0 || h_mesh <= 0)
  Error("beam.geo: L, b, h and h_mesh must be > 0 (got %g, %g, %g, %g)", L, b, h, h_mesh);
  Abort;
EndIf

Box(1) = {0, 0, 0, L, b, h};

eps = 1e-6 * L;
s_clamp[] = Surface In BoundingBox{-eps, -eps, -eps, eps, b + eps, h + eps};
s_free[] = Surface In BoundingBox{L - eps, -eps, -eps, L + eps, b + eps, h + eps};
If (#s_clamp[] != 1 || #s_free[] != 1)
  Error("beam.geo: expected one face at x = 0 and one at x = L, found %g and %g",
        #s_clamp[], #s_free[]);
  Abort;
EndIf

Physical Volume("beam") = {1};
Physical Surface("clamp") = {s_clamp[0]};
Physical Surface("free") = {s_free[0]};

Mesh.MeshSizeMin = h_mesh;
Mesh.MeshSizeMax = h_mesh;
