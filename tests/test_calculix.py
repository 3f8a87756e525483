"""Our Abaqus .inp files solved by CalculiX (Debian's calculix-ccx), an independent consumer.

1. A bar under uniaxial tension, its hexes made here (numpy), written as .vtu with meshio and
   turned into .inp by `mchex-gpu convert`: the deck includes that file, fixes the three symmetry
   planes, pulls the free end with the consistent nodal loads of a uniform traction, and solves.
   Linear elasticity has the exact solution u = (s x / E, -nu s y / E, -nu s z / E) (s the
   stress); trilinear hexes hold a linear field exactly, so CalculiX's displacements must match it
   to solver precision. A wrong corner order (a C3D8 with a negative Jacobian) is an error there.
2. An optimised mesh of mchex-gpu (`mesh --shape sphere --repel --optimize -o inside.inp`, hexes
   moved off the grid, boundary faces curved) under a uniform pressure p on its boundary faces:
   for any solid the exact solution is the hydrostatic state, stress -p I and u = -p (1 - 2 nu) x
   / E. It is linear, so trilinear hexes hold it exactly whatever their shape (the patch test:
   with full 2 x 2 x 2 integration both the stiffness and the pressure loads on a bilinear face
   are integrated exactly), and CalculiX's displacements must match it to solver precision; the
   three nodes that remove the rigid motions are held at their exact values (printed to 13
   digits: CalculiX reads 20 characters a field). A sign or corner
   order error in the element, or a face numbered against C3D8's convention, breaks it.
3. A mesh of mchex-gpu itself (`mesh --shape rounded-box -o inside.inp`): CalculiX must accept it
   (every element of the REGION1 set, positive Jacobians) and finish a gravity load case with a
   finite displacement at every node, zero where fixed.

ctest runs this with MCHEX_GPU set to the CLI.
"""

import os
import re
import shutil
import subprocess
import tempfile
import unittest

import meshio  # Debian's python3-meshio; tests/CMakeLists.txt runs /usr/bin/python3
import numpy as np

E = 210000.0
NU = 0.3


def bar(length, nx, ny, nz):
    """A length x 1 x 1 bar of nx x ny x nz hexes, corners in VTK_HEXAHEDRON order."""
    xs, ys, zs = np.linspace(0, length, nx + 1), np.linspace(0, 1, ny + 1), np.linspace(0, 1, nz + 1)
    index = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)
    points = np.array([[x, y, z] for z in zs for y in ys for x in xs])
    hexes = []
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                hexes.append([index(i, j, k), index(i + 1, j, k), index(i + 1, j + 1, k), index(i, j + 1, k),
                              index(i, j, k + 1), index(i + 1, j, k + 1), index(i + 1, j + 1, k + 1),
                              index(i, j + 1, k + 1)])
    return points, np.array(hexes)


def node_set(name, nodes):
    lines = [f"*NSET, NSET={name}"]
    for i in range(0, len(nodes), 10):
        lines.append(",".join(str(n + 1) for n in nodes[i:i + 10]))
    return "\n".join(lines) + "\n"


def displacements(dat_text):
    """Node number -> (ux, uy, uz) from CalculiX's .dat *NODE PRINT block."""
    out = {}
    in_block = False
    for line in dat_text.splitlines():
        if "displacements" in line:
            in_block = True
            continue
        fields = line.split()
        if in_block and len(fields) == 4 and re.fullmatch(r"\d+", fields[0]):
            out[int(fields[0])] = np.array([float(v) for v in fields[1:]])
    return out


@unittest.skipUnless(shutil.which("ccx"), "CalculiX (calculix-ccx) is not installed: bash setup.sh")
class CalculixSolves(unittest.TestCase):
    def setUp(self):
        self.cli = os.environ.get("MCHEX_GPU")
        if not self.cli:
            self.skipTest("MCHEX_GPU is not set: run through ctest")
        self.tmp = tempfile.TemporaryDirectory(prefix="mchex_calculix_")
        self.addCleanup(self.tmp.cleanup)
        self.dir = self.tmp.name

    def run_cli(self, *args):
        r = subprocess.run([self.cli, *map(str, args)], cwd=self.dir, capture_output=True, text=True, timeout=600)
        self.assertEqual(r.returncode, 0, r.stderr)

    def solve(self, deck, nodes):
        # CalculiX defines no set of all nodes: one for the printed displacements.
        deck = deck.replace("*STEP\n", f"*NSET, NSET=EVERY, GENERATE\n1, {nodes}, 1\n*STEP\n", 1)
        with open(os.path.join(self.dir, "job.inp"), "w") as f:
            f.write(deck)
        r = subprocess.run(["ccx", "-i", "job"], cwd=self.dir, capture_output=True, text=True, timeout=600,
                           env=dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1"))
        output = r.stdout + r.stderr
        self.assertEqual(r.returncode, 0, output[-3000:])
        self.assertNotIn("*ERROR", output, output[-3000:])
        self.assertNotIn("*WARNING", output, output[-3000:])
        self.assertIn("Job finished", output, output[-3000:])
        with open(os.path.join(self.dir, "job.dat")) as f:
            return displacements(f.read())

    def test_bar_in_tension_matches_the_exact_solution(self):
        length, stress = 4.0, 100.0
        points, hexes = bar(length, 8, 2, 3)
        meshio.write(os.path.join(self.dir, "bar.vtu"),
                     meshio.Mesh(points, [("hexahedron", hexes)],
                                 cell_data={"region": [np.ones(len(hexes), dtype=np.int32)]}),
                     binary=True, compression=None)
        self.run_cli("convert", "bar.vtu", "bar.inp")
        with open(os.path.join(self.dir, "bar.inp")) as f:
            self.assertIn("*ELEMENT, TYPE=C3D8", f.read())

        # Consistent loads of a uniform traction on the end face: a quarter of each face's force
        # to each of its corners.
        forces = np.zeros(len(points))
        for hexa in hexes:
            face = [c for c in hexa if abs(points[c][0] - length) < 1e-12]
            if len(face) == 4:
                ys, zs = points[face][:, 1], points[face][:, 2]
                area = (ys.max() - ys.min()) * (zs.max() - zs.min())
                forces[face] += stress * area / 4
        loaded = np.flatnonzero(forces)
        self.assertAlmostEqual(forces.sum(), stress * 1.0)
        deck = ("*INCLUDE, INPUT=bar.inp\n"
                + node_set("XFIX", np.flatnonzero(points[:, 0] == 0))
                + node_set("YFIX", np.flatnonzero(points[:, 1] == 0))
                + node_set("ZFIX", np.flatnonzero(points[:, 2] == 0))
                + f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{E}, {NU}\n"
                + "*SOLID SECTION, ELSET=REGION1, MATERIAL=STEEL\n"
                + "*STEP\n*STATIC\n*BOUNDARY\nXFIX, 1, 1\nYFIX, 2, 2\nZFIX, 3, 3\n*CLOAD\n"
                + "".join(f"{n + 1}, 1, {forces[n]!r}\n" for n in loaded)
                + "*NODE PRINT, NSET=EVERY\nU\n*END STEP\n")
        u = self.solve(deck, len(points))
        self.assertEqual(sorted(u), list(range(1, len(points) + 1)))
        exact = np.column_stack([stress * points[:, 0] / E, -NU * stress * points[:, 1] / E,
                                 -NU * stress * points[:, 2] / E])
        got = np.array([u[n + 1] for n in range(len(points))])
        # The .dat prints 7 significant digits.
        np.testing.assert_allclose(got, exact, rtol=0, atol=1e-6 * np.abs(exact).max())

    def test_an_optimised_mesh_under_pressure_matches_the_exact_solution(self):
        self.run_cli("mesh", "--shape", "sphere", "--depth", 2, "--repel", "--optimize", "-o", "inside.inp",
                     "--no-fidelity", "--quiet")
        mesh = meshio.read(os.path.join(self.dir, "inside.inp"))
        points, hexes = mesh.points, mesh.cells_dict["hexahedron"]
        # Moved off the grid: most points are not on the lattice of cell corners and midpoints.
        self.assertGreater(np.count_nonzero(np.abs(points * 18 - np.round(points * 18)) > 1e-9), len(points) / 10)
        # Boundary faces (on one hex only), each as its element and C3D8 face number (Abaqus:
        # S1 1-2-3-4, S2 5-8-7-6, S3 1-5-6-2, S4 2-6-7-3, S5 3-7-8-4, S6 4-8-5-1).
        faces = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
        seen = {}
        for e, h in enumerate(hexes):
            for k, f in enumerate(faces):
                seen.setdefault(tuple(sorted(h[i] for i in f)), []).append((e, k))
        boundary = [v[0] for v in seen.values() if len(v) == 1]
        self.assertGreater(len(boundary), 100)
        pressure = 100.0
        exact = -pressure * (1 - 2 * NU) / E * points
        a = 0
        b = int(np.argmax(np.linalg.norm(points - points[a], axis=1)))
        ab = (points[b] - points[a]) / np.linalg.norm(points[b] - points[a])
        off = points - points[a]
        c = int(np.argmax(np.linalg.norm(off - np.outer(off @ ab, ab), axis=1)))
        held = "".join(f"{n + 1}, {d + 1}, {d + 1}, {exact[n, d]:.12e}\n" for n in (a, b, c) for d in range(3))
        deck = ("*INCLUDE, INPUT=inside.inp\n"
                + f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{E}, {NU}\n"
                + "*SOLID SECTION, ELSET=REGION1, MATERIAL=STEEL\n"
                + "*STEP\n*STATIC\n*BOUNDARY\n" + held + "*DLOAD\n"
                + "".join(f"{e + 1}, P{k + 1}, {pressure!r}\n" for e, k in boundary)
                + "*NODE PRINT, NSET=EVERY\nU\n*END STEP\n")
        u = self.solve(deck, len(points))
        self.assertEqual(sorted(u), list(range(1, len(points) + 1)))
        got = np.array([u[n + 1] for n in range(len(points))])
        # The .dat prints 7 significant digits.
        np.testing.assert_allclose(got, exact, rtol=0, atol=1e-6 * np.abs(exact).max())

    def test_a_mchex_mesh_solves(self):
        self.run_cli("mesh", "--shape", "rounded-box", "--depth", 2, "-o", "inside.inp", "--outside", "outside.inp",
                     "--no-fidelity", "--quiet")
        mesh = meshio.read(os.path.join(self.dir, "inside.inp"))
        points = mesh.points
        self.assertGreater(len(mesh.cells[0].data), 100)
        self.assertEqual(sorted(mesh.cell_sets), ["REGION1"])
        z0, z1 = points[:, 2].min(), points[:, 2].max()
        fixed = np.flatnonzero(points[:, 2] < z0 + 0.1 * (z1 - z0))
        self.assertGreater(len(fixed), 3)
        deck = ("*INCLUDE, INPUT=inside.inp\n" + node_set("BASE", fixed)
                + f"*MATERIAL, NAME=STEEL\n*ELASTIC\n{E}, {NU}\n*DENSITY\n7.8e-9\n"
                + "*SOLID SECTION, ELSET=REGION1, MATERIAL=STEEL\n"
                + "*STEP\n*STATIC\n*BOUNDARY\nBASE, 1, 3\n*DLOAD\nREGION1, GRAV, 9810., 0., 0., -1.\n"
                + "*NODE PRINT, NSET=EVERY\nU\n*END STEP\n")
        u = self.solve(deck, len(points))
        self.assertEqual(sorted(u), list(range(1, len(points) + 1)))
        got = np.array([u[n + 1] for n in range(len(points))])
        self.assertTrue(np.all(np.isfinite(got)))
        np.testing.assert_array_equal(got[fixed], 0)
        # Gravity pulls down: the free top sags.
        self.assertLess(got[:, 2].min(), 0)


if __name__ == "__main__":
    unittest.main()
